"""``voxelmocap dump`` and ``voxelmocap view`` on a tiny HumanEva-layout data set."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from humaneva_fixture import _write_avi, frame_image, make_tiny_dataset

from voxelmocap.cli import main
from voxelmocap.io.calibration import read_rig
from voxelmocap.io.voxels import VoxelDump
from voxelmocap.measure.carving import Carver
from voxelmocap.measure.surface import smooth_surface, surface_voxels


@pytest.fixture(scope="module")
def dumped(tmp_path_factory):
    root = tmp_path_factory.mktemp("dump")
    data = make_tiny_dataset(root / "data")
    out = root / "vox.h5"
    rc = main(["dump", str(data), "--subject", "S1", "--sequence", "Walking_1", "--frames", "2:4",
               "--out", str(out), "--masks", "--ply", str(root / "ply"), "--voxel-size", "50",
               "--min-views", "1", "--no-progress"])
    assert rc == 0
    return root, out


def test_dump_contents_are_consistent(dumped):
    root, out = dumped
    with VoxelDump(out) as dump:
        assert dump.frames.tolist() == [2, 3, 4]
        assert dump.camera_names == ["C1", "C2", "BW1"]
        assert dump.grid.voxel_size == 50.0
        assert dump.attrs["subject"] == "S1" and dump.attrs["sequence"] == "Walking_1"
        assert "min_views = 1" in dump.attrs["config"]
        carver = Carver(dump.cameras(), dump.grid)
        for fr in dump.frames:
            masks = dump.masks(fr)
            assert masks.shape == (3, 480, 640) and masks.any()
            occ = dump.occupancy(fr)
            assert occ.any()
            # the stored volumes are what the stored masks carve into, and their surface maps
            assert np.array_equal(occ, carver.carve(masks, min_views=1))
            assert np.array_equal(dump.surface(fr), surface_voxels(occ))
            np.testing.assert_array_equal(dump.smoothed(fr), smooth_surface(surface_voxels(occ)))
    assert sorted(p.name for p in (root / "ply").iterdir()) == [
        "frame_00002.ply", "frame_00003.ply", "frame_00004.ply"]


def test_view_writes_png_headless(dumped, monkeypatch, capsys):
    root, out = dumped
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    assert main(["view", str(out), "--frame", "3"]) == 0
    png = root / "vox_frame3.png"
    assert png.exists() and f"wrote {png}" in capsys.readouterr().out
    img = cv2.imread(str(png))
    assert img is not None and img.shape[0] > 300 and img.shape[1] > 600
    assert main(["view", str(out), "--volume", "surface", "--out", str(root / "s.png")]) == 0
    assert (root / "s.png").exists()


def _fails(args, capsys, message):
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and message in err, err


def test_bad_input_is_one_line(dumped, tmp_path, capsys):
    root, out = dumped
    junk = tmp_path / "junk.h5"
    junk.write_bytes(b"\x89HDF\r\n\x1a\n" + b"garbage" * 50)
    _fails(["view", str(junk)], capsys, "not a readable HDF5 file")
    _fails(["view", str(tmp_path / "none.h5")], capsys, "voxel dump not found")
    _fails(["view", str(out), "--frame", "9"], capsys, "frame 9 is not in vox.h5")
    data = root / "data"
    _fails(["dump", str(data), "--subject", "S1", "--sequence", "Walking_1", "--frames", "5:99",
            "--out", str(tmp_path / "x.h5"), "--no-progress"], capsys, "--frames")
    _fails(["dump", str(data), "--subject", "S1", "--sequence", "Walking_1",
            "--out", str(tmp_path / "x.txt"), "--no-progress"], capsys, "expected an .h5")
    _fails(["dump", str(data), "--subject", "S1", "--sequence", "Walking_1", "--min-views", "9",
            "--out", str(tmp_path / "x.h5"), "--no-progress"], capsys, "min_views")
    assert not (tmp_path / "x.h5").exists()


def _files(folder):
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


def test_view_out_folder_receives_the_png(dumped, capsys):
    root, out = dumped
    folder = root / "views" / "deeper"  # created, parents too
    assert main(["view", str(out), "--frame", "4", "--png", "--out", f"{folder}/"]) == 0
    png = folder / "vox_frame4.png"
    assert png.is_file() and f"wrote {png}" in capsys.readouterr().out
    assert cv2.imread(str(png)) is not None
    assert _files(folder) == ["vox_frame4.png"]  # no temporary left
    # a second frame lands beside it
    assert main(["view", str(out), "--frame", "2", "--png", "--out", str(folder)]) == 0
    assert _files(folder) == ["vox_frame2.png", "vox_frame4.png"]


def test_view_and_dump_refuse_unwritable_outputs(dumped, tmp_path, capsys):
    root, out = dumped
    (tmp_path / "plain").write_text("x")
    (tmp_path / "folder.h5").mkdir()
    before = _files(tmp_path)
    _fails(["view", str(out), "--png", "--out", str(tmp_path / "plain" / "v")], capsys,
           "cannot create the output folder")
    _fails(["view", str(out), "--png", "--out", str(tmp_path / "plain")], capsys,
           "exists and is not a folder")
    _fails(["view", str(out), "--png", "--out", str(tmp_path / ("n" * 300 + ".png"))], capsys,
           "cannot write here")
    data = root / "data"
    _fails(["dump", str(data), "--subject", "S1", "--sequence", "Walking_1", "--frames", "2:3",
            "--out", str(tmp_path / "folder.h5"), "--no-progress"], capsys, "is a folder")
    _fails(["dump", str(data), "--subject", "S1", "--sequence", "Walking_1", "--frames", "2:3",
            "--out", str(tmp_path / "plain" / "x.h5"), "--no-progress"], capsys,
           "exists and is not a folder")
    assert _files(tmp_path) == before  # no .partial file anywhere


def test_black_camera_and_empty_frame_are_named_once(tmp_path, capsys):
    """Sync frame 3 shows no one in any camera; C2's video is black from sync frame 4 on."""
    leads = (5, 7, 6)
    data = make_tiny_dataset(tmp_path / "data", leads=leads, n_frames=8)
    for cam, lead in zip(("C1", "C2", "BW1"), leads, strict=True):
        images = []
        for k in range(1, lead + 8 + 1):
            sync = k - lead
            img = frame_image(cam, k)
            if sync == 3:
                img = np.full_like(img, 40)  # the background: nobody in view
            elif cam == "C2" and sync >= 4:
                img = np.zeros_like(img)
            images.append(img)
        _write_avi(data / "S1" / "Image_Data" / f"Walking_1_({cam}).avi", images)
    out = tmp_path / "vox.h5"
    assert main(["dump", str(data), "--subject", "S1", "--sequence", "Walking_1",
                 "--frames", "2:6", "--out", str(out), "--masks", "--voxel-size", "50",
                 "--no-progress"]) == 0
    lines = capsys.readouterr().out.splitlines()
    said = [line for line in lines if "C2" in line and "black" in line]
    assert said == ["camera C2, frame 4: the image is black; it is left out of the carving of "
                    "this and any later such frame"]
    assert [line for line in lines if "no person" in line and "frame 3" in line]
    assert any(line.startswith("warning:") and "camera C2 left out of 3 frame(s): 4, 5, 6" in line
               and "frame(s) with every silhouette empty" in line and ": 3;" in line
               for line in lines)
    with VoxelDump(out) as dump:
        assert not dump.occupancy(3).any()
        rig = read_rig(data / "S1" / "Calibration_Data", names=["C1", "BW1"])
        for fr in (4, 5, 6):
            masks = dump.masks(fr)
            # C2's all-black frame is left out: the occupancy is what C1 and BW1 alone carve
            expected = Carver(list(rig), dump.grid).carve(masks[[0, 2]])
            assert expected.any() and np.array_equal(dump.occupancy(fr), expected)


