"""Who holds a result file: the writer's exclusive ``flock``, the folder lock around creation,
and HDF5's "open for writing" mark (see :mod:`voxelmocap.io.results`)."""

from __future__ import annotations

import contextlib
import fcntl
import os
import time
from pathlib import Path

from ..errors import InputError
from ._result_format import _HDF5_SIGNATURE, _LOCK_PATIENCE_SECONDS


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
