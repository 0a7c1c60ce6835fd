"""A project's cascading configuration: Pose2Sim's merge rule, frame range and rate, batch lists,
anipose's nesting."""

import shutil
from pathlib import Path

import numpy as np
import pytest
from project_fixture import renamed, write_frames

from voxelmocap.camera import Rig
from voxelmocap.errors import InputError
from voxelmocap.io.calibration import read_rig, write_calibration_toml
from voxelmocap.io.project import Project
from voxelmocap.io.project_config import merge_configs, trial_config
from voxelmocap.io.sequence import detect_layout, open_sequence
from voxelmocap.synth import default_rig_path

#: The three Config.toml files of Pose2Sim 0.10.49's Demo_Batch, copied unchanged (tests/data/README.md)
DEMO_BATCH_CONFIGS = Path(__file__).resolve().parents[1] / "data" / "pose2sim_demo_batch"


def _rig(n=2) -> Rig:
    return read_rig(default_rig_path(), names=["C1", "C2", "C3", "C4"][:n])


def _images(n, size=(640, 480)):
    w, h = size
    return [np.full((h, w, 3), 40 + 10 * k, np.uint8) for k in range(n)]


def test_merge_follows_pose2sims_recursive_update():
    # the example of Pose2Sim's recursive_update docstring
    base = {"key": {"key_1": "val_1", "key_2": "val_2"}}
    assert merge_configs(base, {"key": {"key_1": "val_1_new"}}) == {
        "key": {"key_1": "val_1_new", "key_2": "val_2"}}
    assert base == {"key": {"key_1": "val_1", "key_2": "val_2"}}  # not modified
    # deeper tables merge too; lists and scalars replace; a table replaces a scalar and back
    session = {"project": {"frame_rate": 25, "frame_range": "all", "exclude_from_batch": ["a"]},
               "calibration": {"convert": {"qualisys": {"binning_factor": 1}, "other": 3}},
               "x": 1, "y": {"z": 2}}
    trial = {"project": {"frame_range": [10, 20], "exclude_from_batch": []},
             "calibration": {"convert": {"qualisys": {"binning_factor": 2}}},
             "x": {"table": True}, "y": 5}
    assert merge_configs(session, trial) == {
        "project": {"frame_rate": 25, "frame_range": [10, 20], "exclude_from_batch": []},
        "calibration": {"convert": {"qualisys": {"binning_factor": 2}, "other": 3}},
        "x": {"table": True}, "y": 5}


def _p2s_session(root: Path, configs: dict[str, str], trials=("Trial_1", "Trial_2"), n=4):
    """A Pose2Sim session: calibration/ at the top, a videos/ folder per trial, Config.toml files
    given as ``{relative folder: text}``."""
    rig = renamed(_rig(), {"C1": "cam01", "C2": "cam02"})
    (root / "calibration").mkdir(parents=True)
    write_calibration_toml(rig, root / "calibration" / "Calib.toml", translation_scale=1000.0)
    for trial in trials:
        for cam in ("cam01", "cam02"):
            write_frames(root / trial / "videos" / cam, _images(n), 60.0, "mp4")
    for folder, text in configs.items():
        (root / folder / "Config.toml").write_text(text)
    return root


def test_trial_settings_cascade_from_the_session(tmp_path):
    root = _p2s_session(tmp_path / "session", {
        ".": "[project]\nframe_rate = 25\nframe_range = 'all'\nexclude_from_batch = "
             "['Trial_3']\n[pose]\nmode = 'balanced'\n",
        "Trial_1": "[project]\nframe_range = [1, 3]\n",
        "Trial_2": "[pose]\nmode = 'lightweight'\n"}, trials=("Trial_1", "Trial_2", "Trial_3"))
    project = Project(root)
    assert detect_layout(root) == "pose2sim"
    assert list(project.trials) == ["Trial_1", "Trial_2", "Trial_3"]
    one = project.sequence("Trial_1")
    # the trial's [project] table merged into the session's: frame_rate kept, frame_range set
    assert one.frame_rate == 25.0
    np.testing.assert_array_equal(one.frame_numbers, [2, 3])
    assert [f for f, _ in one.frames()] == [2, 3]
    assert any("frames 2..3 of 4" in n and "Trial_1/Config.toml" in n for n in one.notes)
    assert any("frame rate 25 Hz from" in n and "(the videos state 60 Hz)" in n for n in one.notes)
    two = project.sequence("Trial_2")
    np.testing.assert_array_equal(two.frame_numbers, [1, 2, 3, 4])
    assert two.frame_rate == 25.0 and two.config.get("pose", "mode") == "lightweight"
    kept, left_out = project.batch_trials()
    assert [t.name for t in kept] == ["Trial_1", "Trial_2"] and left_out == ["Trial_3"]
    # a trial opened on its own inherits its session's Config.toml, as in Pose2Sim
    alone = open_sequence(root / "Trial_1")
    assert alone.frame_rate == 25.0 and list(alone.frame_numbers) == [2, 3]


