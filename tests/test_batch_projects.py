"""``track PROJECT --all``: every trial of a Pose2Sim session (cascading Config.toml) or of an anipose
project with nested sessions, locally or on Dask, finished ones skipped, one summary.

The projects are written from the rendered walk (4 cameras, a few frames each); the trackers run
with 1 layer of 20 particles from a standing pose at the voxels (no multi-start, no body fit, no
limb search: what is tested is which trials run with which settings, not the tracking).
"""

import shutil

import numpy as np
import pytest
from project_fixture import make_project

from voxelmocap.cli import main
from voxelmocap.config import config_from_toml, config_to_toml, with_overrides
from voxelmocap.io.humaneva import Dataset
from voxelmocap.io.results import read_result
from voxelmocap.run.batch import BatchItem, dataset_items, result_is_done
from voxelmocap.run.pipeline import track_sequence

CAMERAS = ["C1", "C2", "C3", "BW1"]
QUICK = """[init]
method = "voxels"
body = "voxels"
multistart_frames = 0
limb_sweep = false
"""


@pytest.fixture(scope="module")
def settings(tmp_path_factory):
    path = tmp_path_factory.mktemp("config") / "quick.toml"
    path.write_text(QUICK)
    return ["--config", str(path), "--layers", "1", "--particles", "20", "--voxel-size", "40",
            "--no-progress"]


def _config():
    return with_overrides(config_from_toml(QUICK), **{
        "filter.layers": 1, "filter.particles": 20, "measurement.voxel_size": 40.0})


@pytest.fixture(scope="module")
def walk_seq(walk_dataset):
    return Dataset(walk_dataset).sequence("S1", "Walking_1")


@pytest.fixture(scope="module")
def session(walk_seq, tmp_path_factory):
    """A Pose2Sim session as Demo_Batch is laid out: calibration/ and Config.toml at the top,
    Trial_1 … Trial_3 with their videos (and empty-scene videos), Trial_1 with its own
    Config.toml; Trial_3 excluded from batches."""
    root = tmp_path_factory.mktemp("p2s") / "Session"
    for trial, frames in (("Trial_1", [1, 2, 3, 4]), ("Trial_2", [4, 5, 6]),
                          ("Trial_3", [7, 8])):
        make_project(walk_seq, root / trial, "pose2sim", CAMERAS, frames=frames)
        if trial == "Trial_1":
            shutil.move(root / trial / "calibration", root / "calibration")
        else:
            shutil.rmtree(root / trial / "calibration")
    # the trial's [project] table is merged into the session's: its frame_rate stays 50 Hz
    (root / "Config.toml").write_text("[project]\nframe_rate = 50\nframe_range = 'auto'\n"
                                      "exclude_from_batch = ['Trial_3']\n")
    (root / "Trial_1" / "Config.toml").write_text("[project]\nframe_range = [1, 3]\n")
    return root


