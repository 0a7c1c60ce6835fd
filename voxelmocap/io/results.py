"""Tracking results in HDF5: one self-describing file per sequence, streamed one frame at a time.

``RUN/<Subject>/<Action>_<Trial>.h5`` holds

* per-frame datasets, frames along axis 0, each with ``units`` and ``description`` attributes:
  ``frames`` (F,) synchronised 1-based frame numbers, ``state`` (F, 27) and ``map_state`` (F, 27)
  (mm, rad; names in ``state_names``), ``landmarks`` (F, 15, 3) mm, ``endpoints`` (F, 20, 3) mm,
  ``part_scores`` (F, n_parts, 4) of the estimate (Out, DO, Empty, Surf), ``ess`` and ``betas``
  (F, L) per annealing layer, ``seconds`` (F,) per frame, ``log_likelihood`` (F,);
  ``landmark_spread`` (F, 15) mm and ``confidence`` (F, 15) in [0, 1] per landmark
  (:mod:`voxelmocap.pose.confidence`), ``observed`` (F,) uint8 (0: flagged without a person, the row
  repeating the last estimate, ``voxelmocap.pose.recovery``; format 3 on —
  a format-2 file reads as NaN spread and confidence and every frame observed);
* ``state_names`` and ``part_names``: UTF-8 string datasets;
* file attributes: ``format`` / ``format_version``, ``voxelmocap_version``, ``created`` (UTC, ISO
  8601), ``length_unit`` ``"mm"``, ``angle_unit`` ``"rad"``, ``coordinate_frame`` (Z up, floor at
  Z = 0), ``frame_rate`` (Hz), ``landmark_names``, ``endpoint_names``, ``state_names``,
  ``part_names``, ``score_names``, and what the writer was given (``config`` TOML, ``seed``,
  ``dataset`` = the data source, ``subject``, ``action``, ``trial``, ``cameras``, ``body_model``,
  ``init_method``, ``frames_requested``, ``person_masks`` = the ``--masks`` folder or empty,
  ``plate_from`` = the ``--plate-from`` result file or empty);
  strings are UTF-8 (variable length);
* ``commit`` (3,) int64: the number of committed frames, the checkpoint slot holding their filter
  state (−1 for none) and 1 once the run is complete. **Rows beyond the committed count are not
  results** (a killed run may leave one half-written row); :func:`read_result` drops them.
* ``checkpoint_0``, ``checkpoint_1``: uint8, an uncompressed NumPy ``.npz`` archive of the filter
  state after the committed frames (``np.load(io.BytesIO(bytes))``), so ``--resume`` continues
  bit-identically. The two slots alternate: a frame's state goes into the slot not committed.

Writing (:class:`ResultWriter`). The file is created under a temporary name
(``.<name>.partial`` beside it), switched to HDF5's single-writer/multiple-reader (SWMR) mode and
renamed into place, then each frame is appended: the per-frame rows and the checkpoint slot are
written and flushed, and only then the ``commit`` record, flushed again. SWMR mode orders HDF5's
metadata writes so that the file on disk is consistent at every instant; with the commit written
last, a run killed at any moment leaves a readable file holding every completed frame and the
checkpoint of the last one. The cost of a frame does not grow with the sequence (chunked, resizable
datasets; ``scripts/bench_results.py``). The writer holds an exclusive ``flock`` on the file for
the whole run (released by the kernel when the process dies), so a second run on the same result
is refused; a short ``flock`` on the folder serialises creation and renaming. The temporary file
exists only while a file is being created; one left by a killed creation is removed by the next
writer in that folder.

Reading. A file being written, or left by a killed run, still carries HDF5's "open for writing"
mark: :func:`read_result` opens it in SWMR-read mode; other tools need ``h5py.File(path, "r",
swmr=True, locking=False)`` (or ``h5clear -s``). ``--resume`` copies the committed frames into a
fresh file, which clears the mark. While a writer runs, a read can overlap its flush (HDF5 then
sees the file's end before its data) or its next commit (which may rewrite the checkpoint slot
two commits on): :func:`read_result` reads the commit record again after the checkpoint and
repeats a read that a running writer disturbed, so it returns the frames committed at one
instant.
"""

