"""HDF5 files whose write failed, closed without crashing the process.

After a failed write (a full disk), HDF5 2.0's next flush of the file crashed the process with a
segmentation fault, and a dataset handle closed after one reported the failure only in h5py's
deallocator (printed, not raised). Writers therefore hold their dataset handles for the file's
life, catch :data:`WRITE_ERRORS` around their writes, and drop the file with :func:`abandon`.
"""

from __future__ import annotations

import contextlib
import os

__all__ = ["WRITE_ERRORS", "abandon"]

#: What an HDF5 write that did not reach the disk raises (h5py: OSError or RuntimeError).
WRITE_ERRORS = (OSError, RuntimeError)


def abandon(f) -> None:
    """Close an HDF5 file whose write failed without HDF5 writing to it again.

    After a failed write, HDF5 2.0's next flush of the file crashes the process (a segmentation
    fault, found with a full disk). Its descriptor is pointed at ``/dev/null`` first, so the
    flushes of closing go nowhere and the file on disk stays as the last successful write left
    it; then every handle is closed.
    """
    if f is None:
        return
    try:
        fd = f.id.get_vfd_handle()
    except Exception:  # no descriptor to redirect: closing is all there is
        fd = None
    if fd is not None:
        null = os.open(os.devnull, os.O_RDWR)
        try:
            os.dup2(null, fd)
        finally:
            os.close(null)
    with contextlib.suppress(Exception):
        f.close()
