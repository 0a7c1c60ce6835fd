"""Pose2Sim / anipose / EasyMocap projects written from a HumanEva-layout sequence, for the tests.

Each writer takes an opened HumanEva sequence and writes its synchronised frames and calibration
in the project's own formats (frames 1..N of the sequence become frames 1..N of the videos, so
the projects need no sync files), with background videos when ``backgrounds`` is set.

* ``video="png"`` writes numbered PNG folders (lossless: the project shows the very pixels the
  HumanEva layout shows); ``"mp4"`` encodes with OpenCV's ``mp4v`` (lossy).
* :func:`write_qca` writes a Qualisys ``.qca.txt`` from cameras, following QTM's conventions
  written out here independently of the reader.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import cv2
import numpy as np

from voxelmocap.camera import Rig
from voxelmocap.io.calibration import write_calibration_toml
from voxelmocap.io.easymocap import write_easymocap

FLIP_X = np.diag([1.0, -1.0, -1.0])


def renamed(rig, names: dict[str, str]) -> Rig:
    """The rig with cameras renamed (``{old: new}``)."""
    return Rig(dataclasses.replace(cam, name=names[cam.name]) for cam in rig)


def write_frames(path: Path, images: list[np.ndarray], fps: float, video: str) -> Path:
    """Images as a numbered PNG folder (``video="png"``) or an ``mp4v`` MP4 (``"mp4"``)."""
    if video == "png":
        path.mkdir(parents=True)
        for k, image in enumerate(images):
            assert cv2.imwrite(str(path / f"frame_{k:06d}.png"), image)
        return path
    path = path.with_suffix(".mp4")
    path.parent.mkdir(parents=True, exist_ok=True)
    h, w = images[0].shape[:2]
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), float(fps), (w, h))
    assert writer.isOpened()
    for image in images:
        writer.write(image if image.ndim == 3 else cv2.cvtColor(image, cv2.COLOR_GRAY2BGR))
    writer.release()
    return path


def sequence_images(seq, cameras, frames=None) -> dict[str, list[np.ndarray]]:
    out = {cam: [] for cam in cameras}
    for _, images in seq.frames(frames):
        for cam in cameras:
            out[cam].append(images[cam])
    return out


def _videos(seq, cameras, folder: Path, names: dict[str, str], video: str, *,
            stem=lambda name: name, backgrounds: Path | None = None, frames=None):
    folder.mkdir(parents=True, exist_ok=True)
    images = sequence_images(seq, cameras, frames)
    for cam in cameras:
        write_frames(folder / stem(names[cam]), images[cam], seq.frame_rate, video)
    if backgrounds is not None:
        backgrounds.mkdir(parents=True, exist_ok=True)
        for cam in cameras:
            (frames_,) = seq.background_sets(cam)
            write_frames(backgrounds / names[cam], frames_, seq.frame_rate, video)


def write_qca(rig, path: Path, *, offset=(0, 0), extra: str = "", serial_model=None) -> None:
    """A QTM ``.qca.txt`` of ``rig`` (no skew, k3 and skew written as 0).

    QTM's conventions: image coordinates in 1/64 pixel, measured on the sensor (the ``fov_video``
    window starts at ``offset``), the camera centre in mm and the rotation ``M`` with the camera's
    y up and z backwards (``R_opencv = diag(1, −1, −1) M``).
    """
    left, top = offset
    cams = []
    for cam in rig:
        w, h = cam.size
        M = (FLIP_X @ cam.R).tolist()
        c = cam.center.tolist()
        fx, fy = cam.fc.tolist()
        cx, cy = cam.cc.tolist()
        k1, k2, p1, p2, _ = cam.kc.tolist()
        model = (serial_model or {}).get(cam.name, "none")
        rot = " ".join(f'r{i + 1}{j + 1}="{M[i][j]!r}"' for i in range(3) for j in range(3))
        cams.append(
            f'    <camera active="1" avg-residual="0.4" model="{model}" point-count="9" '
            f'serial="{cam.name}" viewrotation="0">\n'
            f'      <fov_video bottom="{top + h - 1}" left="{left}" right="{left + w - 1}" '
            f'top="{top}"/>\n'
            f'      <transform {rot} x="{c[0]!r}" y="{c[1]!r}" z="{c[2]!r}"/>\n'
            f'      <intrinsic centerPointU="{(cx + left) * 64!r}" centerPointV="{(cy + top) * 64!r}" '
            f'focalLengthU="{fx * 64!r}" focalLengthV="{fy * 64!r}" focallength="9.3" '
            f'radialDistortion1="{k1 * 64!r}" radialDistortion2="{k2 * 64!r}" '
            f'radialDistortion3="0" skew="0" tangentalDistortion1="{p1 * 64!r}" '
            f'tangentalDistortion2="{p2 * 64!r}"/>\n'
            "    </camera>\n")
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("<?xml version='1.0' encoding='ASCII'?>\n<calibration type=\"regular\">\n"
                    f"  <cameras>\n{''.join(cams)}{extra}  </cameras>\n</calibration>\n")


def qca_rig(rig) -> Rig:
    """The rig as a ``.qca.txt`` can hold it (no k3, no skew)."""
    return Rig(dataclasses.replace(cam, kc=np.concatenate([cam.kc[:4], [0.0]]), alpha_c=0.0)
               for cam in rig)


def make_project(seq, root: Path, layout: str, cameras, *, video: str = "mp4",
                 backgrounds: bool = True, frames=None, sizes: bool = True) -> tuple[Path, dict]:
    """Write ``seq``'s ``cameras`` as a project; returns the project folder and the name map.

    Layouts: ``"pose2sim"`` (calibration/Calib_scene.toml in metres, videos/cam0k.*),
    ``"pose2sim-qca"`` (calibration/Calib.qca.txt), ``"anipose"`` (calibration/calibration.toml
    in mm, videos-raw/walk-cam<A>.*, cameras A, B, …), ``"easymocap"`` (intri.yml, extri.yml in
    metres, videos/0k.*; ``sizes=False`` leaves out H_/W_).
    """
    root.mkdir(parents=True)
    rig = seq.rig.select(cameras)
    if layout.startswith("pose2sim"):
        names = {cam: f"cam{i + 1:02d}" for i, cam in enumerate(cameras)}
        if layout == "pose2sim-qca":
            write_qca(renamed(qca_rig(rig), names), root / "calibration" / "Calib.qca.txt",
                      offset=(16, 8))
        else:
            (root / "calibration").mkdir()
            write_calibration_toml(renamed(rig, names), root / "calibration" / "Calib_scene.toml",
                                   translation_scale=1000.0)
        _videos(seq, cameras, root / "videos", names, video, frames=frames,
                backgrounds=root / "background" if backgrounds else None)
    elif layout == "anipose":
        names = {cam: "ABCDEFGH"[i] for i, cam in enumerate(cameras)}
        (root / "calibration").mkdir()
        write_calibration_toml(renamed(rig, names), root / "calibration" / "calibration.toml")
        (root / "config.toml").write_text("[triangulation]\ncam_regex = '-cam([A-Z])'\n")
        _videos(seq, cameras, root / "videos-raw", names, video, stem=lambda n: f"walk-cam{n}",
                frames=frames, backgrounds=root / "background" if backgrounds else None)
    elif layout == "easymocap":
        names = {cam: f"{i + 1:02d}" for i, cam in enumerate(cameras)}
        write_easymocap(renamed(rig, names), root, sizes=sizes)
        _videos(seq, cameras, root / "videos", names, video, frames=frames,
                backgrounds=root / "background" if backgrounds else None)
    else:
        raise ValueError(layout)
    return root, names
