"""Writing a synthetic sequence in the HumanEva-I layout (:func:`generate`).

Layout under ``OUT`` (``HUMANEVA.md`` §1)::

    <Subject>/Calibration_Data/<CAM>.cal (+ sizes.toml)
    <Subject>/Image_Data/<Action>_<Trial>_(<CAM>).avi
    <Subject>/Sync_Data/<Action>_<Trial>_(<CAM>).ofs
    <Subject>/Mocap_Data/<Action>_<Trial>.xml          ground truth, 20 endpoints per frame
    <Subject>/Mocap_Data/<Subject>_body.toml           limb lengths and widths (voxelmocap-body-1)
    <Subject>/Mask_Data/<Action>_<Trial>_(<CAM>)/<F:05d>.png   noise-free person masks (optional)
    Background/Background_1_(<CAM>).avi                the empty scene, same noise and flicker

Synchronisation: camera I's video starts with a lead of ``d_I ≥ 5`` frames (distinct per camera,
drawn from the seed) and its ``.ofs`` holds ``im_st = d_I + 1, mc_st = 1, mc_sc = 1``; the
toolkit's ``sync_starts`` then gives ``start(I) = d_I + 1``, so synchronised frame F is video frame
``d_I + F`` (1-based) in camera I, and the ground truth of frame F is what that video frame shows.

Everything is rendered into a temporary folder inside ``OUT`` and moved into place only when
complete, so a failure leaves nothing half-written.
"""

from __future__ import annotations

import logging
import os
import re
import shutil
from importlib import resources
from pathlib import Path

import cv2
import numpy as np

from ..errors import InputError
from .body_shape import BodyShape, _subject_rng, body_primitives, subject_body
from .heading import frames_out_of_view, turn_about_vertical
from .resample import (
    ProceduralSource,
    motion_source,
    place_in_area,
    sample_motion,
    stature_estimate,
)
from .scene import sensor
from .skeletons import endpoints_from_canonical

__all__ = ["CODECS", "default_rig_path", "generate"]

#: FourCC of each supported codec name (all written and read back by OpenCV's FFmpeg backend).
CODECS = {"FFV1": "FFV1", "MJPG": "MJPG", "XVID": "XVID", "HFYU": "HFYU"}

logger = logging.getLogger(__name__)

_NAME = re.compile(r"^[A-Za-z0-9]+$")
_ACTION = re.compile(r"^[A-Za-z]+$")
MIN_LEAD = 5
NOISE_SIGMA = 2.0        # grey levels of sensor noise at noise = 1
FLICKER = 0.006          # relative per-frame gain jitter at noise = 1
BLUR = 0.6               # optical blur sigma (pixels)


def default_rig_path() -> Path:
    """The packaged copy of ``calib/humaneva_i_like`` (works when installed)."""
    return Path(str(resources.files("voxelmocap") / "data" / "rigs" / "humaneva_i_like"))


def _check_options(frames, fps, noise, trial, subject, action, codec, background_frames):
    if int(frames) != frames or frames < 1:
        raise InputError("--frames", f"must be a positive integer, got {frames}")
    if not (np.isfinite(fps) and fps > 0):
        raise InputError("--fps", f"must be positive, got {fps}")
    if not (np.isfinite(noise) and noise >= 0):
        raise InputError("--noise", f"must be ≥ 0, got {noise}")
    if int(trial) != trial or trial < 1:
        raise InputError("--trial", f"must be a positive integer, got {trial}")
    if not _NAME.match(subject):
        raise InputError("--subject", f"must be letters and digits (e.g. S1), got {subject!r}")
    if not _ACTION.match(action):
        raise InputError("--action", f"must be letters only (e.g. Walking), got {action!r}")
    if codec not in CODECS:
        raise InputError("--codec", f"unknown codec {codec!r} (choose {', '.join(CODECS)})")
    if int(background_frames) != background_frames or background_frames < 2:
        raise InputError("background_frames", f"must be an integer ≥ 2, got {background_frames}")


def _open_writer(path: Path, codec: str, fps: float, size) -> cv2.VideoWriter:
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*CODECS[codec]), float(fps),
                             tuple(int(v) for v in size), True)
    if not writer.isOpened():
        raise InputError("--codec", f"OpenCV cannot write {codec} video here ({path.name})")
    return writer


