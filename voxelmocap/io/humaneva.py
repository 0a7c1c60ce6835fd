"""HumanEva-I data sets on disk: layout discovery, ``.ofs`` synchronisation, frames, ground truth.

Layout (``HUMANEVA.md`` §1)::

    <root>/Background/Background_<k>_(<CAM>).avi
    <root>/<Subject>/Calibration_Data/<CAM>.cal
    <root>/<Subject>/Image_Data/<Action>_<Trial>_(<CAM>).avi      (or a folder of numbered images)
    <root>/<Subject>/Sync_Data/<Action>_<Trial>_(<CAM>).ofs
    <root>/<Subject>/Mocap_Data/<Action>_<Trial>.xml              (ground truth, body_pose XML)
    <root>/<Subject>/Mocap_Data/<Action>_<Trial>.mat, Static.mat, <Subject>.mp
                                                     (or raw mocap: see humaneva_mocap.py)
    <root>/<Subject>/Mocap_Data/<Subject>_body.toml               (subject dimensions, optional)

Folder names are matched case-insensitively (``Calibration_Data`` / ``Calibration_DATA``).
Cameras are ordered C1, C2, C3, BW1..BW4. Synchronised frame numbers F are 1-based; camera I shows
frame F at 1-based video frame ``starts[I] + F − 1`` (toolkit ``sync_stream`` / ``cur_image``, §3.2).

>>> ds = Dataset("data/HumanEva")                                   # doctest: +SKIP
>>> seq = ds.sequence("S1", "Walking_1")                            # doctest: +SKIP
>>> for F, images in seq.frames(range(6, 10)): ...                  # doctest: +SKIP
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Iterator
from functools import cached_property
from pathlib import Path

import numpy as np

from ..camera import Rig, sort_camera_names
from ..errors import InputError
from ..joints import endpoints_to_landmarks
from ._atomic import atomic_write_text
from ._files import read_text_file
from .body_pose_xml import BodyPoseSequence, read_body_pose_xml, write_body_pose_xml
from .calibration import read_rig
from .synchronised import SynchronisedVideos
from .video import VideoStream as _VideoStream

__all__ = [
    "BodyPoseSequence",
    "Dataset",
    "Sequence",
    "endpoints_to_landmarks",
    "read_body_pose_xml",
    "read_ofs",
    "sync_starts",
    "write_body_pose_xml",
    "write_ofs",
]

_SEQ_FILE = re.compile(r"^(?P<action>[A-Za-z]+)_(?P<trial>\d+)_\((?P<cam>[A-Za-z0-9]+)\)$")
_BACKGROUND = re.compile(r"^Background_(?P<k>[^_]+)_\((?P<cam>[A-Za-z0-9]+)\)\.avi$", re.I)
_GRAY_PREFIX = "BW"
#: HumanEva-I's cameras all record at 60 Hz; used when no video states its rate.
HUMANEVA_I_FRAME_RATE = 60.0


# ---------------------------------------------------------------------- .ofs and synchronisation
def read_ofs(path) -> tuple[float, float, float]:
    """Read a ``.ofs`` sync file: ``(im_st, mc_st, mc_sc)`` (``HUMANEVA.md`` §3.1).

    Raises
    ------
    InputError
        Missing file, not exactly 3 numbers, text, NaN/inf, a negative ``im_st`` or ``mc_st``
        (1-based frame indices), or a non-positive ``mc_sc``.
    """
    path = Path(path)
    tokens = read_text_file(path, "sync file", encoding="ascii").split()
    if len(tokens) != 3:
        raise InputError(path, f"expected 3 numbers (im_st, mc_st, mc_sc), found {len(tokens)} "
                               "values")
    values = []
    for token in tokens:
        try:
            value = float(token)
        except ValueError:
            raise InputError(path, f"value {token[:20]!r} is not a number") from None
        if not math.isfinite(value):
            raise InputError(path, f"value {token!r} is not finite")
        values.append(value)
    # A negative start is a broken file, not a timing: taken as is, it would move the common
    # timeline (sync_starts) and so the synchronised frames of every camera.
    if values[0] < 0:
        raise InputError(path, f"im_st (first image frame, 1-based) must not be negative, got "
                               f"{values[0]:g}")
    if values[1] < 0:
        raise InputError(path, f"mc_st (matching mocap frame, 1-based) must not be negative, got "
                               f"{values[1]:g}")
    if values[2] <= 0:
        raise InputError(path, f"mc_sc (mocap frames per image frame) must be > 0, got {values[2]}")
    return values[0], values[1], values[2]


def write_ofs(path, im_st: float, mc_st: float, mc_sc: float) -> None:
    """Write a ``.ofs`` sync file (three numbers, one per line), atomically."""
    atomic_write_text(Path(path), f"{im_st:.6f}\n{mc_st:.6f}\n{mc_sc:.6f}\n")


def sync_starts(ofs: dict[str, tuple[float, float, float]]):
    """The toolkit's common timeline (``sync_stream``, ``HUMANEVA.md`` §3.2).

    Parameters
    ----------
    ofs : dict of str to (im_st, mc_st, mc_sc)
        The enabled cameras' sync values, in HumanEva camera order (the first is the reference).

    Returns
    -------
    starts : dict of str to int
        Per camera, the 1-based video frame that shows synchronised frame 1.
    common_time : float
        1-based (fractional) mocap frame of synchronised frame 1.
    common_scaling : float
        Mocap frames per synchronised frame (mean of the ``mc_sc``).
    """
    if not ofs:
        raise ValueError("no enabled camera to synchronise")
    names = list(ofs)
    im0, common_time, common_scaling = ofs[names[0]]
    start = {names[0]: im0}
    for name in names[1:]:
        im_st, mc_st, mc_sc = ofs[name]
        start[name] = im_st + (common_time - mc_st) / mc_sc
        common_scaling += mc_sc
    common_scaling /= len(names)
    low = min(start.values())
    common_time -= common_scaling * (low - 1)
    start = {k: v - low + 1 for k, v in start.items()}
    if common_time < 1:
        start = {k: v - (common_time - 1) / common_scaling for k, v in start.items()}
        common_time = 1.0
    return {k: int(_matlab_round(v)) for k, v in start.items()}, common_time, common_scaling


def _matlab_round(x: float) -> float:
    # MATLAB's round() goes half away from zero; Python's round() goes half to even.
    return math.floor(abs(x) + 0.5) * (1 if x >= 0 else -1)


def _find_dir(parent: Path, name: str) -> Path | None:
    """Case-insensitive child directory lookup."""
    if not parent.is_dir():
        return None
    exact = parent / name
    if exact.is_dir():
        return exact
    for child in parent.iterdir():
        if child.is_dir() and child.name.lower() == name.lower():
            return child
    return None


def _is_gray(camera: str) -> bool:
    return camera.upper().startswith(_GRAY_PREFIX)


# ---------------------------------------------------------------------- data set and sequences
class Dataset:
    """A HumanEva-I-layout data set rooted at ``root``.

    Parameters
    ----------
    root : str or os.PathLike
        The folder holding ``S1/``, ``S2/`` … and ``Background/``.
    """

    def __init__(self, root):
        self.root = Path(root)
        if not self.root.is_dir():
            raise InputError(self.root, "data set folder not found")
        if not self.subjects:
            raise InputError(self.root, "no subject folders (with Image_Data or Sync_Data) here; "
                                        "expected the HumanEva-I layout <root>/S1/Image_Data/…")

    @cached_property
    def subjects(self) -> list[str]:
        """Subject folder names (those with ``Image_Data`` or ``Sync_Data``), sorted."""
        out = []
        for child in sorted(self.root.iterdir()):
            if child.is_dir() and (_find_dir(child, "Image_Data") or _find_dir(child, "Sync_Data")):
                out.append(child.name)
        return out

    def subject_dir(self, subject: str) -> Path:
        """The subject's folder (case-insensitive name)."""
        found = _find_dir(self.root, subject)
        if found is None:
            raise InputError(self.root, f"unknown subject {subject!r} (have "
                                        f"{', '.join(self.subjects) or 'none'})")
        return found

    def sequences(self, subject: str) -> list[str]:
        """``<Action>_<Trial>`` names of the subject's sequences (from Sync_Data and Image_Data)."""
        names = set()
        sdir = self.subject_dir(subject)
        for sub in ("Sync_Data", "Image_Data"):
            folder = _find_dir(sdir, sub)
            if folder is None:
                continue
            for p in folder.iterdir():
                m = _SEQ_FILE.match(p.stem if p.is_file() else p.name)
                if m:
                    names.add(f"{m['action']}_{m['trial']}")
        return sorted(names)

    def sequence(self, subject: str, sequence: str, cameras: Iterable[str] | None = None
                 ) -> Sequence:
        """Open one sequence; ``cameras`` restricts it to some camera names (case-insensitive)."""
        available = self.sequences(subject)
        match = [s for s in available if s.lower() == sequence.lower()]
        if not match:
            raise InputError(self.subject_dir(subject), f"unknown sequence {sequence!r} (have "
                                                        f"{', '.join(available) or 'none'})")
        return Sequence(self, self.subject_dir(subject).name, match[0], cameras)

    def background_dir(self) -> Path | None:
        """The ``Background`` folder, or None."""
        return _find_dir(self.root, "Background")


