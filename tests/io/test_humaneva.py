import shutil
import subprocess
import sys

import numpy as np
import pytest
from humaneva_fixture import decode_frame_number, make_tiny_dataset

from voxelmocap.cli import main
from voxelmocap.errors import InputError
from voxelmocap.io.humaneva import Dataset


def test_discovery_and_sync(tiny_dataset):
    ds = Dataset(tiny_dataset)
    assert ds.subjects == ["S1"]
    assert ds.sequences("S1") == ["Walking_1"]
    seq = ds.sequence("s1", "walking_1")
    assert seq.camera_names == ["C1", "C2", "BW1"]
    assert seq.starts == {"C1": 6, "C2": 8, "BW1": 7}
    assert seq.n_frames == 12
    np.testing.assert_array_equal(seq.frame_numbers, np.arange(1, 13))
    assert seq.rig.names == ["C1", "C2", "BW1"]
    assert seq.ground_truth().endpoints.shape == (12, 20, 3)
    assert len(seq.background_paths("BW1")) == 1


def test_frames_show_the_synchronised_video_frame(tiny_dataset):
    seq = Dataset(tiny_dataset).sequence("S1", "Walking_1")
    leads = {"C1": 5, "C2": 7, "BW1": 6}
    for F, images in seq.frames([1, 4, 5, 12]):
        for cam, image in images.items():
            assert decode_frame_number(image) == leads[cam] + F
        assert images["C1"].shape == (480, 640, 3)
        assert images["BW1"].shape == (480, 640)
    # random access agrees with sequential decoding
    np.testing.assert_array_equal(seq.read_frame(9)["C2"], dict(seq.frames([9]))[9]["C2"])


def test_numbered_image_folder_and_camera_subset(tmp_path):
    root = make_tiny_dataset(tmp_path / "d", image_folder_camera="C2")
    seq = Dataset(root).sequence("S1", "Walking_1", cameras=["C2", "bw1"])
    assert seq.camera_names == ["C2", "BW1"]
    images = seq.read_frame(3)
    assert decode_frame_number(images["C2"]) == 7 + 3


def test_case_insensitive_folders(tmp_path):
    root = make_tiny_dataset(tmp_path / "d")
    (root / "S1" / "Calibration_Data").rename(root / "S1" / "Calibration_DATA")
    seq = Dataset(root).sequence("S1", "Walking_1")
    assert seq.rig.names == ["C1", "C2", "BW1"]


def test_bad_inputs(tmp_path):
    root = make_tiny_dataset(tmp_path / "d")
    ds = Dataset(root)
    with pytest.raises(InputError, match="unknown sequence"):
        ds.sequence("S1", "Jog_1")
    with pytest.raises(InputError, match="unknown subject"):
        ds.sequence("S7", "Walking_1")
    with pytest.raises(InputError, match=r"^--cameras: unknown camera 'C3' \(S1/Walking_1 has "
                                         r"C1, C2, BW1\)$"):
        ds.sequence("S1", "Walking_1", cameras=["C1", "C3"])
    seq = ds.sequence("S1", "Walking_1")
    with pytest.raises(InputError, match="outside the synchronised range"):
        list(seq.frames([13]))
    (root / "S1" / "Image_Data" / "Walking_1_(C1).avi").unlink()
    with pytest.raises(InputError, match=r"Walking_1_\(C1\).avi: video not found"):
        _ = Dataset(root).sequence("S1", "Walking_1").n_frames


def run_cli(*args):
    return subprocess.run([sys.executable, "-m", "voxelmocap.cli", *args], capture_output=True,
                          text=True)


def test_info_lists_and_validates(tiny_dataset, capsys):
    assert main(["info", str(tiny_dataset)]) == 0
    out = capsys.readouterr().out
    assert "Walking_1: 12 synchronised frames, cameras C1, C2, BW1" in out
    assert "start    8" in out and "all files read are valid" in out


@pytest.mark.parametrize(
    ("damage", "message"),
    [
        (lambda r: (r / "S1/Calibration_Data/C2.cal").write_text("1 2 3"), "C2.cal: expected 22"),
        (lambda r: (r / "S1/Sync_Data/Walking_1_(BW1).ofs").write_text("1\n2\n"),
         "expected 3 numbers"),
        (lambda r: (r / "S1/Image_Data/Walking_1_(C2).avi").write_bytes(b"not a video"),
         "cannot open video"),
        (lambda r: (r / "S1/Mocap_Data/Walking_1.xml").write_text("<SEQUENCE>"), "malformed XML"),
        (lambda r: (r / "S1/Calibration_Data/sizes.toml").write_text('C1 = [320, 240]\n'
                                                                     'C2 = [640, 480]\n'
                                                                     'BW1 = [640, 480]\n'),
         "differs from the calibration"),
        (lambda r: shutil.rmtree(r / "S1"), "no subject folders"),
    ],
)
def test_info_bad_input_is_one_line_exit_2(tmp_path, damage, message):
    root = make_tiny_dataset(tmp_path / "d")
    damage(root)
    result = run_cli("info", str(root))
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert message in lines[0]
    assert "Traceback" not in result.stderr