def generate(out_dir, motion: str = "walk", frames: int = 60, subject: str = "S1",
             action: str | None = None, trial: int = 1, rig=None, fps: float = 60.0,
             seed: int = 0, noise: float = 1.0, cameras=None, progress: bool = True, *,
             render_masks: bool = False, codec: str = "MJPG", background_frames: int = 120,
             start: float = 0.0, unit="auto", scene_seed: int = 0, overwrite: bool = True,
             heading_deg: float = 0.0) -> Path:
    """Render a synthetic HumanEva-I sequence and return the data set root (``out_dir``).

    Parameters
    ----------
    out_dir : str or os.PathLike
        Data set root; created if needed. Existing files of the same sequence are replaced.
    motion : str
        ``walk``, ``jog``, ``box``, ``gestures``, ``throwcatch``, the path of a ``.bvh`` file, or
        of a CMU ``.amc`` file (its ``.asf`` beside it, 120 fps).
    frames : int
        Number N of synchronised frames (with ground truth), numbered 1..N.
    subject : str
        Subject folder name (letters and digits).
    action : str, optional
        HumanEva action name; default from the motion (``Walking``, ``Jog``, ``Box``,
        ``Gestures``, ``ThrowCatch``; ``Combo`` for BVH files).
    trial : int
        Trial number.
    rig : str, os.PathLike or voxelmocap.camera.Rig, optional
        Calibration folder or rig; default the packaged ``humaneva_i_like`` rig.
    fps : float
        Video frame rate (HumanEva: 60).
    seed : int
        Seed of everything random (noise, flicker, camera leads, motion variations).
    noise : float
        Scales the sensor noise (σ = 2 grey levels at 1) and gain flicker (0.6 % at 1).
    cameras : list of str, optional
        Subset of the rig's cameras to render.
    progress : bool
        Show a progress bar.
    render_masks : bool
        Also write the noise-free person masks of frames 1..N as PNG (255 = person).
    codec : {"MJPG", "FFV1", "XVID", "HFYU"}
        Video codec; FFV1 and HFYU are lossless.
    background_frames : int
        Length of each background video.
    start : float
        Start time in the motion (s), for BVH clips.
    unit : str or float
        BVH unit (see :func:`voxelmocap.io.bvh.read_bvh`).
    scene_seed : int
        Seed of the room (layout and textures); keep it fixed across sequences of one data set.
    overwrite : bool
        Replace an existing sequence of the same subject, action and trial (all its cameras);
        when False, an existing one is an :class:`InputError`.
    heading_deg : float
        Turn the placed motion by this angle (degrees, counter-clockwise seen from above) about
        the vertical through the pelvis at synchronised frame 1 before rendering
        (:func:`voxelmocap.synth.heading.turn_about_vertical`); the ground truth is the turned
        motion's. 0 (the default) leaves the motion as placed. A turned motion that leaves the
        cameras' common view is logged as a warning (and still rendered).

    Returns
    -------
    pathlib.Path
        ``out_dir``.

    Raises
    ------
    InputError
        Bad options, unknown motion, unreadable BVH, a rig folder without cameras, or more frames
        than the clip holds. Nothing is written in that case.
    """
    from tqdm import tqdm

    from ..io.body_file import write_body_file
    from ..io.body_pose_xml import write_body_pose_xml
    from ..io.calibration import read_rig, write_rig
    from ..io.humaneva import write_ofs
    from .render import Renderer

    src_probe = motion_source(motion, seed=seed, unit=unit)
    action = action or src_probe.action
    _check_options(frames, fps, noise, trial, subject, action, codec, background_frames)
    if not np.isfinite(heading_deg):
        raise InputError("--heading", f"must be a finite angle in degrees, got {heading_deg}")
    frames, trial = int(frames), int(trial)
    if rig is None or isinstance(rig, (str, os.PathLike)):
        rig = read_rig(rig if rig is not None else default_rig_path())
    if cameras:
        rig = rig.select(list(cameras))
    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise InputError(out_dir, "exists and is not a folder")
    seq = f"{action}_{trial}"
    existing = sorted((out_dir / subject / "Image_Data").glob(f"{seq}_(*).avi"))
    if existing and not overwrite:
        raise InputError(out_dir / subject, f"sequence {seq} exists already (use --overwrite)")

    rng = np.random.default_rng(seed)
    n_cam = len(rig)
    leads = {cam.name: MIN_LEAD + int(d) for cam, d in
             zip(rig, rng.choice(np.arange(2 * n_cam), size=n_cam, replace=False), strict=True)}
    d_max = max(leads.values())
    # Synchronised frames 1 - d_max … N (the leads) at times start + (F - 1 + d_max) / fps.
    total = frames + d_max
    if src_probe.duration == np.inf:
        # A procedural subject's stature belongs to the subject (not the seed), so every sequence
        # of one subject shares one body file.
        height = float(_subject_rng(subject).uniform(1650, 1850))
        source = motion_source(motion, height=height, seed=seed)
    else:
        source = src_probe
    if start + (total - 1) / fps > source.duration + 1e-9:
        most = int(np.floor((source.duration - start) * fps + 1e-9)) + 1 - d_max
        raise InputError("--frames", f"{source.name} lasts {source.duration:.2f} s: at {fps:g} fps "
                                     f"from {start:g} s it supplies at most {max(most, 0)} frames "
                                     f"(after {d_max} camera-lead frames); asked for {frames}")
    points = place_in_area(sample_motion(source, total, fps, start=start), fps)
    if heading_deg != 0:
        # turned after placing, about frame 1's pelvis: the start stays where the clip put it
        points = turn_about_vertical(points, heading_deg, pivot_frame=d_max)
    sync_numbers = np.arange(1 - d_max, frames + 1)
    truth = points[d_max:]
    if heading_deg != 0:
        missed = frames_out_of_view(rig, truth).any(axis=1)
        if missed.any():
            logger.warning("turned by %g°, %s leaves the cameras' common view in %d of %d frames "
                           "(first: frame %d)", heading_deg, source.name, int(missed.sum()),
                           frames, int(np.argmax(missed)) + 1)
    height = (source.height if isinstance(source, ProceduralSource)
              else stature_estimate(truth))
    shape = BodyShape.for_subject(subject, height)
    body = subject_body(truth, shape, height=height)
    _check_body_consistency(out_dir / subject, seq, body, overwrite)

    created = not out_dir.exists()
    out_dir.mkdir(parents=True, exist_ok=True)
    tmp = out_dir / f".synth-tmp-{os.getpid()}-{seq}"
    shutil.rmtree(tmp, ignore_errors=True)
    try:
        sdir = tmp / subject
        write_rig(rig, sdir / "Calibration_Data")
        for sub in ("Image_Data", "Sync_Data", "Mocap_Data"):
            (sdir / sub).mkdir(parents=True, exist_ok=True)
        renderer = Renderer(rig, scene_seed=scene_seed)
        noise_rng = np.random.default_rng([seed, 1])
        sigma = NOISE_SIGMA * noise
        writers = {cam.name: _open_writer(sdir / "Image_Data" / f"{seq}_({cam.name}).avi", codec,
                                          fps, cam.size) for cam in rig}
        mask_dirs = {}
        if render_masks:
            for cam in rig:
                mask_dirs[cam.name] = sdir / "Mask_Data" / f"{seq}_({cam.name})"
                mask_dirs[cam.name].mkdir(parents=True, exist_ok=True)
        phase = {cam.name: noise_rng.uniform(0, 2 * np.pi) for cam in rig}
        try:
            bar = tqdm(total=len(sync_numbers) * n_cam, disable=not progress, unit="img",
                       desc=f"synth {subject}/{seq}")
            for k, F in enumerate(sync_numbers):
                prims = body_primitives(points[k], shape)
                for cam in rig:
                    if F < 1 - leads[cam.name]:
                        continue
                    radiance, mask = renderer.render(cam.name, prims)
                    gain = _gain(noise_rng, noise, k / fps, phase[cam.name])
                    img = sensor(radiance, gray=cam.name.upper().startswith("BW"), gain=gain,
                                 noise_sigma=sigma, rng=noise_rng, blur=BLUR)
                    writers[cam.name].write(img)
                    if render_masks and F >= 1:
                        ok = cv2.imwrite(str(mask_dirs[cam.name] / f"{F:05d}.png"),
                                         mask.astype(np.uint8) * 255)
                        if not ok:
                            raise InputError(mask_dirs[cam.name], "cannot write mask PNG")
                    bar.update(1)
            bar.close()
        finally:
            for w in writers.values():
                w.release()
        for cam in rig:
            write_ofs(sdir / "Sync_Data" / f"{seq}_({cam.name}).ofs", leads[cam.name] + 1, 1, 1)
        _write_backgrounds(renderer, rig, tmp / "Background", codec, fps, background_frames,
                           np.random.default_rng([seed, 2]), noise, progress)
        attrs = {"DatasetName": "voxelmocap-synth", "DatasetBasePath": "../",
                 "SubjectName": subject, "ActionType": action, "Trial": trial, "FrameStart": 1,
                 "FrameEnd": frames, "Partition": "Synthetic", "Motion": source.name,
                 "Seed": seed, "FrameRate": f"{fps:g}"}
        if heading_deg != 0:
            attrs["Heading"] = f"{heading_deg:g}"
        write_body_pose_xml(sdir / "Mocap_Data" / f"{seq}.xml", np.arange(1, frames + 1),
                            endpoints_from_canonical(truth), attributes=attrs)
        write_body_file(sdir / "Mocap_Data" / f"{subject}_body.toml", body, subject)
        _remove_sequence(out_dir / subject, seq)
        _move_into(tmp, out_dir)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
        if created and not any(out_dir.iterdir()):
            out_dir.rmdir()  # a failed run leaves no trace, not even the folder it made
    return out_dir


