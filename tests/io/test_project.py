"""Pose2Sim / anipose / EasyMocap projects: discovery, camera matching, sizes, trials, bad input."""

import dataclasses
from pathlib import Path

import cv2
import numpy as np
import pytest
from humaneva_fixture import make_tiny_dataset
from project_fixture import make_project, qca_rig, renamed, write_frames

from voxelmocap.errors import InputError
from voxelmocap.io.calibration import read_rig, write_calibration_toml
from voxelmocap.io.humaneva import Dataset
from voxelmocap.io.project import Project
from voxelmocap.io.project_checks import match_cameras
from voxelmocap.io.sequence import detect_layout, open_sequence
from voxelmocap.synth import default_rig_path

CAMERAS = ["C1", "C2", "BW1"]


def _points():
    return np.random.default_rng(4).uniform([-1500, -1500, 0], [1500, 1500, 2000], (300, 3))


@pytest.fixture(scope="module")
def walk_seq(walk_dataset):
    return Dataset(walk_dataset).sequence("S1", "Walking_1")


@pytest.mark.parametrize(("layout", "sizes"), [("pose2sim", True), ("pose2sim-qca", True),
                                               ("anipose", True), ("easymocap", True),
                                               ("easymocap", False)])
def test_layouts_open_like_the_humaneva_layout(walk_seq, tmp_path, layout, sizes):
    root, names = make_project(walk_seq, tmp_path / "proj", layout, CAMERAS, sizes=sizes)
    assert detect_layout(root) == layout.split("-")[0]
    seq = open_sequence(root)
    assert seq.camera_names == [names[c] for c in CAMERAS]
    expected = walk_seq.rig.select(CAMERAS)
    if layout == "pose2sim-qca":  # a .qca.txt holds no k3 and no skew
        expected = qca_rig(expected)
    for cam in CAMERAS:
        got = seq.rig[names[cam]]
        assert got.size == expected[cam].size
        np.testing.assert_allclose(got.project(_points()), expected[cam].project(_points()),
                                   atol=1e-6)
    assert seq.n_frames == walk_seq.n_frames and seq.frame_rate == walk_seq.frame_rate
    assert seq.ground_truth() is None and seq.body_file is None
    assert seq.subject == seq.name == ("walk" if layout == "anipose" else "proj")
    # mp4 is lossy: the frames are the HumanEva frames up to compression
    images = seq.read_frame(4)
    truth = walk_seq.read_frame(4)
    for cam in CAMERAS:
        a = images[names[cam]].astype(float)
        b = truth[cam].astype(float)
        b = b if b.ndim == 3 else np.repeat(b[..., None], 3, axis=2)
        assert a.shape == b.shape and np.abs(a - b).mean() < 6.0
    assert all(len(seq.background_paths(names[c])) == 1 for c in CAMERAS)
    if not sizes:
        assert any("states no image size" in n for n in seq.notes)


def test_camera_matching_rules():
    notes = []
    assert match_cameras(["cam_1", "cam_2"], ["cam02", "cam01"], notes=notes)[0] == {
        "cam_1": "cam01", "cam_2": "cam02"}
    assert "ignoring case, separators and leading zeros" in notes[0]
    notes = []
    assert match_cameras(["cam01", "cam02"], ["cam02_img", "cam01_img"], notes=notes)[0] == {
        "cam01": "cam01_img", "cam02": "cam02_img"}
    notes = []
    pairs, left_c, left_v = match_cameras(["A", "B", "C"], ["left", "mid", "right"], notes=notes)
    assert pairs == {"A": "left", "B": "mid", "C": "right"} and "natural order" in notes[0]
    pairs, left_c, left_v = match_cameras(["cam1", "cam2", "cam3"], ["cam1", "cam2", "cam4"],
                                          notes=[])
    assert pairs == {"cam1": "cam1", "cam2": "cam2"} and left_c == ["cam3"] and left_v == ["cam4"]
    # natural order: cam2 before cam10
    assert match_cameras(["x2", "x10"], ["v10", "v2"], notes=[])[0] == {"x2": "v2", "x10": "v10"}