from __future__ import annotations

import contextlib
import datetime
import fcntl
import io
import json
import os
import time
from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

from ..errors import InputError

__all__ = ["FORMAT", "FORMAT_VERSION", "PER_FRAME", "ResultWriter", "TrackResult",
           "check_not_being_written", "read_result", "write_result"]

FORMAT = "voxelmocap tracking result"
FORMAT_VERSION = 3
#: Datasets added in format 3, and what an older file reads as (see :class:`TrackResult`).
_ADDED_IN_3 = ("landmark_spread", "confidence", "observed")

#: Per-frame datasets: name → (units, description).
PER_FRAME: dict[str, tuple[str, str]] = {
    "frames": ("1", "synchronised 1-based frame number"),
    "state": ("mm (translation), rad (angles)", "the estimate: weighted mean of the last "
              "annealing layer, clipped to the legal ranges; names in state_names"),
    "landmarks": ("mm", "the 15 landmarks of the estimate, names in landmark_names"),
    "endpoints": ("mm", "the 20 body_pose endpoints of the estimate, names in endpoint_names"),
    "part_scores": ("1", "Out, DO, Empty, Surf of each body part of the estimate (part_names, "
                    "score_names)"),
    "ess": ("particles", "effective sample size of each annealing layer"),
    "betas": ("1", "likelihood exponent of each annealing layer"),
    "seconds": ("s", "wall time of the frame: measurement, initialisation and filter"),
    "log_likelihood": ("1", "log-likelihood of the estimate (paper 002 eqs 7-9)"),
    "map_state": ("mm (translation), rad (angles)", "the particle of largest last-layer weight"),
    "landmark_spread": ("mm", "weighted RMS distance of each landmark over the last layer's "
                        "particles (NaN: unknown)"),
    "confidence": ("1", "confidence of each landmark in [0, 1]: voxel support of its parts x "
                   "P(error < 100 mm) for the particles' spread (voxelmocap.pose.confidence)"),
    "observed": ("1", "1 when a person was seen in the frame, 0 when not (then the estimate "
                 "is the filter's prediction)"),
}
#: What a record without the format-3 attributes (e.g. one made before them) writes.
_ROW_DEFAULTS = {"landmark_spread": np.full(15, np.nan), "confidence": np.full(15, np.nan),
                 "observed": 1}
_INT_ROWS = {"frames"}
_UINT8_ROWS = {"observed"}
_CHUNK_ROWS = 64  # rows per chunk: a few kB per dataset, rewritten at most once per frame
_STR = h5py.string_dtype("utf-8")
_LOCKING = False  # this module's own flock guards the file; HDF5's would block its readers
_SCORE_NAMES = ("out", "do", "empty", "surf")
_HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"
#: How long a reader keeps retrying a file whose writer moves under it (each try: milliseconds).
_LIVE_READ_SECONDS = 5.0
#: How long a new writer waits out readers' momentary shared locks before calling a file busy.
_LOCK_PATIENCE_SECONDS = 0.5
_COORDINATE_FRAME = ("world frame of the cameras' calibration: right-handed, Z up, floor at Z = 0,"
                     " lengths in mm")


@dataclass
class TrackResult:
    """In-memory form of a result file (per-frame arrays stacked along axis 0).

    ``attrs`` holds the file's attributes and ``complete`` (whether the run finished);
    ``checkpoint`` the filter state after the last frame (None when the file has none).
    """

    frames: np.ndarray
    state: np.ndarray
    landmarks: np.ndarray
    endpoints: np.ndarray
    part_scores: np.ndarray
    ess: np.ndarray
    betas: np.ndarray
    seconds: np.ndarray
    log_likelihood: np.ndarray
    map_state: np.ndarray
    state_names: list = field(default_factory=list)
    part_names: list = field(default_factory=list)
    attrs: dict = field(default_factory=dict)
    checkpoint: dict | None = None
    #: (F, 15) mm; NaN when unknown (results before format 3)
    landmark_spread: np.ndarray | None = None
    #: (F, 15) in [0, 1]; NaN when unknown
    confidence: np.ndarray | None = None
    #: (F,) bool; all True when unknown
    observed: np.ndarray | None = None

    def __post_init__(self) -> None:
        n = len(self.frames)
        if self.landmark_spread is None:
            self.landmark_spread = np.full((n, 15), np.nan)
        if self.confidence is None:
            self.confidence = np.full((n, 15), np.nan)
        self.observed = (np.ones(n, dtype=bool) if self.observed is None
                         else np.asarray(self.observed, dtype=bool))

    def __len__(self) -> int:
        return len(self.frames)


