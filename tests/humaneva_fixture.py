"""Builds small HumanEva-I-layout data sets for the tests (cameras from calib/humaneva_i_like)."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from voxelmocap.io.calibration import read_rig, write_rig
from voxelmocap.io.humaneva import write_body_pose_xml, write_ofs

REPO = Path(__file__).resolve().parents[1]
RIG_DIR = REPO / "calib" / "humaneva_i_like"


def frame_image(camera: str, video_frame: int, size=(640, 480)) -> np.ndarray:
    """A BGR test image whose content encodes the camera's 1-based video frame number.

    The frame number is drawn as a bright bar whose column is ``20 * video_frame`` so that a
    reader can recover it from the decoded image even through lossy compression.
    """
    w, h = size
    image = np.full((h, w, 3), 40, np.uint8)
    x = 20 * video_frame
    image[:, x:x + 10] = 230
    return image


def decode_frame_number(image: np.ndarray) -> int:
    """Inverse of :func:`frame_image`."""
    gray = image if image.ndim == 2 else image.mean(axis=2)
    profile = gray.mean(axis=0)
    return int(round((np.argmax(profile > 135) + 0) / 20))


def make_tiny_dataset(root, *, cameras=("C1", "C2", "BW1"), leads=(5, 7, 6), n_frames=12,
                      subject="S1", action="Walking", trial=1, with_gt=True,
                      image_folder_camera=None, backgrounds=True, mc_sc=2.0) -> Path:
    """Write a HumanEva-layout data set with moving-bar videos and a ground-truth XML.

    Camera ``cameras[i]`` gets ``leads[i]`` extra frames at the start of its video and a ``.ofs``
    (im_st = lead + 1, mc_st = 1, mc_sc) such that synchronised frame F is video frame lead + F.
    """
    root = Path(root)
    sdir = root / subject
    rig = read_rig(RIG_DIR, names=cameras)
    write_rig(rig, sdir / "Calibration_Data")
    name = f"{action}_{trial}"
    for cam, lead in zip(cameras, leads, strict=True):
        write_ofs(sdir / "Sync_Data" / f"{name}_({cam}).ofs", lead + 1, 1, mc_sc)
        total = lead + n_frames
        images = [frame_image(cam, k) for k in range(1, total + 1)]
        if cam == image_folder_camera:
            folder = sdir / "Image_Data" / f"{name}_({cam})"
            folder.mkdir(parents=True, exist_ok=True)
            for k, image in enumerate(images, start=1):
                cv2.imwrite(str(folder / f"frame_{k:05d}.png"), image)
        else:
            _write_avi(sdir / "Image_Data" / f"{name}_({cam}).avi", images)
        if backgrounds:
            bg = [np.full((480, 640, 3), 40, np.uint8) for _ in range(4)]
            _write_avi(root / "Background" / f"Background_1_({cam}).avi", bg)
    if with_gt:
        rng = np.random.default_rng(0)
        frames = np.arange(1, n_frames + 1)
        endpoints = rng.normal(0, 300, size=(n_frames, 20, 3)) + [0, 0, 1000]
        write_body_pose_xml(sdir / "Mocap_Data" / f"{name}.xml", frames, endpoints,
                            attributes={"SubjectName": subject, "ActionType": action,
                                        "Trial": trial, "FrameStart": 1, "FrameEnd": n_frames})
    return root


def _write_avi(path: Path, images) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    h, w = images[0].shape[:2]
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 60.0, (w, h))
    assert writer.isOpened()
    for image in images:
        writer.write(image)
    writer.release()
