"""``scripts/make_guise.py``: a Pose2Sim project's guise sees the same scene, pixel for pixel."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from project_fixture import qca_rig, renamed, write_frames, write_qca

from voxelmocap.io.calibration import read_rig
from voxelmocap.io.calibration_files import find_calibration, read_calibration_file
from voxelmocap.io.sequence import open_sequence
from voxelmocap.io.video import VideoStream, find_videos
from voxelmocap.synth import default_rig_path

NAMES = ("cam01", "cam02", "cam03")
CONFIG = "[project]\nframe_rate = 'auto' # fps\n\n[calibration.convert.qualisys]\nbinning_factor = 1\n"


@pytest.fixture(scope="module")
def guise(load_script):
    return load_script("make_guise")


@pytest.fixture(scope="module")
def project(tmp_path_factory) -> Path:
    """Three cameras (a Qualisys calibration, 640x480 MP4s at 50 Hz, 4 frames of noise)."""
    root = tmp_path_factory.mktemp("guise") / "original"
    rig = qca_rig(renamed(read_rig(default_rig_path()).select(["C1", "C2", "C3"]),
                          dict(zip(["C1", "C2", "C3"], NAMES, strict=True))))
    write_qca(rig, root / "calibration" / "Calib.qca.txt")
    (root / "Config.toml").write_text(CONFIG)
    rng = np.random.default_rng(0)
    for name in NAMES:
        # smooth noise (blurred), so that the MP4 keeps it and the resize has something to average
        images = [cv2.GaussianBlur(rng.integers(0, 256, (480, 640, 3), dtype=np.uint8), (7, 7), 2)
                  for _ in range(4)]
        write_frames(root / "videos" / name, images, 50.0, "mp4")
    return root


def _rig(folder: Path):
    return {c.name: c for c in read_calibration_file(find_calibration(folder / "calibration"))[0]}


def _points(rig) -> np.ndarray:
    """World points every camera sees: around the middle of the cameras' optical axes."""
    cams = list(rig.values())
    centre = np.mean([c.center + 3000.0 * np.asarray(c.R)[2] for c in cams], axis=0)
    rng = np.random.default_rng(1)
    return centre + rng.uniform(-300, 300, (20, 3))


def _frames(path: Path) -> list[np.ndarray]:
    stream = VideoStream(path, gray=False)
    return [image for _, image in stream.read(range(stream.n_frames))]


@pytest.mark.parametrize("scale, fmt", [(0.5, "toml"), (0.75, "qca"), (1.0, "toml")])
def test_the_guise_projects_to_the_scaled_pixel_centres(guise, project, tmp_path, scale, fmt):
    out = guise.make_guise(project, tmp_path / "g", scale=scale, calibration=fmt)
    assert not (tmp_path / ".g.tmp").exists()
    calib = find_calibration(out / "calibration")
    assert calib.name.endswith(".toml" if fmt == "toml" else ".qca.txt")
    before, after = _rig(project), _rig(out)
    assert list(after) == list(NAMES)
    pts = _points(before)
    for name in NAMES:
        a, b = before[name], after[name]
        assert b.size == (round(640 * scale), round(480 * scale))
        np.testing.assert_allclose(b.R, a.R, atol=1e-12)
        np.testing.assert_allclose(b.T, a.T, atol=1e-6)        # mm, whatever the file's unit
        np.testing.assert_allclose(b.project(pts), (a.project(pts) + 0.5) * scale - 0.5,
                                   atol=1e-6)
        # closed form: a point on the optical axis images at the principal point, moved as a
        # pixel centre (distortion leaves the axis alone)
        axis = a.center + 2500.0 * np.asarray(a.R)[2]
        np.testing.assert_allclose(b.project(axis[None])[0], (np.asarray(a.cc) + 0.5) * scale - 0.5,
                                   atol=1e-6)
    videos = find_videos(out / "videos")
    assert list(videos) == list(NAMES)
    for name in NAMES:
        original = _frames(find_videos(project / "videos")[name])
        frames = _frames(videos[name])
        assert len(frames) == len(original) == 4
        for o, g in zip(original, frames, strict=True):
            want = o if scale == 1 else cv2.resize(o, (round(640 * scale), round(480 * scale)),
                                                   interpolation=cv2.INTER_AREA)
            np.testing.assert_array_equal(g, want)
    if scale != 1:
        assert all(p.is_dir() for p in videos.values())            # lossless PNG folders
        # image folders state no frame rate: the guise's Config.toml states the original's
        assert "frame_rate = 50 # fps" in (out / "Config.toml").read_text()
        assert open_sequence(out).frame_rate == 50.0
    else:
        assert (out / "Config.toml").read_text() == CONFIG


def test_a_camera_left_out_and_a_later_first_frame(guise, project, tmp_path):
    out = guise.make_guise(project, tmp_path / "g", drop=("cam02",), first_frame=3)
    assert list(_rig(out)) == ["cam01", "cam03"]
    videos = find_videos(out / "videos")
    assert list(videos) == ["cam01", "cam03"]
    for name in videos:
        original = _frames(find_videos(project / "videos")[name])
        frames = _frames(videos[name])
        assert len(frames) == 2                      # guise frame F is original frame F + 2
        for o, g in zip(original[2:], frames, strict=True):
            np.testing.assert_array_equal(g, o)
    before, after = _rig(project), _rig(out)
    pts = _points(before)
    for name in videos:
        np.testing.assert_allclose(after[name].project(pts), before[name].project(pts), atol=1e-6)
    seq = open_sequence(out)
    assert [c.name for c in seq.rig] == ["cam01", "cam03"] and seq.frame_rate == 50.0


def test_another_frame_rate_keeps_every_kth_frame(guise, project, tmp_path):
    out = guise.make_guise(project, tmp_path / "g", first_frame=2, every=2)
    videos = find_videos(out / "videos")
    for name in NAMES:
        original = _frames(find_videos(project / "videos")[name])
        frames = _frames(videos[name])
        assert len(frames) == 2                      # guise frame F is original frame 2F
        for o, g in zip(original[1::2], frames, strict=True):
            np.testing.assert_array_equal(g, o)
    assert "frame_rate = 25 # fps" in (out / "Config.toml").read_text()
    assert open_sequence(out).frame_rate == 25.0


def test_bad_requests_are_refused(guise, project, tmp_path):
    with pytest.raises(SystemExit, match="no such camera"):
        guise.make_guise(project, tmp_path / "a", drop=("cam09",))
    with pytest.raises(SystemExit, match="has 4 frames"):
        guise.make_guise(project, tmp_path / "b", first_frame=5)
    with pytest.raises(SystemExit, match="--every must be >= 1"):
        guise.make_guise(project, tmp_path / "d", every=0)
    (tmp_path / "c").mkdir()
    with pytest.raises(SystemExit, match="exists"):
        guise.make_guise(project, tmp_path / "c")
