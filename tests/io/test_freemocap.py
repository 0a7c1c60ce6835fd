"""FreeMoCap recording folders read as a project: synchronized_videos/ + the calibration TOML (mm).

The recordings are written here from the rendered walk, the calibration TOML by hand in
aniposelib's layout (as FreeMoCap's ``CameraGroup.dump`` writes it: ``[cam_0]`` tables, camera
names = the calibration recording's video stems, OpenCV's Rodrigues rotation, translations in mm,
a ``[metadata]`` table), not with the package's own writer.
"""

import re
from pathlib import Path

import cv2
import numpy as np
import pytest
import tomli_w
from project_fixture import sequence_images, write_frames

from voxelmocap.errors import InputError
from voxelmocap.io.humaneva import Dataset
from voxelmocap.io.project import Project
from voxelmocap.io.sequence import detect_layout, open_sequence
from voxelmocap.run.batch import BatchItem, dataset_items

CAMERAS = ["C1", "C2", "BW1"]


@pytest.fixture(scope="module")
def walk_seq(walk_dataset):
    return Dataset(walk_dataset).sequence("S1", "Walking_1")


def _stem(k: int) -> str:
    return f"Camera_{k:03d}_synchronized"


def write_freemocap_toml(rig, path: Path) -> None:
    """An aniposelib calibration TOML as FreeMoCap writes it, translations in mm."""
    doc = {}
    for k, cam in enumerate(rig):
        K = np.array([[cam.fc[0], cam.alpha_c * cam.fc[0], cam.cc[0]],
                      [0.0, cam.fc[1], cam.cc[1]], [0.0, 0.0, 1.0]])
        rvec, _ = cv2.Rodrigues(cam.R)
        doc[f"cam_{k}"] = {"name": _stem(k), "size": [int(v) for v in cam.size],
                           "matrix": K.tolist(), "distortions": [float(v) for v in cam.kc],
                           "rotation": rvec.ravel().tolist(),
                           "translation": [float(v) for v in cam.T]}  # mm, as calibrated
    doc["metadata"] = {"charuco_square_size": 39.0, "charuco_board_object": "7x5",
                       "path_to_recorded_videos": "calibration/synchronized_videos",
                       "date_time_calibrated": "2024-05-17T12:49:06"}
    path.write_bytes(tomli_w.dumps(doc).encode())


def make_recording(seq, folder: Path, cameras, frames=None, calibration=True) -> Path:
    """A FreeMoCap recording folder of ``seq``'s ``cameras``."""
    videos = folder / "synchronized_videos"
    images = sequence_images(seq, cameras, frames)
    for k, cam in enumerate(cameras):
        write_frames(videos / _stem(k), images[cam], seq.frame_rate, "mp4")
    (videos / "timestamps").mkdir()
    (videos / "timestamps" / "camera_timestamps.csv").write_text("frame_duration_ms\n16.7\n")
    (folder / "output_data").mkdir()
    if calibration:
        write_freemocap_toml(seq.rig.select(cameras), folder / f"{folder.name}_camera_calibration"
                                                               ".toml")
    return folder


def test_a_recording_folder_opens_as_a_project(walk_seq, tmp_path):
    root = make_recording(walk_seq, tmp_path / "recording_12_00_walk", CAMERAS)
    assert detect_layout(root) == "freemocap"
    seq = open_sequence(root)
    assert seq.name == "recording_12_00_walk"
    assert seq.camera_names == [_stem(k) for k in range(3)]
    points = np.random.default_rng(2).uniform([-1500, -1500, 0], [1500, 1500, 2000], (200, 3))
    for k, cam in enumerate(CAMERAS):
        got, want = seq.rig[_stem(k)], walk_seq.rig[cam]
        # millimetres as written: the same cameras, not 1000 times farther or nearer
        np.testing.assert_allclose(got.center, want.center, atol=1e-6)
        np.testing.assert_allclose(got.project(points), want.project(points), atol=1e-6)
    assert seq.n_frames == walk_seq.n_frames and seq.frame_rate == walk_seq.frame_rate
    assert any("FreeMoCap calibration, translations read as millimetres" in n
               for n in seq.notes)
    image = seq.read_frame(3)[_stem(1)].astype(float)
    truth = walk_seq.read_frame(3)["C2"].astype(float)
    assert np.abs(image - truth).mean() < 6.0  # mp4 is lossy


def test_a_folder_of_recordings_is_a_batch(walk_seq, tmp_path):
    root = tmp_path / "recording_sessions"
    make_recording(walk_seq, root / "rec_a", CAMERAS, frames=[1, 2, 3])
    make_recording(walk_seq, root / "rec_b", CAMERAS, frames=[4, 5])
    project = Project(root)
    assert project.kind == "freemocap" and list(project.trials) == ["rec_a", "rec_b"]
    assert project.sequence("rec_b").n_frames == 2
    assert dataset_items(root) == [BatchItem("rec_a", "rec_a"), BatchItem("rec_b", "rec_b")]
    assert BatchItem("rec_a", "rec_a").key == "rec_a"


def test_which_calibration_and_what_is_refused(walk_seq, tmp_path):
    root = make_recording(walk_seq, tmp_path / "rec", CAMERAS, frames=[1, 2], calibration=False)
    with pytest.raises(InputError, match=re.escape("no FreeMoCap calibration "
                                                   "(rec_camera_calibration.toml")):
        open_sequence(root)
    # FreeMoCap's fallback: the one *.toml whose name says calibration
    write_freemocap_toml(walk_seq.rig.select(CAMERAS), root / "lab_calibration.toml")
    assert open_sequence(root).trial_info.calibration.name == "lab_calibration.toml"
    write_freemocap_toml(walk_seq.rig.select(CAMERAS), root / "old_calibration.toml")
    with pytest.raises(InputError, match=re.escape(
            "several calibration TOMLs (lab_calibration.toml, old_calibration.toml): choose one "
            "with --calibration")):
        open_sequence(root)
    assert open_sequence(root, calibration=root / "old_calibration.toml").n_frames == 2
    # the recording's own name wins over the others
    write_freemocap_toml(walk_seq.rig.select(CAMERAS), root / "rec_camera_calibration.toml")
    assert open_sequence(root).trial_info.calibration.name == "rec_camera_calibration.toml"