# ---------------------------------------------------------------------- checkpoints as bytes
def _pack_checkpoint(state: dict) -> np.ndarray:
    """A filter state (arrays, numbers, strings, dicts, None) as the bytes of an ``.npz``."""
    arrays = {k: v for k, v in state.items() if isinstance(v, np.ndarray)}
    scalars = {k: v for k, v in state.items() if not isinstance(v, np.ndarray)}
    if any(a.dtype.hasobject for a in arrays.values()):
        raise TypeError("cannot store object arrays in a checkpoint")
    text = json.dumps(scalars, default=_json_default).encode()
    buffer = io.BytesIO()
    np.savez(buffer, __scalars__=np.frombuffer(text, dtype=np.uint8), **arrays)
    return np.frombuffer(buffer.getvalue(), dtype=np.uint8)


def _json_default(value):
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.floating):
        return float(value)
    raise TypeError(f"cannot store {type(value).__name__} in a checkpoint")


def _unpack_checkpoint(data: np.ndarray) -> dict:
    with np.load(io.BytesIO(np.asarray(data, dtype=np.uint8).tobytes()),
                 allow_pickle=False) as z:
        state = json.loads(bytes(z["__scalars__"]).decode())
        for key in z.files:
            if key != "__scalars__":
                state[key] = z[key]
    return state


# ---------------------------------------------------------------------- locks
@contextlib.contextmanager
def _folder_lock(folder: Path):
    """Exclusive flock on a folder while files in it are created and renamed (milliseconds)."""
    fd = os.open(folder, os.O_RDONLY)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)  # closing releases the lock


def _try_lock(path: Path) -> int | None:
    """An fd holding an exclusive flock on ``path``, or None when another process holds one."""
    try:
        fd = os.open(path, os.O_RDONLY)
    except FileNotFoundError:
        return None
    deadline = time.monotonic() + _LOCK_PATIENCE_SECONDS
    while True:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            return fd
        except BlockingIOError:
            # A reader checking for a writer holds a shared lock for microseconds; a writer
            # holds its lock for the whole run.
            if time.monotonic() > deadline:
                os.close(fd)
                return None
        time.sleep(0.01)


def _busy(path) -> InputError:
    return InputError(path, "another track run is writing this result; wait for it to finish "
                            "or choose another --out")


def check_not_being_written(path) -> None:
    """Raise the busy error when a running :class:`ResultWriter` holds ``path``.

    A run that tracks passes before its final result asks this first, so a result another
    run is writing is refused before the passes, not after them. It is a courtesy, not the
    guard: the final pass's own writer still takes the lock.

    Raises
    ------
    InputError
        "another track run is writing this result …".
    """
    if _being_written(Path(path)):
        raise _busy(path)


def _utc_now() -> str:
    return datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")


def _version() -> str:
    from .. import __version__

    return __version__


