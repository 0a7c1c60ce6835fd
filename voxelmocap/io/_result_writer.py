"""Streamed, exclusive writing of a result file (see :mod:`voxelmocap.io.results`)."""

from __future__ import annotations

import contextlib
import datetime
import fcntl
import os
from pathlib import Path

import h5py
import numpy as np

from ..errors import InputError
from ._atomic import write_reason
from ._hdf5 import WRITE_ERRORS as _WRITE_ERRORS
from ._hdf5 import abandon as _abandon
from ._result_format import (
    _CHUNK_ROWS,
    _COORDINATE_FRAME,
    _INT_ROWS,
    _LOCKING,
    _ROW_DEFAULTS,
    _SCORE_NAMES,
    _STR,
    _UINT8_ROWS,
    FORMAT,
    FORMAT_VERSION,
    PER_FRAME,
    TrackResult,
    _pack_checkpoint,
)
from ._result_locks import _busy, _folder_lock, _try_lock
from ._result_reader import _read_once


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
        # Folders this writer creates, removed again if it never creates the file.
        self._new_dirs = [p for p in (self.path.parent, *self.path.parent.parents)
                          if not p.exists()]
        ensure_output_dir(self.path.parent)
        self.temp = self.path.with_name(f".{self.path.name}.partial")
        self._file: h5py.File | None = None
        self._data: dict[str, h5py.Dataset] = {}
        self._frame_bytes = 0
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
            rows = 0 if previous is None else len(previous)
            self._check_space(_CREATE_BYTES + rows * _row_bytes(template, previous)
                              + _blob_bytes(previous))
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
            except BaseException as exc:
                _abandon(f)
                self.temp.unlink(missing_ok=True)
                if isinstance(exc, _WRITE_ERRORS):
                    raise InputError(self.path, f"cannot write the result ({write_reason(exc)})"
                                                ": free some space and run again") from None
                raise
        if self._fd is not None:
            os.close(self._fd)  # the replaced file's lock
        self._fd, self._file = fd, f
        # Held open for the writer's life: a dataset closed after a failed write would report
        # the failure in h5py's deallocator, unseen, and the next flush would crash.
        self._data = {name: f[name] for name in (*PER_FRAME, "checkpoint_0", "checkpoint_1",
                                                 "commit")}
        self._frame_bytes = _CHUNK_ROWS * sum(_dataset_row_bytes(self._data[n]) for n in PER_FRAME)

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
        blob = None if checkpoint is None else _pack_checkpoint(checkpoint)
        # Refused before anything is written: the file stays as committed, to be resumed.
        self._check_space(self._frame_bytes + (0 if blob is None else _round_blob(len(blob))))
        data = self._data
        try:
            for name in PER_FRAME:
                d = data[name]
                d.resize(n + 1, axis=0)
                d[n] = _row(record, name)
            slot = -1  # without a new state, no checkpoint matches the frames any more
            if blob is not None:
                slot = 1 if self._slot == 0 else 0  # never overwrite the committed state
                _write_blob(data[f"checkpoint_{slot}"], blob)
            # Everything above reaches the file before the commit that makes it count.
            f.flush()
            data["commit"][...] = (n + 1, slot, int(complete))
            f.flush()
        except _WRITE_ERRORS as exc:
            self._fail(exc)
        self._n, self._slot = n + 1, slot

    def _check_space(self, need: int) -> None:
        """Refuse to write when the result's folder has less than ``need`` (+ a margin) bytes."""
        free = _free_bytes(self.path.parent)
        if free is not None and free < need + _SPACE_MARGIN:
            raise InputError(self.path, f"not enough free space ({free / 1024:.0f} kB free, "
                                        f"about {(need + _SPACE_MARGIN) / 1024:.0f} kB needed)"
                                        + self._next_step())

    def _next_step(self) -> str:
        if self._file is not None or self._n:  # the result exists: it is resumed
            return (f"; {self._n} frame(s) tracked and kept: free some space and continue "
                    "with --resume")
        return ": free some space and run again"

    def _fail(self, exc: BaseException) -> None:
        """A write failed (a full disk, an I/O error): drop the file without touching it again
        and raise the one-line error. The frames committed before stay readable and resumable:
        the file is as a run killed at this instant leaves it."""
        self._data = {}
        _abandon(self._file)
        message = f"cannot write the result ({write_reason(exc)})" + self._next_step()
        self._file = None
        raise InputError(self.path, message) from None

    def close(self) -> None:
        """Close the file and release the lock (idempotent).

        Raises
        ------
        InputError
            The last writes cannot reach the disk (the committed frames are kept).
        """
        try:
            if self._file is not None:
                try:
                    self._file.flush()
                except _WRITE_ERRORS as exc:
                    self._fail(exc)
                self._data = {}
                self._file.close()
                self._file = None
        finally:
            if self._fd is not None:
                os.close(self._fd)
                self._fd = None
            for folder in self._new_dirs:  # a refused run leaves no empty folder behind
                if self.path.exists():
                    break
                with contextlib.suppress(OSError):
                    folder.rmdir()
            self._new_dirs = []


#: Bytes a new result file needs besides its rows: header, attributes, dataset headers, first
#: chunks (the file of a 1-frame run is about 100 kB; scripts/bench_results.py).
_CREATE_BYTES = 1 << 20
#: Free space left aside beyond what a write needs (HDF5's metadata, the log, the exports).
_SPACE_MARGIN = 256 << 10
_BLOB_CHUNK = 1 << 16


def _free_bytes(folder: Path) -> int | None:
    """Bytes an unprivileged process may still write in ``folder``'s file system, or None."""
    try:
        st = os.statvfs(folder)
    except OSError:
        return None
    return st.f_bavail * st.f_frsize


def _dataset_row_bytes(d: h5py.Dataset) -> int:
    return int(np.prod(d.shape[1:], dtype=np.int64)) * d.dtype.itemsize


def _row_bytes(template, previous) -> int:
    """Bytes of one frame's rows (from a record, or the rows of a previous result)."""
    source = template if template is not None else previous
    if source is None:
        return 0
    total = 0
    for name in PER_FRAME:
        shape = (np.shape(_row(source, name)) if template is not None
                 else np.shape(getattr(previous, name))[1:])
        total += 8 * int(np.prod(shape, dtype=np.int64))
    return total


def _round_blob(n: int) -> int:
    return -(-n // _BLOB_CHUNK) * _BLOB_CHUNK


def _blob_bytes(previous) -> int:
    if previous is None or previous.checkpoint is None:
        return 0
    return _round_blob(len(_pack_checkpoint(previous.checkpoint)))


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