def test_a_camera_without_sync_file_is_reported_not_dropped(tmp_path, capsys):
    root = make_tiny_dataset(tmp_path / "d", cameras=("C1", "C2", "C3", "BW1"), leads=(5, 7, 4, 6))
    ofs = root / "S1" / "Sync_Data" / "Walking_1_(C3).ofs"
    ofs.unlink()
    seq = Dataset(root).sequence("S1", "Walking_1")
    assert seq.camera_names == ["C1", "C2", "BW1"] and seq.unsynced_cameras == ["C3"]
    assert seq.problems == [f"camera C3 has a video but no sync file {ofs}: not used"]
    # asked for by name, it is refused naming the missing file (not "unknown camera")
    with pytest.raises(InputError, match=r"Walking_1_\(C3\)\.ofs: sync file not found: camera C3"):
        Dataset(root).sequence("S1", "Walking_1", cameras=["c3", "C1"])
    # info lists it as a problem of that camera and exits 1
    assert main(["info", str(root)]) == 1
    out = capsys.readouterr().out
    assert f"      problem: camera C3 has a video but no sync file {ofs}: not used" in out
    assert "1 problem(s) leave data unused" in out and not out.rstrip().endswith("are valid")
    # dump names the cameras it uses and warns about the one it cannot
    assert main(["dump", str(root), "--subject", "S1", "--sequence", "Walking_1", "--frames", "1:1",
                 "--voxel-size", "100", "--no-progress",
                 "--out", str(tmp_path / "v.h5")]) == 0
    out = capsys.readouterr().out
    assert f"warning: camera C3 has a video but no sync file {ofs}: not used" in out
    assert "cameras C1,C2,BW1," in out


def test_negative_image_start_is_refused(tmp_path):
    root = make_tiny_dataset(tmp_path / "d")
    ofs = root / "S1" / "Sync_Data" / "Walking_1_(BW1).ofs"
    ofs.write_text("-5\n1\n2\n")
    with pytest.raises(InputError, match=r"Walking_1_\(BW1\)\.ofs: im_st .* negative, got -5"):
        Dataset(root).sequence("S1", "Walking_1")
    result = run_cli("info", str(root))
    assert result.returncode == 2 and "must not be negative" in result.stderr
    # not used, it is reported and left out of the timeline instead of moving it
    seq = Dataset(root).sequence("S1", "Walking_1", cameras=["C1", "C2"])
    assert seq.starts == {"C1": 6, "C2": 8}
    assert len(seq.problems) == 1 and seq.problems[0].startswith("camera BW1 (not used): ")


def test_camera_subset_keeps_the_full_timeline(tmp_path):
    from voxelmocap.io.humaneva import sync_starts, write_ofs

    root = make_tiny_dataset(tmp_path / "d")
    ofs = {"C1": (14, 5, 1.0), "C2": (15, 5, 1.0), "BW1": (13.3, 5, 1.1)}
    for cam, values in ofs.items():
        write_ofs(root / "S1" / "Sync_Data" / f"Walking_1_({cam}).ofs", *values)
    full, _, _ = sync_starts(ofs)
    alone, _, _ = sync_starts({"BW1": ofs["BW1"]})
    assert full["BW1"] != alone["BW1"]  # the case where a per-subset timeline goes wrong
    ds = Dataset(root)
    assert ds.sequence("S1", "Walking_1", cameras=["BW1"]).starts == {"BW1": full["BW1"]}
    assert ds.sequence("S1", "Walking_1", cameras=["C2", "C1"]).starts == {
        "C1": full["C1"], "C2": full["C2"]}
    with pytest.raises(InputError, match="no camera names"):
        ds.sequence("S1", "Walking_1", cameras=[" "])


def test_image_folder_gap_is_an_error_not_a_shift(tmp_path):
    # refused when the folder is opened (issue 36: not when a run reaches the frame), never a
    # silent shift of the later frames
    root = make_tiny_dataset(tmp_path / "d", image_folder_camera="C2")
    folder = root / "S1" / "Image_Data" / "Walking_1_(C2)"
    (folder / "frame_00010.png").unlink()  # video frame 10 = synchronised frame 3
    with pytest.raises(InputError, match="no image file with counter 10"):
        Dataset(root).sequence("S1", "Walking_1", cameras=["C2"]).read_frame(4)


def test_negative_frame_range_gets_its_own_message(tiny_dataset, tmp_path, capsys):
    code = main(["track", str(tiny_dataset), "--subject", "S1", "--sequence", "Walking_1",
                 "--frames", "-5:3", "--out", str(tmp_path / "run"), "--no-progress"])
    err = capsys.readouterr().err
    assert code == 2
    assert err.strip().splitlines() == [err.strip()]  # one line, no argparse usage
    assert "frame -5 is outside the available frames" in err
    assert not (tmp_path / "run").exists() or not any((tmp_path / "run").rglob("*.h5"))