class Sequence(SynchronisedVideos):
    """One ``<Subject>/<Action>_<Trial>`` sequence: cameras, sync, frames and ground truth.

    Use :meth:`Dataset.sequence` to open one.
    """

    def __init__(self, dataset: Dataset, subject: str, name: str,
                 cameras: Iterable[str] | None = None):
        self.dataset = dataset
        self.subject = subject
        self.name = name
        self.action, self.trial = name.rsplit("_", 1)
        self.subject_dir = dataset.root / subject
        sync_dir = _find_dir(self.subject_dir, "Sync_Data")
        if sync_dir is None:
            raise InputError(self.subject_dir, "no Sync_Data folder")
        ofs_files = {}
        for p in sync_dir.iterdir():
            m = _SEQ_FILE.match(p.stem)
            if m and p.suffix.lower() == ".ofs" and f"{m['action']}_{m['trial']}" == name:
                ofs_files[m["cam"]] = p
        if not ofs_files:
            raise InputError(sync_dir, f"no .ofs sync files for {name}")
        all_names = sort_camera_names(ofs_files)
        #: cameras with a video of this sequence but no sync file: they cannot be used
        self.unsynced_cameras: list[str] = sort_camera_names(
            set(self._video_cameras()) - {c.upper() for c in all_names})
        #: one line per camera left out although the sequence has data for it (for logs, ``info``)
        self.problems: list[str] = [
            f"camera {cam} has a video but no sync file {sync_dir / f'{name}_({cam}).ofs'}: "
            "not used" for cam in self.unsynced_cameras]
        #: assumptions made in reading the sequence (none for this layout; see io.project)
        self.notes: list[str] = []
        names = all_names
        if cameras is not None:
            names = self._select(cameras, all_names, sync_dir)
        self.camera_names: list[str] = names
        #: every camera with a sync file, used or not
        self.all_camera_names: list[str] = all_names
        # The common timeline is built from every camera whose .ofs reads (toolkit sync_stream),
        # whichever cameras are used, so that frame F is the same instant for any subset.
        timeline = {}
        for cam in all_names:
            try:
                timeline[cam] = read_ofs(ofs_files[cam])
            except InputError as exc:
                if cam in names:
                    raise
                self.problems.append(f"camera {cam} (not used): {exc}; it is left out of the "
                                     "common timeline")
        self.ofs = {cam: timeline[cam] for cam in names}
        starts, self.common_time, self.common_scaling = sync_starts(timeline)
        self.starts = {cam: starts[cam] for cam in names}

    def _video_cameras(self) -> list[str]:
        """Upper-case names of the cameras with a video (AVI or image folder) of this sequence."""
        image_dir = _find_dir(self.subject_dir, "Image_Data")
        if image_dir is None:
            return []
        out = []
        for p in image_dir.iterdir():
            m = _SEQ_FILE.match(p.name if p.is_dir() else p.stem)
            if m and f"{m['action']}_{m['trial']}" == self.name and (
                    p.is_dir() or p.suffix.lower() == ".avi"):
                out.append(m["cam"].upper())
        return out

    def _select(self, cameras: Iterable[str], synced: list[str], sync_dir: Path) -> list[str]:
        """The requested cameras (case-insensitive) in HumanEva order; each must have a sync file."""
        wanted = [c.strip() for c in cameras if c.strip()]
        if not wanted:
            raise InputError("--cameras", "no camera names given")
        upper = {n.upper(): n for n in synced}
        unsynced = {c.upper(): c for c in self.unsynced_cameras}
        for cam in wanted:
            if cam.upper() in unsynced:
                raise InputError(sync_dir / f"{self.name}_({unsynced[cam.upper()]}).ofs",
                                 f"sync file not found: camera {unsynced[cam.upper()]} of "
                                 f"{self.subject}/{self.name} cannot be synchronised")
            if cam.upper() not in upper:
                have = sort_camera_names([*synced, *self.unsynced_cameras])
                raise InputError("--cameras", f"unknown camera {cam!r} ({self.subject}/{self.name} "
                                              f"has {', '.join(have)})")
        return sort_camera_names({upper[c.upper()] for c in wanted})

    # ------------------------------------------------------------------ calibration
    @cached_property
    def rig(self) -> Rig:
        """The cameras' calibration (``Calibration_Data/<CAM>.cal``), in ``camera_names`` order."""
        cal_dir = _find_dir(self.subject_dir, "Calibration_Data")
        if cal_dir is None:
            raise InputError(self.subject_dir, "no Calibration_Data folder")
        return read_rig(cal_dir, names=self.camera_names)

    # ------------------------------------------------------------------ images
    def video_path(self, camera: str) -> Path:
        """The camera's AVI file or numbered-image folder (the folder wins, as in the toolkit)."""
        image_dir = _find_dir(self.subject_dir, "Image_Data")
        if image_dir is None:
            raise InputError(self.subject_dir, "no Image_Data folder")
        stem = f"{self.name}_({camera})"
        folder = image_dir / stem
        if folder.is_dir():
            return folder
        for p in image_dir.iterdir():
            if p.is_file() and p.stem.lower() == stem.lower() and p.suffix.lower() == ".avi":
                return p
        raise InputError(image_dir / f"{stem}.avi", "video not found")

    @cached_property
    def _streams(self) -> dict[str, _VideoStream]:
        streams = {cam: _VideoStream(self.video_path(cam), _is_gray(cam))
                   for cam in self.camera_names}
        for stream in streams.values():  # an image folder's every frame, from its bytes: info
            stream.check_frames()        # and track refuse a bad frame before any work
        return streams

    @cached_property
    def frame_rate(self) -> float:
        """Frames per second: the first used camera's video metadata, else 60 Hz (HumanEva-I)."""
        for cam in self.camera_names:
            if self._streams[cam].fps is not None:
                return self._streams[cam].fps
        return HUMANEVA_I_FRAME_RATE

    def check_video_sizes(self) -> None:
        """Decode each camera's first frame and compare its size with the calibration's."""
        for cam in self.camera_names:
            image = self._streams[cam].first_frame()
            h, w = image.shape[:2]
            if (w, h) != tuple(self.rig[cam].size):
                raise InputError(self._streams[cam].path,
                                 f"frame size {w}x{h} differs from the calibration's "
                                 f"{self.rig[cam].size[0]}x{self.rig[cam].size[1]}")

    # ------------------------------------------------------------------ backgrounds
    def background_paths(self, camera: str) -> list[Path]:
        """``Background/Background_*_(<CAM>).avi`` files of a camera (may be empty)."""
        bdir = self.dataset.background_dir()
        if bdir is None:
            return []
        out = []
        for p in sorted(bdir.iterdir()):
            m = _BACKGROUND.match(p.name)
            if m and m["cam"].upper() == camera.upper():
                out.append(p)
        return out

    def check_backgrounds(self) -> None:
        """Open every background video of every camera and check its frame size."""
        for cam in self.camera_names:
            for path in self.background_paths(cam):
                image = _VideoStream(path, _is_gray(cam)).first_frame()
                if (image.shape[1], image.shape[0]) != tuple(self.rig[cam].size):
                    raise InputError(path, f"frame size {image.shape[1]}x{image.shape[0]} differs "
                                           f"from the calibration's {self.rig[cam].size}")

    def background_sets(self, camera: str, *, max_frames: int | None = None
                        ) -> list[list[np.ndarray]]:
        """Per background video of a camera, its first ``max_frames`` frames (a list each)."""
        out = []
        for path in self.background_paths(camera):
            stream = _VideoStream(path, _is_gray(camera))
            n = stream.n_frames if max_frames is None else min(max_frames, stream.n_frames)
            out.append([image for _, image in stream.read(range(n))])
        return out

    def background_frames(self, camera: str, *, max_frames: int | None = None
                          ) -> Iterator[np.ndarray]:
        """Frames of all background videos of a camera (same colour handling as :meth:`frames`)."""
        count = 0
        for path in self.background_paths(camera):
            stream = _VideoStream(path, _is_gray(camera))
            for _, image in stream.read(range(stream.n_frames)):
                if max_frames is not None and count >= max_frames:
                    return
                count += 1
                yield image

    # ------------------------------------------------------------------ ground truth
    @property
    def ground_truth_path(self) -> Path | None:
        """``Mocap_Data/<Action>_<Trial>.xml`` when it exists."""
        mdir = _find_dir(self.subject_dir, "Mocap_Data")
        if mdir is None:
            return None
        for p in mdir.iterdir():
            if p.is_file() and p.name.lower() == f"{self.name}.xml".lower():
                return p
        return None

    @property
    def ground_truth_source(self) -> str | None:
        """Where :meth:`ground_truth` comes from: ``"body_pose XML <file>"``, ``"raw mocap
        <Action>_<Trial>.mat + <Subject>.mp"`` (:mod:`voxelmocap.io.humaneva_mocap`) or None."""
        if self.ground_truth_path is not None:
            return f"body_pose XML {self.ground_truth_path.name}"
        from .humaneva_mocap import find_mocap_files

        files = find_mocap_files(self.subject_dir, self.subject, self.name)
        return None if files is None else files.describe()

    def ground_truth(self) -> BodyPoseSequence | None:
        """The ground-truth poses: the body_pose XML, else computed from the raw mocap files as
        the toolkit does (``mocap_stream``, synchronised by this sequence's ``.ofs``), else None."""
        path = self.ground_truth_path
        if path is not None:
            return read_body_pose_xml(path)
        from .humaneva_mocap import sequence_ground_truth

        return sequence_ground_truth(self)

    @property
    def body_file(self) -> Path | None:
        """``Mocap_Data/<Subject>_body.toml`` when it exists."""
        mdir = _find_dir(self.subject_dir, "Mocap_Data")
        if mdir is None:
            return None
        for p in mdir.iterdir():
            if p.is_file() and p.name.lower() == f"{self.subject}_body.toml".lower():
                return p
        return None

    def __repr__(self) -> str:
        return (f"Sequence({self.subject}/{self.name}, cameras={','.join(self.camera_names)}, "
                f"starts={self.starts})")