def test_ffmpeg_messages_do_not_precede_the_error_line(tmp_path):
    """A damaged video: FFmpeg's own stderr lines ("[mjpeg @ …] overread 8") are silenced, so
    the command's one line is all the user sees (a fresh process: FFmpeg reads its log level
    once, at the first video opened)."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    import voxelmocap

    data = make_tiny_dataset(tmp_path / "data", n_frames=5)
    video = data / "S1" / "Image_Data" / "Walking_1_(C1).avi"
    raw = bytearray(video.read_bytes())
    for k in range(len(raw) // 3, len(raw) - 2000, 131):
        raw[k] = 0xFF
    video.write_bytes(bytes(raw))
    env = {k: v for k, v in os.environ.items() if not k.startswith("OPENCV_")}
    env["PYTHONPATH"] = str(Path(voxelmocap.__file__).resolve().parents[1])
    proc = subprocess.run(
        [sys.executable, "-m", "voxelmocap.cli", "dump", str(data), "--subject", "S1",
         "--sequence", "Walking_1", "--out", str(tmp_path / "v.h5"), "--min-views", "1",
         "--no-progress"], capture_output=True, text=True, env=env, check=False)
    assert proc.returncode == 2
    lines = proc.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"voxelmocap dump: error: {video}: "), lines
    assert sorted(p.name for p in tmp_path.iterdir()) == ["data"]
