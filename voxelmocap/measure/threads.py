"""Independent pieces of measurement work run side by side: one camera's silhouette, one block
of a plate's rows.

GrabCut, morphology and the plate's numba kernels run on one core each and release the GIL, so
the cameras of a frame (or the row blocks of a median) are done by a small pool of threads. The
pool is as wide as OpenCV's own thread count (``cv2.getNumThreads()``, which
``OPENCV_FOR_THREADS_NUM`` and ``cv2.setNumThreads`` set), so whoever limits OpenCV's threads
limits these too. Each piece is a pure function of its inputs — GrabCut's k-means start is
seeded in the thread that runs it (OpenCV's generator is per thread) — so the results do not
depend on the width.

Work handed out from a worker thread runs in that thread, one piece after another: the pool
is never waited on by its own workers. A process forked from one that used the pool starts
without it (the threads do not survive the fork) and makes its own.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable, Iterable
from concurrent.futures import ThreadPoolExecutor
from typing import TypeVar

import cv2

__all__ = ["each", "width"]

T = TypeVar("T")
R = TypeVar("R")

_local = threading.local()
_pools: dict[int, ThreadPoolExecutor] = {}
_lock = threading.Lock()


def width() -> int:
    """Threads that :func:`each` uses: OpenCV's thread count (at least 1)."""
    return max(1, int(cv2.getNumThreads()))


def each(fn: Callable[[T], R], items: Iterable[T], *, at_most: int | None = None) -> list[R]:
    """``[fn(x) for x in items]``, the calls spread over :func:`width` threads.

    Parameters
    ----------
    fn : callable
        Called once per item; calls must not depend on each other's effects.
    items : iterable
    at_most : int, optional
        Run at most this many at once (e.g. to bound the memory the pieces hold together).

    Returns
    -------
    list
        The results in the order of ``items``. The first exception (in that order) is raised.
    """
    items = list(items)
    n = min(width(), len(items), len(items) if at_most is None else max(1, int(at_most)))
    if n <= 1 or getattr(_local, "worker", False):
        return [fn(x) for x in items]
    return list(_pool(n).map(lambda x: _as_worker(fn, x), items))


def _as_worker(fn, x):
    _local.worker = True
    try:
        return fn(x)
    finally:
        _local.worker = False


def _forget_pools() -> None:
    # A forked child inherits the pools but not their threads: it would wait on them forever.
    global _lock
    _pools.clear()
    _lock = threading.Lock()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forget_pools)


def _pool(n: int) -> ThreadPoolExecutor:
    with _lock:
        pool = _pools.get(n)
        if pool is None:
            pool = _pools[n] = ThreadPoolExecutor(n, thread_name_prefix="voxelmocap-measure")
        return pool