#: Rigid limb lengths that must agree (within BODY_TOLERANCE mm) between sequences of one subject.
BODY_KEYS = ("upper_arm", "forearm", "thigh", "shin")
BODY_TOLERANCE = 2.0


def _check_body_consistency(sdir: Path, seq: str, body, overwrite: bool) -> None:
    """Refuse to give a subject that has other sequences a body file from a different skeleton."""
    from ..io.body_file import read_body_file

    path = sdir / "Mocap_Data" / f"{sdir.name}_body.toml"
    if not path.exists():
        return
    others = [p for p in (sdir / "Image_Data").glob("*_(*).avi")
              if not p.name.startswith(f"{seq}_(")] if (sdir / "Image_Data").is_dir() else []
    if not others:
        return
    try:
        old = read_body_file(path)
    except InputError as exc:
        raise InputError(path, f"unreadable subject body file ({exc.problem}); remove it or "
                               "choose another --subject") from None
    for key in BODY_KEYS:
        a = np.asarray(getattr(old, key), dtype=float)
        b = np.asarray(getattr(body, key), dtype=float)
        if a.shape != b.shape or not np.all(np.abs(a - b) <= BODY_TOLERANCE):
            raise InputError(path, f"subject {sdir.name} already has other sequences with "
                                   f"another body ({key} {a.tolist()} mm, this motion "
                                   f"{b.tolist()} mm); choose another --subject")