def test_frame_range_past_the_end_and_bad_settings(tmp_path):
    root = _p2s_session(tmp_path / "s", {".": "[project]\nframe_range = [2, 10]\n"}, n=4)
    seq = Project(root).sequence("Trial_1")
    np.testing.assert_array_equal(seq.frame_numbers, [3, 4])
    assert any("the videos end at frame 4" in n for n in seq.notes)
    for text, message in (("frame_range = [4, 10]", "starts after the 4 synchronised frames"),
                          ("frame_range = [5, 2]", "frame_range must be 'auto', 'all' or"),
                          ("frame_range = 'some'", "frame_range must be"),
                          ("frame_rate = -3", "frame_rate must be 'auto' or a positive"),
                          ("frame_rate = 'fast'", "frame_rate must be")):
        (root / "Trial_2" / "Config.toml").write_text(f"[project]\n{text}\n")
        project = Project(root)
        with pytest.raises(InputError, match=message) as err:
            _ = project.sequence("Trial_2").rig
        assert str(err.value).startswith(str(root / "Trial_2" / "Config.toml"))
        # the other trial is unaffected
        assert list(project.sequence("Trial_1").frame_numbers) == [3, 4]
    (root / "Trial_2" / "Config.toml").write_text("[project\n")
    project = Project(root)  # listing does not read a trial's configuration
    assert [t.name for t in project.batch_trials()[0]] == ["Trial_1", "Trial_2"]
    with pytest.raises(InputError, match="invalid TOML"):
        project.sequence("Trial_2")


def test_anipose_nesting_says_how_deep_the_sessions_lie(tmp_path):
    rig = renamed(_rig(), {"C1": "A", "C2": "B"})
    root = tmp_path / "experiment"
    (root / "calibration").mkdir(parents=True)
    write_calibration_toml(rig, root / "calibration" / "calibration.toml")
    sessions = ["mouse1/day1/arena", "mouse1/day2/arena", "mouse2/day1/arena"]
    for k, session in enumerate(sessions):
        for cam in "AB":
            write_frames(root / session / "videos-raw" / f"trial{k}-cam{cam}", _images(2), 30.0,
                         "mp4")
    # three levels down: not found without nesting (two levels are searched)
    with pytest.raises(InputError, match="not a Pose2Sim"):
        detect_layout(root)
    (root / "config.toml").write_text("nesting = 3\n[triangulation]\ncam_regex = '-cam([A-Z])'\n")
    project = Project(root)
    assert project.kind == "anipose"
    assert list(project.trials) == ["trial0", "trial1", "trial2"]
    assert project.sequence("trial1").trial_info.folder == root / "mouse1" / "day2" / "arena"
    # the calibration is found going up from the session, as anipose looks for it
    assert project.sequence("trial2").trial_info.calibration == (
        root / "calibration" / "calibration.toml")
    (root / "config.toml").write_text("nesting = 2\n")
    with pytest.raises(InputError, match="not a Pose2Sim, anipose"):
        Project(root)  # no session two levels down
    (root / "config.toml").write_text("nesting = -1\n")
    assert list(Project(root).trials) == ["trial0", "trial1", "trial2"]
    (root / "config.toml").write_text("nesting = 'deep'\n")
    with pytest.raises(InputError, match="nesting must be an integer"):
        Project(root)


