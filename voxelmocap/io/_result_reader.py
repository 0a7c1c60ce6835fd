"""Reading a result file, also while a ``track`` run writes it (see :mod:`voxelmocap.io.results`)."""

from __future__ import annotations

import time
from pathlib import Path

import h5py
import numpy as np

from ..errors import InputError
from ._result_format import (
    _ADDED_IN_3,
    _LIVE_READ_SECONDS,
    _LOCKING,
    FORMAT,
    FORMAT_VERSION,
    PER_FRAME,
    TrackResult,
    _unpack_checkpoint,
)
from ._result_locks import _being_written, _writer_mark


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