def _gain(rng, noise, t, phase) -> float:
    """Per-frame gain: a slow mains-like beat plus white jitter, both scaled by ``noise``."""
    return float(1.0 + noise * (FLICKER * rng.standard_normal()
                                + 0.5 * FLICKER * np.sin(2 * np.pi * 0.7 * t + phase)))


def _write_backgrounds(renderer, rig, folder: Path, codec, fps, n, rng, noise, progress):
    from tqdm import tqdm

    folder.mkdir(parents=True, exist_ok=True)
    for cam in rig:
        # The blur is linear and the gain a scalar, so blurring the static radiance once gives
        # the same frames as blurring each one.
        bg = cv2.GaussianBlur(renderer.background(cam.name), (0, 0), BLUR)
        writer = _open_writer(folder / f"Background_1_({cam.name}).avi", codec, fps, cam.size)
        phase = rng.uniform(0, 2 * np.pi)
        try:
            for k in tqdm(range(n), disable=not progress, desc=f"background {cam.name}",
                          leave=False):
                img = sensor(bg, gray=cam.name.upper().startswith("BW"),
                             gain=_gain(rng, noise, k / fps, phase), noise_sigma=NOISE_SIGMA * noise,
                             rng=rng, blur=0.0)
                writer.write(img)
        finally:
            writer.release()


def _remove_sequence(sdir: Path, seq: str) -> None:
    """Delete an earlier version of sequence ``seq`` (all cameras), so no stale camera remains."""
    for sub in ("Image_Data", "Sync_Data", "Mask_Data"):
        folder = sdir / sub
        if not folder.is_dir():
            continue
        for path in folder.glob(f"{seq}_(*)*"):
            if path.is_dir():
                shutil.rmtree(path)
            else:
                path.unlink()


def _move_into(tmp: Path, out_dir: Path) -> None:
    """Move every file of ``tmp`` to the same relative place under ``out_dir`` (replacing)."""
    for path in sorted(tmp.rglob("*")):
        if path.is_dir():
            continue
        target = out_dir / path.relative_to(tmp)
        target.parent.mkdir(parents=True, exist_ok=True)
        if target.is_dir():
            shutil.rmtree(target)
        os.replace(path, target)
