"""The same CPU code paths on every machine: NumPy's and OpenBLAS's, chosen before NumPy loads.

NumPy picks some loops by the CPU's instruction sets (its float64 ``exp``/``log`` on AVX-512
machines round differently in the last bit from the AVX2 ones) and OpenBLAS picks its kernels by
the CPU model (an Intel AVX-512 server sums a matrix-vector product in another order than an AMD
or a desktop Intel). SciPy's least squares, which fits the track's starting pose, goes through
both. A particle filter makes another track out of such a last bit (``docs/architecture.md``,
"The same bits on every CPU").

:func:`pin` asks both libraries, through the environment variables they read when they load, for
the paths every x86-64 machine since 2013 has — NumPy's AVX2 loops (``NPY_DISABLE_CPU_FEATURES``
of the AVX-512 groups) and OpenBLAS's Haswell kernels (``OPENBLAS_CORETYPE``, only when the CPU
has AVX2 and FMA) — and leaves a variable the user set alone. It must run before NumPy is
imported: the ``voxelmocap`` command calls it first thing (:mod:`voxelmocap.cli`); in a process
that imported NumPy already it changes nothing (and returns nothing). Processes started from it
(local Dask workers) inherit the choice; workers of a remote scheduler do not. What it cannot
pin: the C library's mathematical functions (the same on machines with the same ``libm``), a
NumPy built with another BLAS (MKL) or an OpenBLAS without runtime kernel selection, and machines
older than AVX2 or of another architecture. Checked on one AVX-512 machine by switching code paths
off, not on a second machine.

This module imports nothing but the standard library.
"""

from __future__ import annotations

import os
import platform
import sys

__all__ = ["AVX512_GROUPS", "AVX512_GROUPS_BEFORE_2_4", "avx512_groups", "pin"]

#: NumPy's names for its AVX-512 dispatch targets: from 2.4 on (``X86_V4`` …) and before. A name
#: the installed NumPy does not dispatch to makes it warn (an ImportWarning, an error under
#: ``-W error``), so only the installed version's list is given (:func:`avx512_groups`).
AVX512_GROUPS = ("X86_V4", "AVX512_ICL", "AVX512_SPR")
AVX512_GROUPS_BEFORE_2_4 = ("AVX512F", "AVX512CD", "AVX512_KNL", "AVX512_KNM", "AVX512_SKX",
                            "AVX512_CLX", "AVX512_CNL", "AVX512_ICL", "AVX512_SPR")


def avx512_groups(numpy_version: str | None = None) -> tuple[str, ...]:
    """The AVX-512 dispatch names of a NumPy version (default: the installed one, read from its
    metadata without importing it)."""
    if numpy_version is None:
        from importlib.metadata import PackageNotFoundError, version

        try:
            numpy_version = version("numpy")
        except PackageNotFoundError:
            return AVX512_GROUPS
    try:
        major, minor = (int(p) for p in numpy_version.split(".")[:2])
    except ValueError:
        return AVX512_GROUPS
    return AVX512_GROUPS if (major, minor) >= (2, 4) else AVX512_GROUPS_BEFORE_2_4


def _cpu_flags() -> set[str]:
    try:
        with open("/proc/cpuinfo", encoding="ascii", errors="replace") as f:
            for line in f:
                if line.startswith("flags"):
                    return set(line.split(":", 1)[1].split())
    except OSError:
        pass
    return set()


def pin(environ=None, *, flags: set[str] | None = None) -> dict[str, str]:
    """Set the environment variables that pin NumPy's and OpenBLAS's CPU paths (x86-64 only).

    Parameters
    ----------
    environ : mutable mapping, optional
        Where to set them (default ``os.environ``).
    flags : set of str, optional
        The CPU's feature flags (default: read from ``/proc/cpuinfo``).

    Returns
    -------
    dict
        The variables this call set (none that were set already; empty off x86-64, or when
        NumPy was imported already and ``environ`` is ``os.environ``).
    """
    env = os.environ if environ is None else environ
    if platform.machine().lower() not in ("x86_64", "amd64"):
        return {}
    if environ is None and "numpy" in sys.modules:
        return {}
    flags = _cpu_flags() if flags is None else flags
    wanted = {"NPY_DISABLE_CPU_FEATURES": " ".join(avx512_groups())}
    if {"avx2", "fma"} <= flags:
        wanted["OPENBLAS_CORETYPE"] = "Haswell"
    done = {}
    for key, value in wanted.items():
        if key not in env:
            env[key] = value
            done[key] = value
    return done
