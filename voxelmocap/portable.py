"""Numerics that give the same bits on every CPU: what the particle filter's weights go through.

A tracked result should not depend on the machine. Two things in NumPy do: its float64 ``exp``,
``log``, ``expm1`` and ``log1p`` (and ``scipy.special.logsumexp``, built on them) run loops chosen
by the CPU's instruction sets, and the AVX-512 loops round differently from the AVX2 ones in the
last bit; a matrix-vector product ``W @ x`` goes to OpenBLAS, whose kernel — and so the order of
its sums — depends on the CPU model. The annealed particle filter resamples on these weights, and
a last-bit difference becomes another track within a few frames (a rendered walk tracked without
the answer: 125 mm apart by frame 12 with NumPy's and OpenBLAS's CPU-specific code switched off;
``docs/architecture.md``). The functions
here compute the same quantities from the C library's scalar functions and sums in index order
(:mod:`voxelmocap._portable_kernels`), which do not change with the CPU's instruction sets.

What stays outside: the C library itself (results are the same across x86-64 machines with the
same ``libm``, not across operating systems); SciPy's least squares, which :mod:`voxelmocap.cpu_paths`
pins for the command; and OpenCV, whose CPU-specific code paths did not change the demo's tracked
result (``docs/benchmarks.md``).

>>> import numpy as np
>>> float(log(exp(np.float64(1.5))))
1.5
>>> float(logsumexp(np.log([1.0, 2.0, 5.0])))     # log 8
2.0794415416798357
"""

from __future__ import annotations

import math

import numpy as np

from . import _portable_kernels as _k

__all__ = ["atan2", "dot", "exp", "expm1", "log", "log1p", "logsumexp", "matmul", "norm",
           "weighted_sum"]


def exp(x):
    """``e**x`` element-wise (float64), from the C library's ``exp``."""
    return _k.exp(np.asarray(x, dtype=np.float64))


def log(x):
    """Natural logarithm element-wise (float64): ``-inf`` at 0, NaN below."""
    return _k.log(np.asarray(x, dtype=np.float64))


def expm1(x):
    """``e**x - 1`` element-wise (float64), accurate near 0."""
    return _k.expm1(np.asarray(x, dtype=np.float64))


def log1p(x):
    """``log(1 + x)`` element-wise (float64), accurate near 0: ``-inf`` at −1, NaN below."""
    return _k.log1p(np.asarray(x, dtype=np.float64))


def logsumexp(a, axis=None):
    """``log Σ exp(a)`` over ``axis`` (all elements by default), shifted by the maximum.

    Parameters
    ----------
    a : array_like
        Log-values; ``-inf`` terms add nothing.
    axis : int, optional

    Returns
    -------
    float or ndarray
        ``-inf`` where every term is ``-inf``; ``+inf`` where one is ``+inf``; NaN where one is
        NaN (as :func:`scipy.special.logsumexp`).
    """
    a = np.asarray(a, dtype=np.float64)
    top = np.max(a, axis=axis, keepdims=True)
    shift = np.where(np.isfinite(top), top, 0.0)
    with np.errstate(divide="ignore"):
        out = log(np.sum(exp(a - shift), axis=axis, keepdims=True)) + shift
    out = np.where(np.isinf(top) | np.isnan(top), top, out)
    out = out.reshape(()) if axis is None else np.squeeze(out, axis=axis)
    return float(out) if out.ndim == 0 else out


def weighted_sum(w, x):
    """``Σ_p w[p] x[p]``: the weighted sum of rows, accumulated in the order of the rows.

    Parameters
    ----------
    w : (P,) array_like
    x : (P,) or (P, D) array_like

    Returns
    -------
    float or (D,) ndarray
        What ``w @ x`` computes, without a BLAS kernel chosen by the CPU model.
    """
    w = np.ascontiguousarray(w, dtype=np.float64)
    x = np.asarray(x, dtype=np.float64)
    if w.ndim != 1 or x.shape[:1] != w.shape:
        raise ValueError(f"weighted_sum: weights {w.shape} and rows {x.shape} do not match")
    if x.ndim == 1:
        return float(_k.weighted_sum(w, np.ascontiguousarray(x[:, None]))[0])
    return _k.weighted_sum(w, np.ascontiguousarray(x))


def matmul(a, b):
    """``a @ b`` for small matrices and vectors, as products summed by NumPy, not by BLAS.

    Parameters
    ----------
    a : (..., N, K) or (K,) array_like
    b : (..., K, M) or (K,) array_like

    Returns
    -------
    ndarray
        (..., N, M), (..., N) for a vector ``b``, (..., M) for a vector ``a`` (``a @ b``'s
        shapes; two vectors: use :func:`dot`).
    """
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    if b.ndim == 1:
        return (a * b).sum(axis=-1)
    vector = a.ndim == 1
    if vector:
        a = a[None]
    # one term of K at a time, added in the order of k: no (..., N, K, M) temporary
    out = a[..., :, 0:1] * b[..., 0:1, :]
    for k in range(1, a.shape[-1]):
        out = out + a[..., :, k:k + 1] * b[..., k:k + 1, :]
    return out[..., 0, :] if vector else out


def atan2(y, x) -> float:
    """``atan2(y, x)`` of two scalars (float), from the C library: NumPy's ``arctan2`` has AVX-512
    loops, even for scalars."""
    return math.atan2(float(y), float(x))


def dot(a, b) -> float:
    """``a · b`` of two vectors (float), summed by NumPy rather than a CPU-specific BLAS kernel."""
    return float((np.asarray(a, dtype=np.float64) * np.asarray(b, dtype=np.float64)).sum())


def norm(v) -> float:
    """Euclidean length of a vector (float): :func:`numpy.linalg.norm` of a vector goes to BLAS."""
    v = np.asarray(v, dtype=np.float64)
    return float(np.sqrt((v * v).sum()))