def test_pose2sims_demo_batch(tmp_path):
    """Demo_Batch's own Config.toml files (session, Trial_1 all comments, Trial_2 overriding a
    few keys) in a session of rendered videos: the cascade as Pose2Sim's recursive_update."""
    root = _p2s_session(tmp_path / "Demo_Batch", {})
    for folder in (".", "Trial_1", "Trial_2"):
        shutil.copyfile(DEMO_BATCH_CONFIGS / folder / "Config.toml", root / folder / "Config.toml")
    project = Project(root)
    kept, left_out = project.batch_trials()
    assert [t.name for t in kept] == ["Trial_1", "Trial_2"] and left_out == []
    session = trial_config(root, root).values
    one = project.config(root / "Trial_1")
    two = project.config(root / "Trial_2")
    assert one.values == session  # Trial_1's Config.toml is all comments
    # Trial_2 overrides three [project] keys and four [synchronization] keys, keeps the rest
    assert two.get("project", "multi_person") is True
    assert two.get("project", "participant_mass") == [70.0, 63.5]
    assert two.get("project", "frame_rate") == "auto" == session["project"]["frame_rate"]
    assert two.get("synchronization", "synchronization_gui") is True
    assert two.get("synchronization", "filter_cutoff") == session["synchronization"][
        "filter_cutoff"]
    assert two.get("pose") == session["pose"]
    seq = project.sequence("Trial_2")
    assert seq.frame_rate == 60.0 and len(seq.frame_numbers) == seq.n_frames  # the videos' rate
    assert any("multi_person = true" in n for n in seq.notes)


def test_wrong_types_in_any_file_of_the_cascade_name_that_file(tmp_path):
    """Issue 36's type checks hold for the cascade of issue 35: a table of the wrong type in a
    trial's Config.toml is one line naming that file (not the session's), the other trial is
    unaffected, and the same value in the session's file names the session's."""
    root = _p2s_session(tmp_path / "s", {".": "[project]\nframe_rate = 25\n"})
    for text, table in (("project = 5", "[project]"), ("calibration = 'x'", "[calibration]"),
                        ("[calibration]\nconvert = 'qualisys'", "[calibration.convert]"),
                        ("[calibration.convert]\nqualisys = [1]",
                         "[calibration.convert.qualisys]"),
                        ("triangulation = 5", "[triangulation]")):
        (root / "Trial_2" / "Config.toml").write_text(text + "\n")
        project = Project(root)
        with pytest.raises(InputError) as err:
            project.sequence("Trial_2")
        assert str(err.value) == (f"{root / 'Trial_2' / 'Config.toml'}: {table} must be a "
                                  f"table, got {err.value.problem.split('got ')[1]}")
        assert project.sequence("Trial_1").frame_rate == 25.0
    (root / "Trial_2" / "Config.toml").unlink()
    (root / "Config.toml").write_text("[project]\nframe_rate = 25\n[calibration]\nconvert = 3\n")
    with pytest.raises(InputError, match=r"\[calibration.convert\] must be a table") as err:
        Project(root).sequence("Trial_1")
    assert str(err.value).startswith(f"{root / 'Config.toml'}: ")


def test_a_sessions_cam_regex_goes_through_the_safe_regex(tmp_path):
    """anipose: a session's own config.toml overrides the root's cam_regex (issue 35), and that
    pattern meets issue 36's guard: nested quantifiers are refused naming the session's file;
    a safe one groups the session's videos by it."""
    rig = renamed(_rig(), {"C1": "A", "C2": "B"})
    root = tmp_path / "experiment"
    (root / "calibration").mkdir(parents=True)
    write_calibration_toml(rig, root / "calibration" / "calibration.toml")
    for cam in "AB":
        write_frames(root / "day1" / "videos-raw" / f"walk_cam{cam}", _images(2), 30.0, "mp4")
    (root / "config.toml").write_text("nesting = 1\n[triangulation]\ncam_regex = '-cam([A-Z])'\n")
    session_config = root / "day1" / "config.toml"
    session_config.write_text("[triangulation]\ncam_regex = '^(a|aa)*_cam([A-Z])'\n")
    with pytest.raises(InputError, match="nested quantifiers") as err:
        Project(root)
    assert str(err.value).startswith(f"{session_config}: cam_regex ")
    session_config.write_text("[triangulation]\ncam_regex = '_cam([A-Z])'\n")
    project = Project(root)
    assert list(project.trials) == ["walk"]
    assert list(project.trials["walk"].videos) == ["A", "B"]