# ---------------------------------------------------------------------- writing
class ResultWriter:
    """Exclusive, streamed writing of one result file (see the module docstring).

    Use as a context manager; :meth:`start` creates the file, :meth:`append` adds one frame.

    Parameters
    ----------
    path : str or os.PathLike
        The result file ``RUN/<Subject>/<Action>_<Trial>.h5``.

    Raises
    ------
    InputError
        When ``path`` is a folder, its parent cannot be a folder, or another run holds the file.

    Examples
    --------
    >>> with ResultWriter(path) as out:                             # doctest: +SKIP
    ...     out.start(first_record, attrs={...}, state_names=..., part_names=...)
    ...     out.append(first_record, filter_state, complete=False)
    """

    def __init__(self, path):
        from ._atomic import ensure_output_dir

        self.path = Path(path)
        if self.path.is_dir():
            raise InputError(self.path, "is a folder; give a file name")
        ensure_output_dir(self.path.parent)
        self.temp = self.path.with_name(f".{self.path.name}.partial")
        self._file: h5py.File | None = None
        self._n = 0
        self._slot = -1
        self._fd = _try_lock(self.path) if self.path.exists() else None
        if self.path.exists() and self._fd is None:
            raise _busy(self.path)

    def __enter__(self) -> ResultWriter:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    @property
    def n_frames(self) -> int:
        """Frames committed so far."""
        return self._n

    @property
    def started(self) -> bool:
        """Whether :meth:`start` created the file."""
        return self._file is not None

    def read_existing(self) -> TrackResult | None:
        """The current file's committed content (read under this writer's lock), or None."""
        if self._fd is None:
            return None
        return _read_once(self.path)  # under the lock: nobody moves it, no retrying

    def start(self, template=None, *, attrs: dict, state_names, part_names,
              previous: TrackResult | None = None, replace: bool = False) -> None:
        """Create the file (with ``previous``'s frames and checkpoint, when resuming).

        Parameters
        ----------
        template : object, optional
            A frame record (attributes named like :data:`PER_FRAME`, ``frame`` for ``frames``)
            that sets each dataset's row shape; default the rows of ``previous``.
        attrs : dict
            File attributes (str, numbers, bool, lists of str); ``frame_rate`` is required.
        state_names, part_names : sequence of str
        previous : TrackResult, optional
            Frames (and checkpoint) to carry over; ``previous.attrs["complete"]`` is kept.
        replace : bool
            Replace an existing file (which this writer must have locked) instead of refusing.
        """
        from ..joints import ENDPOINT_NAMES, LANDMARK_NAMES

        if self._file is not None:
            raise RuntimeError("ResultWriter.start: already started")
        if "frame_rate" not in attrs:
            raise ValueError("ResultWriter.start: attrs need the frame_rate")
        header = {
            "voxelmocap_version": _version(), "created": _utc_now(),
            "length_unit": "mm", "angle_unit": "rad", "coordinate_frame": _COORDINATE_FRAME,
            "landmark_names": list(LANDMARK_NAMES), "endpoint_names": list(ENDPOINT_NAMES),
            "state_names": list(state_names), "part_names": list(part_names),
            "score_names": list(_SCORE_NAMES), **attrs,
            # what this writer writes, whatever attrs a converted older file carried
            "format": FORMAT, "format_version": FORMAT_VERSION,
        }
        with _folder_lock(self.path.parent):
            self._check_target(replace)
            if self.temp.exists():  # left by a killed creation: nobody creates without this lock
                self.temp.unlink()
            try:
                f = h5py.File(self.temp, "w", libver="latest", locking=_LOCKING)
            except OSError as exc:
                raise InputError(self.path, f"cannot write the result ({exc})") from None
            try:
                self._create(f, template, header, state_names, part_names, previous)
                f.flush()
                f.swmr_mode = True
                fd = os.open(self.temp, os.O_RDONLY)
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)  # a new inode: nobody else has it
                os.replace(self.temp, self.path)
            except BaseException:
                f.close()
                self.temp.unlink(missing_ok=True)
                raise
        if self._fd is not None:
            os.close(self._fd)  # the replaced file's lock
        self._fd, self._file = fd, f

    def _check_target(self, replace: bool) -> None:
        """Under the folder lock: may this writer put a new file at ``path``?"""
        if not self.path.exists():
            return
        if self._fd is not None and os.fstat(self._fd).st_ino == os.stat(self.path).st_ino:
            if replace:
                return
            raise InputError(self.path, "result exists; use --resume to continue it or "
                                        "--overwrite to replace it")
        # The file appeared (or was replaced) after this writer was made.
        fd = _try_lock(self.path)
        if fd is None:
            raise _busy(self.path)
        os.close(fd)
        raise InputError(self.path, "another run created this result meanwhile; use --resume "
                                    "or --overwrite")

    def _create(self, f, template, header, state_names, part_names, previous) -> None:
        for key, value in header.items():
            _set_attr(f.attrs, key, value)
        f.create_dataset("state_names", data=list(state_names), dtype=_STR)
        f.create_dataset("part_names", data=list(part_names), dtype=_STR)
        n = 0 if previous is None else len(previous)
        for name, (units, description) in PER_FRAME.items():
            if template is not None:
                shape = np.shape(_row(template, name))
            else:
                shape = np.shape(getattr(previous, name))[1:]
            dtype = np.int64 if name in _INT_ROWS else np.uint8 if name in _UINT8_ROWS \
                else np.float64
            rows = np.empty((n,) + shape, dtype) if previous is None else np.asarray(
                getattr(previous, name), dtype=dtype).reshape((n,) + shape)
            d = f.create_dataset(name, data=rows, maxshape=(None,) + shape,
                                 chunks=(_CHUNK_ROWS,) + shape, dtype=dtype)
            d.attrs["units"] = units
            d.attrs["description"] = description
        for slot in (0, 1):
            d = f.create_dataset(f"checkpoint_{slot}", shape=(0,), maxshape=(None,),
                                 chunks=(1 << 16,), dtype=np.uint8)
            d.attrs["description"] = ("filter state after the committed frames when commit[1] "
                                      f"== {slot}: the bytes of an uncompressed NumPy .npz")
        slot = -1
        if previous is not None and previous.checkpoint is not None:
            slot = 0
            _write_blob(f["checkpoint_0"], _pack_checkpoint(previous.checkpoint))
        complete = int(bool(previous is not None and previous.attrs.get("complete")))
        d = f.create_dataset("commit", data=np.array([n, slot, complete], dtype=np.int64))
        d.attrs["description"] = ("committed frames, checkpoint slot (-1: none), complete (0/1); "
                                  "rows beyond the committed frames are not results")
        self._n, self._slot = n, slot

    def append(self, record, checkpoint: dict | None, *, complete: bool = False) -> None:
        """Add one frame and the filter state after it, then commit them.

        Parameters
        ----------
        record : object
            Attributes named like :data:`PER_FRAME` (``frame`` for ``frames``), e.g. a
            :class:`voxelmocap.pose.records.FrameRecord`.
        checkpoint : dict or None
            The filter state after this frame (None: the file then has no checkpoint).
        complete : bool
            Whether this is the run's last frame.
        """
        f = self._file
        if f is None:
            raise RuntimeError("ResultWriter.append: call start() first")
        n = self._n
        for name in PER_FRAME:
            d = f[name]
            d.resize(n + 1, axis=0)
            d[n] = _row(record, name)
        slot = -1  # without a new state, no checkpoint matches the frames any more
        if checkpoint is not None:
            slot = 1 if self._slot == 0 else 0  # never overwrite the committed state
            _write_blob(f[f"checkpoint_{slot}"], _pack_checkpoint(checkpoint))
        # Everything above reaches the file before the commit that makes it count.
        f.flush()
        f["commit"][...] = (n + 1, slot, int(complete))
        f.flush()
        self._n, self._slot = n + 1, slot

    def close(self) -> None:
        """Close the file and release the lock (idempotent)."""
        if self._file is not None:
            self._file.close()
            self._file = None
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None


