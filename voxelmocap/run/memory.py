"""Freed memory handed back to the system between the passes of a run.

glibc's allocator keeps the memory a process frees in its heaps, for the process's own later
use; it returns to the system only what lies at a heap's top. A pass of the Pose2Sim demo
leaves 1.0–1.3 GiB resident of which about 0.6 GiB is such freed memory (its frames' images,
masks and likelihood buffers, freed in the order they were made), and the next pass's plate
learning takes its sampled frames as new mappings (arrays above the allocator's mmap threshold)
rather than from that free memory: the two add up to the run's peak. Handing the free memory
back before each pass (:func:`voxelmocap.run.pipeline.track`) lowered the demo's peak from 1.69
to 1.37 GiB (seed 0, the results the same to the bit; ``docs/benchmarks.md``).

Elsewhere (another C library, macOS, Windows) there is nothing to call and nothing is done.

>>> isinstance(release_freed_memory(), bool)
True
"""

from __future__ import annotations

import ctypes
import ctypes.util
import functools
import gc

__all__ = ["release_freed_memory", "resident_mib"]


@functools.cache
def _malloc_trim():
    """glibc's ``malloc_trim``, or None where the C library has none."""
    name = ctypes.util.find_library("c")
    if name is None:
        return None
    try:
        trim = ctypes.CDLL(name).malloc_trim
    except (OSError, AttributeError):
        return None
    trim.argtypes, trim.restype = [ctypes.c_size_t], ctypes.c_int
    return trim


def release_freed_memory() -> bool:
    """Collect unreachable Python objects, then return the allocator's free memory to the system.

    Returns
    -------
    bool
        True when the C library released memory (glibc's ``malloc_trim(0)``); False where it
        has no such call or had nothing to release.
    """
    gc.collect()  # objects held only by reference cycles are freed first
    trim = _malloc_trim()
    return bool(trim(0)) if trim is not None else False


def resident_mib() -> float | None:
    """The process's resident memory (MiB) from ``/proc/self/status``; None where there is none."""
    try:
        with open("/proc/self/status", encoding="ascii") as status:
            for line in status:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return None