# ---------------------------------------------------------------------- small projects
def _rig(n=3):
    return read_rig(default_rig_path()).select(["C1", "C2", "C3"][:n])


def _images(size, n=3, seed=0):
    rng = np.random.default_rng(seed)
    return [rng.integers(0, 256, (size[1], size[0], 3), dtype=np.uint8) for _ in range(n)]


def _pose2sim(root: Path, *, names=("cam01", "cam02", "cam03"), videos=None, sizes=None,
              n_frames=None, fps=None, calibration=True) -> Path:
    rig = renamed(_rig(len(names)), dict(zip(["C1", "C2", "C3"], names, strict=False)))
    if calibration:
        (root / "calibration").mkdir(parents=True)
        write_calibration_toml(rig, root / "calibration" / "Calib.toml", translation_scale=1000.0)
    (root / "videos").mkdir(parents=True, exist_ok=True)
    for i, video in enumerate(videos or names):
        size = (sizes or {}).get(video, (640, 480))
        n = (n_frames or {}).get(video, 3)
        write_frames(root / "videos" / video, _images(size, n, seed=i),
                     (fps or {}).get(video, 50.0), "mp4")
    return root


def test_a_few_columns_narrower_is_a_crop_on_the_right(tmp_path):
    root = _pose2sim(tmp_path / "p", sizes={"cam02": (632, 480)})
    seq = open_sequence(root)
    cam, calibrated = seq.rig["cam02"], _rig()["C2"]
    assert cam.size == (632, 480)
    np.testing.assert_array_equal(cam.cc, calibrated.cc)  # the principal point is kept
    np.testing.assert_allclose(cam.project(_points()), calibrated.project(_points()), atol=1e-6)
    assert any("8 column(s) cropped on the right (principal point kept)" in n for n in seq.notes)
    assert seq.read_frame(1)["cam02"].shape == (480, 632, 3)


@pytest.mark.parametrize(("size", "message"), [((600, 480), "more than 16 pixels apart"),
                                               ((480, 640), "turned by 90°")])
def test_sizes_that_cannot_match_are_refused(tmp_path, size, message):
    root = _pose2sim(tmp_path / "p", sizes={"cam03": size})
    with pytest.raises(InputError, match=message) as info:
        _ = open_sequence(root).rig
    assert info.value.source == str(root / "videos" / "cam03.mp4")


def test_frame_rate_and_length_from_the_videos(tmp_path):
    root = _pose2sim(tmp_path / "p", n_frames={"cam01": 5})
    seq = open_sequence(root)
    _ = seq.rig
    assert seq.frame_rate == 50.0 and seq.n_frames == 3
    assert any("different lengths" in n for n in seq.notes)
    root = _pose2sim(tmp_path / "q", fps={"cam02": 25.0})
    # the odd one out is named, whatever the order of the videos
    with pytest.raises(InputError,
                       match=r"cam02\.mp4: frame rate 25 Hz differs from the 50 Hz of cam01, cam03"):
        _ = open_sequence(root).frame_rate


def test_image_folders_and_the_project_frame_rate(tmp_path):
    root = tmp_path / "p"
    (root / "calibration").mkdir(parents=True)
    write_calibration_toml(_rig(), root / "calibration" / "Calib.toml", translation_scale=1000.0)
    for i, name in enumerate(["cam01_img", "cam02_img", "cam03_img"]):
        write_frames(root / "videos" / name, _images((640, 480), 2, seed=i), 0, "png")
    seq = open_sequence(root)
    assert seq.camera_names == ["C1", "C2", "C3"]  # no name in common: natural order
    assert seq.frame_rate == 30.0 and any("30 Hz assumed" in n for n in seq.notes)
    (root / "Config.toml").write_text("[project]\nframe_rate = 120\n")
    assert open_sequence(root).frame_rate == 120.0
    np.testing.assert_array_equal(open_sequence(root).read_frame(2)["C2"],
                                  _images((640, 480), 2, seed=1)[1])


