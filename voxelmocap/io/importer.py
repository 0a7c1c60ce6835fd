"""``voxelmocap import``: write a project's trial into the HumanEva-I layout (tracking does not need it).

The trial's synchronised frames are copied as decoded, losslessly (FFV1 AVI, the frame rate kept
in the container), so tracking the imported sequence sees the very pixels tracking the project
sees::

    <out>/<Subject>/Calibration_Data/<CAM>.cal + sizes.toml   (the rig, mm, image sizes as read)
    <out>/<Subject>/Image_Data/<Action>_1_(<CAM>).avi         (FFV1, frames 1..N)
    <out>/<Subject>/Sync_Data/<Action>_1_(<CAM>).ofs          (1, 1, 1: already synchronised)
    <out>/Background/Background_1_(<CAM>).avi                 (when the trial has backgrounds)

HumanEva names allow letters and digits only: camera names lose every other character
(``cam_01`` → ``cam01``), the action is the trial's name reduced to letters; the camera names are
mapped in the returned outcome.
"""

from __future__ import annotations

import contextlib
import dataclasses
import re
from dataclasses import dataclass
from pathlib import Path

import cv2

from ..camera import Rig
from ..errors import InputError
from ._atomic import ensure_output_dir
from .video import VideoStream

__all__ = ["ImportOutcome", "humaneva_name", "import_sequence"]

_LOSSLESS = "FFV1"


@dataclass
class ImportOutcome:
    """What :func:`import_sequence` wrote."""

    root: Path
    subject: str
    sequence: str
    cameras: dict[str, str]  #: project camera name → HumanEva camera name
    frames: int


def humaneva_name(name: str, what: str, *, letters_only: bool = False) -> str:
    """``name`` reduced to the characters a HumanEva file name allows."""
    out = re.sub(r"[^A-Za-z]" if letters_only else r"[^A-Za-z0-9]", "", name)
    if not out:
        raise InputError(what, f"{name!r} has no {'letter' if letters_only else 'letter or digit'} "
                               "to name it in the HumanEva layout")
    return out


class _LosslessVideo:
    """An FFV1 AVI written to a temporary name and renamed when complete (deleted on failure)."""

    def __init__(self, path: Path, fps: float, size):
        self.path = path
        self.tmp = path.with_name(f".{path.stem}.partial.avi")
        self.writer = cv2.VideoWriter(str(self.tmp), cv2.VideoWriter_fourcc(*_LOSSLESS),
                                      float(fps), tuple(size))
        self.count = 0
        if not self.writer.isOpened():
            self.tmp.unlink(missing_ok=True)
            raise InputError(path, f"OpenCV cannot write {_LOSSLESS} video here")

    def write(self, image) -> None:
        if image.ndim == 2:
            image = cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)
        self.writer.write(image)
        self.count += 1

    def close(self, ok: bool) -> None:
        self.writer.release()
        if ok:
            # OpenCV's writer does not report a failed write (a full disk): the file is read
            # back, and one that does not hold every frame is not renamed into place.
            cap = cv2.VideoCapture(str(self.tmp))
            written = int(cap.get(cv2.CAP_PROP_FRAME_COUNT)) if cap.isOpened() else 0
            cap.release()
            if written != self.count:
                self.tmp.unlink(missing_ok=True)
                raise InputError(self.path, f"cannot write the video ({written} of {self.count} "
                                            "frames reached the disk: is it full?)")
            try:
                self.tmp.replace(self.path)
            except OSError as exc:
                self.tmp.unlink(missing_ok=True)
                raise InputError(self.path, f"cannot write here ({exc.strerror or exc})") from None
        else:
            self.tmp.unlink(missing_ok=True)


def _write_avi(path: Path, frames, fps: float, size) -> int:
    video = _LosslessVideo(path, fps, size)
    ok = False
    try:
        for image in frames:
            video.write(image)
        ok = True
    finally:
        video.close(ok)
    return video.count