def _row(record, name: str):
    """A record's row of dataset ``name`` (``frame`` for ``frames``; defaults for format 3's)."""
    if name in _ROW_DEFAULTS:
        return getattr(record, name, _ROW_DEFAULTS[name])
    return getattr(record, "frame" if name == "frames" else name)


def _write_blob(d: h5py.Dataset, data: np.ndarray) -> None:
    d.resize((len(data),))
    d[:] = data


def _set_attr(attrs, key: str, value) -> None:
    if isinstance(value, str):
        attrs.create(key, data=value, dtype=_STR)
    elif isinstance(value, (list, tuple)) and all(isinstance(v, str) for v in value):
        attrs.create(key, data=list(value), dtype=_STR)
    elif value is None:
        attrs.create(key, data="", dtype=_STR)
    else:
        attrs[key] = value


def write_result(path, result: TrackResult) -> None:
    """Write a whole result at once, replacing any file (for tests and conversions).

    ``result.attrs`` may hold ``complete``; ``frame_rate`` defaults to HumanEva-I's 60 Hz.
    """
    attrs = {k: v for k, v in result.attrs.items() if k != "complete"}
    attrs.setdefault("frame_rate", 60.0)
    with ResultWriter(path) as out:
        out.start(attrs=attrs, state_names=result.state_names, part_names=result.part_names,
                  previous=result, replace=True)