def test_several_trials(tmp_path):
    root = tmp_path / "session"
    (root / "calibration").mkdir(parents=True)
    write_calibration_toml(renamed(_rig(), {"C1": "cam01", "C2": "cam02", "C3": "cam03"}),
                           root / "calibration" / "Calib.toml", translation_scale=1000.0)
    _pose2sim(root / "Trial_2", calibration=False)
    _pose2sim(root / "Trial_10", calibration=False)
    # a trial with its own calibration (Pose2Sim looks in the trial first)
    _pose2sim(root / "Trial_1", names=("camA", "camB"))
    project = Project(root)
    assert list(project.trials) == ["Trial_1", "Trial_2", "Trial_10"]
    with pytest.raises(InputError, match=r"3 trials \(Trial_1, Trial_2, Trial_10\): choose one "
                                         "with --trial"):
        open_sequence(root)
    assert open_sequence(root, trial="trial_1").camera_names == ["camA", "camB"]
    seq = open_sequence(root, trial="Trial_10")
    assert seq.subject == seq.name == "Trial_10" and seq.camera_names == ["cam01", "cam02", "cam03"]
    # a trial folder opened on its own finds the session's calibration
    assert open_sequence(root / "Trial_2").name == "Trial_2"
    # a result's RUN/<trial>/<trial>.h5 names the trial as subject and sequence
    assert open_sequence(root, "Trial_2", "Trial_2").name == "Trial_2"
    with pytest.raises(InputError, match="unknown trial 'Trial_3'"):
        open_sequence(root, trial="Trial_3")


def test_calibration_option_and_units(tmp_path):
    root = _pose2sim(tmp_path / "p")
    other = tmp_path / "calibration.toml"
    write_calibration_toml(renamed(_rig(), {"C1": "cam01", "C2": "cam02", "C3": "cam03"}), other,
                           translation_scale=1000.0)
    # a Pose2Sim project's TOML is in metres; one given by --calibration too
    seq = open_sequence(root, calibration=other)
    assert np.abs(seq.rig["cam01"].T - _rig()["C1"].T).max() < 1e-6
    # written in mm, read as metres its cameras would stand kilometres apart: mm (issue 35)
    write_calibration_toml(renamed(_rig(), {"C1": "cam01", "C2": "cam02", "C3": "cam03"}), other)
    seq = open_sequence(root, calibration=other)
    assert np.abs(seq.rig["cam01"].T - _rig()["C1"].T).max() < 1e-6
    with pytest.raises(InputError, match="calibration file not found"):
        open_sequence(root, calibration=tmp_path / "calib.json")
    (tmp_path / "calib.json").write_text("{}")
    with pytest.raises(InputError, match="unknown calibration format") as info:
        open_sequence(root, calibration=tmp_path / "calib.json")
    assert info.value.source == str(tmp_path / "calib.json")


@pytest.mark.parametrize(("damage", "message", "where"), [
    (lambda r: (r / "videos" / "cam03.mp4").unlink(),
     r"calibration camera cam03 \(Calib.toml\) has no video here", "videos"),
    (lambda r: write_frames(r / "videos" / "cam04", _images((640, 480)), 50.0, "mp4"),
     "no camera of the calibration", "videos/cam04.mp4"),
    (lambda r: (r / "videos" / "cam02.mp4").write_bytes(b"not a video"),
     "cannot open video", "videos/cam02.mp4"),
    (lambda r: [(r / "calibration" / "Calib.toml").unlink(),
                (r / "calibration" / "calib.xml").write_text("<x/>")],
     r"no calibration file .* \(it holds calib.xml\)", "calibration"),
    (lambda r: (r / "calibration" / "Calib.toml").write_text("[x]\na = 1\n"),
     "no camera tables", "calibration/Calib.toml"),
])
def test_bad_projects_name_the_file(tmp_path, damage, message, where):
    root = _pose2sim(tmp_path / "p")
    damage(root)
    with pytest.raises(InputError, match=message) as info:
        seq = open_sequence(root)
        _ = seq.rig
    assert info.value.source == str(root / where)


