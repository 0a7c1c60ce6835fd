"""Idle worker threads that sleep instead of spinning: OpenMP's wait policy, set before numba loads.

numba runs its parallel kernels (the likelihood, the silhouette cue, the carving) on its OpenMP
threading layer, and OpenMP's worker threads by default keep spinning for a while after each
parallel region in case another one follows. A run makes thousands of short parallel regions,
and with another process on the machine (a second run, other work) the spinning workers take
the cores the other's work needs. Measured on the Pose2Sim demo's 10 frames
(``docs/benchmarks.md``, "Speed"): two runs side by side on 2 cores took 377 s each by default and
135 s with the workers sleeping; a run alone took the same time either way. The results are the
same bit for bit (the wait policy only decides what an idle thread does).

:func:`passive` sets ``OMP_WAIT_POLICY = PASSIVE`` (the OpenMP standard's variable, read by GNU
and LLVM/Intel OpenMP when they load) unless the user set it. The ``voxelmocap`` command calls it
first thing (:mod:`voxelmocap.cli`); local Dask workers inherit it. A program importing
voxelmocap sets the variable itself (before the first parallel kernel runs).

Sleeping workers take tens of microseconds to wake, so a parallel region costs that much before
any work: more than a few poses' worth. Kernels that score small batches (the compass searches
of the limb searches and of the filter's refinement: a few poses a call, thousands of calls)
have a one-thread twin sharing each pose's code, chosen by :func:`serial`; the values are the
same to the bit (tested per kernel).

This module imports nothing but the standard library.
"""

from __future__ import annotations

import os

__all__ = ["SERIAL_BELOW", "WAIT_POLICY", "passive", "serial"]

#: The variable and the value :func:`passive` sets.
WAIT_POLICY = ("OMP_WAIT_POLICY", "PASSIVE")


def passive(environ=None) -> dict[str, str]:
    """Ask OpenMP's idle worker threads to sleep (``OMP_WAIT_POLICY``), unless already chosen.

    Parameters
    ----------
    environ : mutable mapping, optional
        Where to set it (default ``os.environ``, which C libraries loaded later read).

    Returns
    -------
    dict
        The variable this call set (empty when it was set already).
    """
    env = os.environ if environ is None else environ
    name, value = WAIT_POLICY
    if name in env:
        return {}
    env[name] = value
    return {name: value}


#: Batches of fewer poses than this run on one thread (:func:`serial`). Measured on the limb
#: sweep of a rendered walk (7 cameras, 8 poses a compass-search call): the silhouette counts
#: and outlines 58 and 53 µs a call in parallel, 14 and 5 µs on one thread.
SERIAL_BELOW = 16


def serial(n_poses: int) -> bool:
    """Whether a batch of ``n_poses`` poses is scored on one thread (:data:`SERIAL_BELOW`)."""
    return int(n_poses) < SERIAL_BELOW