def import_sequence(seq, out, *, subject: str = "S1", action: str | None = None,
                    progress: bool = True, log=print) -> ImportOutcome:
    """Write an opened sequence (a project's trial) into the HumanEva-I layout under ``out``
    (see :func:`_import`); a failed import (a full disk, an interruption) removes every file and
    folder it created, so the data set is as it was."""
    out = Path(out)
    existed = out.exists()
    before = set(out.rglob("*")) if existed and out.is_dir() else set()
    try:
        return _import(seq, out, subject=subject, action=action, progress=progress, log=log)
    except BaseException:
        if out.is_dir():
            created = [q for q in out.rglob("*") if q not in before]
            for q in sorted(created, key=lambda q: len(q.parts), reverse=True):
                with contextlib.suppress(OSError):
                    q.rmdir() if q.is_dir() and not q.is_symlink() else q.unlink()
            if not existed:
                with contextlib.suppress(OSError):
                    out.rmdir()
        raise


def _import(seq, out, *, subject: str, action: str | None, progress: bool,
            log) -> ImportOutcome:
    """Write an opened sequence (a project's trial) into the HumanEva-I layout under ``out``.

    Parameters
    ----------
    seq : voxelmocap.io.project_sequence.ProjectSequence or voxelmocap.io.humaneva.Sequence
        The sequence (:func:`voxelmocap.io.sequence.open_sequence`).
    out : str or os.PathLike
        The data set root to write (created; an existing sequence of the same name is refused).
    subject : str
        Subject folder name.
    action : str, optional
        Action name (letters); default the trial's name reduced to letters.
    progress : bool
        Show a progress bar.
    log : callable
        Where one-line messages go.
    """
    from .calibration import write_rig
    from .humaneva import write_ofs

    subject = humaneva_name(subject, "--subject")
    action = humaneva_name(action or seq.name, "--action", letters_only=True)
    name = f"{action}_1"
    rig = seq.rig
    mapping = {cam.name: humaneva_name(cam.name, f"camera {cam.name}") for cam in rig}
    if len({v.upper() for v in mapping.values()}) != len(mapping):
        raise InputError("cameras", f"camera names collide once reduced to letters and digits: "
                                    f"{mapping}")
    root = ensure_output_dir(out)
    sdir = root / subject
    image_dir, sync_dir, cal_dir = (sdir / "Image_Data", sdir / "Sync_Data",
                                    sdir / "Calibration_Data")
    for folder in (image_dir, sync_dir, cal_dir):
        folder.mkdir(parents=True, exist_ok=True)
    existing = [p for p in image_dir.iterdir() if p.name.lower().startswith(name.lower() + "_(")]
    if existing:
        raise InputError(existing[0], f"sequence {subject}/{name} exists already")
    fps = seq.frame_rate
    for note in seq.notes:
        log(f"note: {note}")
    write_rig(Rig(dataclasses.replace(cam, name=mapping[cam.name]) for cam in rig), cal_dir)
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=seq.n_frames, desc=f"import {seq.name}", unit="frame")
    # One pass over the frames, every camera's video open at once: each frame is decoded once.
    videos = {}
    ok = False
    try:
        for cam in rig:
            videos[cam.name] = _LosslessVideo(image_dir / f"{name}_({mapping[cam.name]}).avi", fps,
                                              cam.size)
        for _, images in seq.frames():
            for cam_name, video in videos.items():
                video.write(images[cam_name])
            if bar is not None:
                bar.update(1)
        ok = True
    finally:
        failed = None
        for video in videos.values():  # every one closed (and, on a failure, deleted)
            try:
                video.close(ok and failed is None)
            except InputError as exc:
                failed = failed or exc
        if bar is not None:
            bar.close()
    if failed is not None:
        raise failed
    n = seq.n_frames
    for cam in rig:
        he = mapping[cam.name]
        write_ofs(sync_dir / f"{name}_({he}).ofs", 1, 1, 1)
        for k, path in enumerate(seq.background_paths(cam.name), start=1):
            stream = VideoStream(path, gray=False)
            bdir = root / "Background"
            bdir.mkdir(exist_ok=True)
            _write_avi(bdir / f"Background_{k}_({he}).avi",
                       (im for _, im in stream.read(range(stream.n_frames))), fps, cam.size)
    log(f"imported {seq.name} as {subject}/{name}: {n} frames, cameras "
        + ", ".join(f"{k} → {v}" if k != v else k for k, v in mapping.items()))
    return ImportOutcome(root, subject, name, mapping, n)