# ---------------------------------------------------------------------- reading
def _check_shapes(path, data: dict) -> None:
    n = len(np.atleast_1d(data["frames"]))
    expected = {"frames": (n,), "state": (n, None), "landmarks": (n, 15, 3),
                "endpoints": (n, 20, 3), "part_scores": (n, None, 4), "ess": (n, None),
                "betas": (n, None), "seconds": (n,), "log_likelihood": (n,),
                "map_state": (n, None), "landmark_spread": (n, 15), "confidence": (n, 15),
                "observed": (n,)}
    for name, shape in expected.items():
        got = np.shape(data[name])
        if len(got) != len(shape) or any(e is not None and g != e
                                         for g, e in zip(got, shape, strict=True)):
            want = "×".join("*" if e is None else str(e) for e in shape)
            raise InputError(path, f"dataset {name!r} has shape {got}, expected {want}")


def _attr_value(value):
    if isinstance(value, bytes):
        return value.decode("utf-8", "replace")
    if isinstance(value, np.ndarray) and value.dtype.kind in "OSU":
        return [v.decode("utf-8", "replace") if isinstance(v, bytes) else str(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    return value


def _identify(path, f) -> None:
    fmt = f.attrs.get("format")
    if fmt is None:
        if "state" in f and "frames" in f:
            raise InputError(path, "written by an older voxelmocap (result format 1, before "
                                   "streamed results): track the sequence again")
        raise InputError(path, "not a voxelmocap result file (no 'format' attribute)")
    if _attr_value(fmt) != FORMAT:
        raise InputError(path, f"not a voxelmocap result file (format {_attr_value(fmt)!r})")
    version = int(f.attrs.get("format_version", 0))
    if version > FORMAT_VERSION:
        raise InputError(path, f"written by a newer voxelmocap (result format {version}; this "
                               f"one reads up to {FORMAT_VERSION})")


#: What h5py raises on files it cannot parse (damaged superblock, B-trees, heaps …).
_H5_ERRORS = (OSError, RuntimeError, KeyError, ValueError, TypeError)


def _writer_mark(path: Path) -> bool:
    """Whether the superblock carries HDF5's "open for writing" flags (a run writing or killed).

    Superblock versions 2 and 3 (``libver="latest"``) keep the file-consistency flags in byte 11.
    """
    try:
        with open(path, "rb") as fh:
            head = fh.read(12)
    except OSError:
        return False
    return len(head) == 12 and head[:8] == _HDF5_SIGNATURE and head[8] >= 2 and head[11] != 0


def _being_written(path: Path) -> bool:
    """Whether a :class:`ResultWriter` holds the file (its exclusive flock)."""
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except BlockingIOError:
        return True
    finally:
        os.close(fd)  # closing releases the lock
    return False


def _open(path: Path) -> h5py.File:
    # A plain read first: in SWMR-read mode HDF5 retries every metadata read whose checksum
    # fails (up to 100 times, with growing sleeps, in case the writer was mid-write), so a
    # damaged file took minutes to refuse (found by fuzzing). Only a file whose writer is
    # running or was killed needs SWMR-read: plain opening refuses its superblock flags, or,
    # while the writer's flush has moved the end-of-file mark but not yet the data, calls it
    # truncated.
    try:
        return h5py.File(path, "r", locking=_LOCKING)
    except _H5_ERRORS as exc:
        first = exc
    if not _writer_mark(path):  # damaged, or not HDF5
        raise InputError(path, f"cannot read HDF5 result file ({first})") from None
    try:
        return h5py.File(path, "r", swmr=True, locking=_LOCKING)
    except _H5_ERRORS:
        raise InputError(path, f"cannot read HDF5 result file ({first})") from None


class _Moved(Exception):
    """The writer committed a frame while the file was being read."""


def read_result(path) -> TrackResult:
    """Read the committed frames of a result file.

    A file that a running ``track`` is writing reads as the frames committed at one instant: a
    read that overlaps the writer's flush or its next commit is repeated (for up to
    :data:`_LIVE_READ_SECONDS`).

    Raises
    ------
    InputError
        Missing file, not HDF5, another format or an older version, missing or damaged datasets.
    """
    path = Path(path)
    if not path.exists():
        raise InputError(path, "result file not found")
    if path.is_dir():
        raise InputError(path, "is a folder, not a result file")
    deadline = time.monotonic() + _LIVE_READ_SECONDS
    while True:
        before = _identity(path)
        try:
            return _read_once(path)
        except (InputError, _Moved) as exc:
            # Retry only what a writer can cause: it runs, or it changed the file meanwhile
            # (e.g. it closed it). A file nobody touches fails the same way every time.
            changing = _being_written(path) or _identity(path) != before
            if not changing or time.monotonic() > deadline:
                if isinstance(exc, _Moved):
                    raise InputError(path, "the running track kept changing the file while it "
                                           "was read; try again") from None
                raise
        time.sleep(0.02)


def _identity(path: Path) -> tuple | None:
    try:
        st = path.stat()
    except OSError:
        return None
    return st.st_ino, st.st_size, st.st_mtime_ns


def _read_once(path: Path) -> TrackResult:
    with _open(path) as f:
        try:
            return _read(path, f)
        except (InputError, _Moved):
            raise
        except _H5_ERRORS as exc:
            raise InputError(path, f"damaged HDF5 result file ({type(exc).__name__}: {exc})"
                             ) from None


def _read(path: Path, f: h5py.File) -> TrackResult:
    """The committed content of an open result file (see :func:`read_result`)."""
    _identify(path, f)
    version = int(f.attrs.get("format_version", 0))
    optional = _ADDED_IN_3 if version < 3 else ()
    missing = [n for n in (*PER_FRAME, "state_names", "part_names", "commit")
               if n not in f and n not in optional]
    if missing:
        raise InputError(path, f"damaged result file (no {missing[0]!r} dataset)")
    commit = np.asarray(f["commit"][()])
    if commit.shape != (3,) or commit.dtype.kind not in "iu":
        raise InputError(path, "damaged result file (bad 'commit' record)")
    n, slot, complete = (int(v) for v in commit)
    present = [name for name in PER_FRAME if name in f]
    lengths = {name: f[name].shape[0] if f[name].shape else 0 for name in present}
    short = [name for name, length in lengths.items() if length < n]
    if n < 0 or short or slot not in (-1, 0, 1):
        raise InputError(path, f"damaged result file (commit says {n} frames, slot {slot}"
                               + (f"; {short[0]!r} has {lengths[short[0]]}" if short else "")
                               + ")")
    checkpoint = None
    if slot >= 0:  # before the rows: the writer reuses this slot two commits later
        try:
            checkpoint = _unpack_checkpoint(f[f"checkpoint_{slot}"][()])
        except Exception as exc:  # any decoding failure means damage
            raise InputError(path, f"damaged checkpoint ({type(exc).__name__}: {exc})"
                             ) from None
    if f.swmr_mode:  # a writer may be running: the slot was whole only if nothing was committed
        f["commit"].refresh()
        if not np.array_equal(f["commit"][()], commit):
            raise _Moved
    data = {name: f[name][:n] for name in present}
    if version < 3:  # format 2 had no confidence: unknown, and every frame counted as observed
        data.setdefault("landmark_spread", np.full((n, 15), np.nan))
        data.setdefault("confidence", np.full((n, 15), np.nan))
        data.setdefault("observed", np.ones(n, dtype=np.uint8))
    _check_shapes(path, data)
    data["observed"] = np.asarray(data["observed"]).astype(bool)
    attrs = {k: _attr_value(v) for k, v in f.attrs.items()}
    attrs["complete"] = bool(complete)
    return TrackResult(
        **data,
        state_names=list(f["state_names"].asstr()[()]),
        part_names=list(f["part_names"].asstr()[()]),
        attrs=attrs, checkpoint=checkpoint)
