"""``voxelmocap dump`` and ``voxelmocap view`` on a tiny HumanEva-layout data set."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from humaneva_fixture import make_tiny_dataset

from voxelmocap.carving import Carver
from voxelmocap.cli import main
from voxelmocap.io.voxels import VoxelDump
from voxelmocap.surface import smooth_surface, surface_voxels


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