def test_a_pose2sim_session_with_trials(session, settings, tmp_path, capsys):
    assert dataset_items(session) == [BatchItem("Trial_1", "Trial_1"),
                                      BatchItem("Trial_2", "Trial_2")]
    run = tmp_path / "run"
    assert main(["track", str(session), "--all", "--out", str(run), *settings]) == 0
    out = capsys.readouterr().out
    assert "left out ([project] exclude_from_batch): Trial_3" in out
    assert "2 sequences, 0 already done, 2 to track" in out
    assert "summary: 2 done, 0 skipped, 0 failed" in out
    assert "  done:    Trial_1\n  done:    Trial_2\n" in out
    one, two = (read_result(run / t / f"{t}.h5") for t in ("Trial_1", "Trial_2"))
    # Trial_1's frame_range [1, 3]: video frames 1 and 2 from 0, i.e. frames 2 and 3 here
    np.testing.assert_array_equal(one.frames, [2, 3])
    np.testing.assert_array_equal(two.frames, [1, 2, 3])
    assert one.attrs["frame_rate"] == two.attrs["frame_rate"] == 50.0
    assert one.attrs["complete"] and two.attrs["complete"]
    assert not (run / "Trial_3").exists()
    # the batch ran the tracking one trial's command runs (the same frames, bit-identical)
    alone = track_sequence(session, None, None, tmp_path / "alone", trial="Trial_1",
                           config=_config(), seed=0, progress=False)
    np.testing.assert_array_equal(one.state, read_result(alone.result_path).state)
    assert result_is_done(run / "Trial_1" / "Trial_1.h5", config_to_toml(_config()), 0)

    stamps = {p: p.stat().st_mtime_ns for p in run.rglob("*.h5")}
    assert main(["track", str(session), "--all", "--out", str(run), *settings]) == 0
    out = capsys.readouterr().out
    assert "2 sequences, 2 already done, 0 to track" in out
    assert "summary: 0 done, 2 skipped, 0 failed" in out
    assert "  skipped: Trial_1 (complete)\n  skipped: Trial_2 (complete)" in out
    assert {p: p.stat().st_mtime_ns for p in run.rglob("*.h5")} == stamps


def test_a_bad_trial_setting_fails_that_trial_only(session, settings, tmp_path, capsys):
    root = tmp_path / "Session"
    shutil.copytree(session, root)
    (root / "Trial_2" / "Config.toml").write_text("[project]\nframe_range = [30, 40]\n")
    run = tmp_path / "run"
    assert main(["track", str(root), "--all", "--out", str(run), *settings]) == 1
    out = capsys.readouterr().out
    assert "summary: 1 done, 0 skipped, 1 failed" in out
    assert (f"  failed:  Trial_2: {root / 'Trial_2' / 'Config.toml'}: [project] frame_range "
            "[30, 40] starts after the 3 synchronised frames of Trial_2") in out
    assert read_result(run / "Trial_1" / "Trial_1.h5").attrs["complete"]


def test_anipose_nested_sessions_on_dask(walk_seq, settings, tmp_path, capsys):
    root = tmp_path / "experiment"
    for session, frames in (("subject1/day1", [1, 2, 3]), ("subject2/day1", [5, 6, 7])):
        make_project(walk_seq, root / session, "anipose", CAMERAS, frames=frames)
        (root / session / "config.toml").unlink()
        if not (root / "calibration").exists():
            shutil.move(root / session / "calibration", root / "calibration")
        else:
            shutil.rmtree(root / session / "calibration")
    (root / "config.toml").write_text("nesting = 2\n[triangulation]\ncam_regex = '-cam([A-Z])'\n")
    names = ["subject1_day1_walk", "subject2_day1_walk"]  # both sessions hold a trial 'walk'
    assert dataset_items(root) == [BatchItem(n, n) for n in names]
    run = tmp_path / "run"
    assert main(["track", str(root), "--all", "--out", str(run), "--workers", "2",
                 *settings]) == 0
    assert "summary: 2 done, 0 skipped, 0 failed" in capsys.readouterr().out
    for name in names:
        result = read_result(run / name / f"{name}.h5")
        assert result.attrs["complete"] and len(result) == 3
        assert (run / name / f"{name}.bvh").exists()
    log = (run / "voxelmocap.log").read_text()
    assert f"[{names[1]}] {names[1]}/{names[1]}: 3 frames" in log  # written by the worker
    # in this process, the same project: both skipped
    assert main(["track", str(root), "--all", "--out", str(run), *settings]) == 0
    assert "summary: 0 done, 2 skipped, 0 failed" in capsys.readouterr().out


def test_all_refuses_a_trial(session, tmp_path, capsys):
    assert main(["track", str(session), "--all", "--trial", "Trial_1", "--out",
                 str(tmp_path / "r")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--trial: not with --all" in err[0]
    assert not (tmp_path / "r").exists()