def test_cameras_option_leaves_out_a_camera_without_video(tmp_path):
    root = _pose2sim(tmp_path / "p")
    (root / "videos" / "cam03.mp4").unlink()
    seq = open_sequence(root, cameras=["CAM01", "cam02"])
    assert seq.camera_names == ["cam01", "cam02"] and seq.all_camera_names == ["cam01", "cam02"]
    with pytest.raises(InputError, match="no video of camera cam03"):
        open_sequence(root, cameras=["cam03"])
    with pytest.raises(InputError, match="unknown camera 'cam09'"):
        open_sequence(root, cameras=["cam09"])


def test_humaneva_layout_needs_subject_and_sequence(tiny_dataset):
    assert detect_layout(tiny_dataset) == "humaneva"
    assert open_sequence(tiny_dataset, "S1", "Walking_1").name == "Walking_1"
    with pytest.raises(InputError, match="needs --subject and --sequence"):
        open_sequence(tiny_dataset)
    with pytest.raises(InputError, match="--trial"):
        open_sequence(tiny_dataset, "S1", "Walking_1", trial="x")


def test_not_a_project(tmp_path):
    with pytest.raises(InputError, match="not a Pose2Sim"):
        detect_layout(tmp_path)
    with pytest.raises(InputError, match="not found"):
        detect_layout(tmp_path / "nothing")


def test_anipose_sessions_and_cam_regex(tmp_path):
    rig = renamed(_rig(2), {"C1": "1", "C2": "2"})
    root = tmp_path / "anipose"
    (root / "config.toml").parent.mkdir(parents=True)
    (root / "config.toml").write_text("[triangulation]\ncam_regex = '_cam(\\d)'\n")
    for session in ("day1", "day2"):
        (root / session / "calibration").mkdir(parents=True)
        write_calibration_toml(rig, root / session / "calibration" / "calibration.toml",
                               translation_scale=1000.0)  # metres: recognised from the spacing
        for trial in ("jump", "run"):
            for cam in ("1", "2"):
                write_frames(root / session / "videos-raw" / f"{trial}_cam{cam}",
                             _images((640, 480), 2), 30.0, "mp4")
    project = Project(root)
    assert list(project.trials) == ["day1_jump", "day1_run", "day2_jump", "day2_run"]
    seq = project.sequence("day2_run")
    assert seq.camera_names == ["1", "2"] and seq.video_path("2").name == "run_cam2.mp4"
    np.testing.assert_allclose(seq.rig["1"].T, _rig()["C1"].T, atol=1e-6)
    assert any("translations taken as metres" in n for n in seq.notes)


def test_video_decoder_reads_mp4_mov_and_avi(tmp_path):
    from voxelmocap.io.video import VideoStream, find_videos

    images = _images((64, 48), 4)
    for suffix, fourcc in ((".mp4", "mp4v"), (".mov", "mp4v"), (".avi", "FFV1")):
        path = tmp_path / f"v_{suffix[1:]}{suffix}"
        writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*fourcc), 24.0, (64, 48))
        for image in images:
            writer.write(image)
        writer.release()
        stream = VideoStream(path, gray=False)
        assert stream.n_frames == 4 and stream.fps == 24.0
        got = [im for _, im in stream.read([0, 2, 3])]
        assert got[0].shape == (48, 64, 3)
        if suffix == ".avi":  # lossless
            np.testing.assert_array_equal(got[1], images[2])
    (tmp_path / "notes.txt").write_text("x")
    (tmp_path / "empty").mkdir()
    assert list(find_videos(tmp_path)) == ["v_avi", "v_mov", "v_mp4"]


