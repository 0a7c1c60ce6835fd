"""Numba kernels of :mod:`voxelmocap.portable`: the C library's ``exp``, ``log``, ``expm1`` and
``log1p``, and a weighted sum in a fixed order.

NumPy picks its float64 ``exp``/``log`` loops by the CPU it runs on (AVX-512 machines get their
own, which differ from the AVX2 ones in the last bit), and a matrix-vector product goes to
OpenBLAS, whose kernel (and summation order) depends on the CPU model too. A particle filter
turns such last-bit differences into another track within a few frames. Compiled here, without
fast-math, each element is one call to the C library and each sum runs in index order: the same
bits on any CPU (``tests/test_portable.py`` runs them with NumPy's and OpenBLAS's CPU-specific
code switched off).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, vectorize


@vectorize(["float64(float64)"], cache=True)
def exp(x):
    return math.exp(x)


@vectorize(["float64(float64)"], cache=True)
def log(x):
    if x < 0.0:
        return np.nan
    if x == 0.0:
        return -np.inf
    return math.log(x)


@vectorize(["float64(float64)"], cache=True)
def expm1(x):
    return math.expm1(x)


@vectorize(["float64(float64)"], cache=True)
def log1p(x):
    if x < -1.0:
        return np.nan
    if x == -1.0:
        return -np.inf
    return math.log1p(x)


@njit(cache=True)
def weighted_sum(w, x):
    """``Σ_p w[p] x[p, :]`` of ``w`` (P,) and ``x`` (P, D), accumulated in the order of p."""
    n, d = x.shape
    out = np.zeros(d)
    for p in range(n):
        wp = w[p]
        for j in range(d):
            out[j] += wp * x[p, j]
    return out