def test_world_frame_notes():
    from voxelmocap.camera import Rig
    from voxelmocap.io.project_checks import world_frame_notes

    rig = read_rig(default_rig_path())
    assert world_frame_notes(rig) == []
    # the same cameras in a Y-up world (x' = Q x): R' = R Qᵀ, T' = T
    Q = np.array([[1.0, 0, 0], [0, 0, 1], [0, -1, 0]])
    y_up = Rig(dataclasses.replace(c, R=c.R @ Q.T) for c in rig)
    (note,) = world_frame_notes(y_up)
    assert "looks +Y-up" in note
    np.testing.assert_allclose(y_up["C1"].project(_points() @ Q.T), rig["C1"].project(_points()),
                               atol=1e-6)
    low = Rig(dataclasses.replace(c, T=c.T + c.R @ np.array([0, 0, 1400.0])) for c in rig)
    assert "floor may not be at Z = 0" in world_frame_notes(low)[0]


def test_import_writes_the_humaneva_layout_losslessly(tmp_path, capsys):
    from voxelmocap.cli import main

    root = _pose2sim(tmp_path / "My_Trial2", names=("cam_01", "cam_02", "cam_03"),
                     sizes={"cam_03": (636, 480)})
    assert main(["import", str(root), "--out", str(tmp_path / "data"), "--no-progress"]) == 0
    assert "--subject S1 --sequence MyTrial_1" in capsys.readouterr().out
    assert main(["info", str(tmp_path / "data")]) == 0
    project = open_sequence(root)
    imported = Dataset(tmp_path / "data").sequence("S1", "MyTrial_1")
    assert imported.camera_names == ["cam01", "cam02", "cam03"]
    assert imported.n_frames == project.n_frames and imported.frame_rate == 50.0
    assert imported.rig["cam03"].size == (636, 480)
    for cam, he in zip(project.camera_names, imported.camera_names, strict=True):
        np.testing.assert_allclose(imported.rig[he].project(_points()),
                                   project.rig[cam].project(_points()), atol=1e-6)
    for (_, a), (_, b) in zip(project.frames(), imported.frames(), strict=True):
        for cam, he in zip(project.camera_names, imported.camera_names, strict=True):
            np.testing.assert_array_equal(a[cam], b[he])


def test_info_on_a_project(tmp_path, capsys):
    from voxelmocap.cli import main

    root = _pose2sim(tmp_path / "p", sizes={"cam02": (640, 472)})
    assert main(["info", str(root)]) == 0
    out = capsys.readouterr().out
    assert "pose2sim project" in out and "p: 3 frames at 50 Hz, cameras cam01, cam02, cam03" in out
    assert "note: cam02: the video is 640x472, the calibration 640x480: taken as the calibrated " \
           "image with 8 row(s) cropped at the bottom (principal point kept)" in out
    assert out.rstrip().endswith("all files read are valid")


# ---------------------------------------------------------------------- issue 36 / issue 35
def test_trial_names_never_leave_the_run_folder(tmp_path, monkeypatch):
    """``track .`` and ``track PROJ/videos/..`` name the trial after the project's real folder
    (not "" or ".."), so RUN/<trial>/<trial>.h5 stays inside RUN."""
    from bad_input_cases import _project

    data = make_tiny_dataset(tmp_path / "data", n_frames=2)
    root = _project(data, tmp_path)
    assert list(Project(root / "videos" / "..").trials) == ["proj"]
    monkeypatch.chdir(root)
    project = Project(".")
    assert list(project.trials) == ["proj"] and project.root == root


def test_pose2sim_calibration_in_mm_is_read_as_mm(tmp_path):
    """Issue 35: a Pose2Sim layout holding a calibration TOML written in mm (FreeMoCap's) would
    put its cameras kilometres apart read as metres: the geometry says mm, a note says so, and
    the rig is the one the mm file describes."""
    from bad_input_cases import _project

    data = make_tiny_dataset(tmp_path / "data", n_frames=2)
    root = _project(data, tmp_path)
    truth = read_rig(data / "S1" / "Calibration_Data")
    write_calibration_toml(truth, root / "calibration" / "Calib.toml")  # mm
    seq = Project(root).sequence()
    for cam in truth:
        np.testing.assert_allclose(seq.rig[cam.name].center, cam.center, atol=1e-6)
    assert any("taken as mm although Pose2Sim writes metres" in n for n in seq.notes)
