"""Numba kernel of :func:`voxelmocap.tracking.annealing.ess_fraction`.

:func:`~voxelmocap.tracking.annealing.find_beta` bisects β to a relative precision of 1e-10,
about forty ESS evaluations per annealing layer; in NumPy each one builds four temporaries
(finite mask, tempered weights, exponentials, squares) for a few hundred particles, and their
call overhead was a third of the filter's own time per frame. One pass here computes the same
quantity (the sums in another order: equal to the NumPy expression within a few ulps,
``tests/tracking/test_annealing.py``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def ess_fraction(log_lik, beta, offset):
    """ESS / N of ``exp(beta · log_lik + offset)``, non-finite log-likelihoods and ``-inf``
    offsets weighing 0; 0 when every weight does.

    Parameters
    ----------
    log_lik : (N,) float64 ndarray
    beta : float
    offset : (N,) or (0,) float64 ndarray
        Extra log-weights; empty for none.
    """
    n = log_lik.size
    has_offset = offset.size > 0
    top = -np.inf
    for i in range(n):
        lw = _log_weight(log_lik, beta, offset, has_offset, i)
        if lw > top:
            top = lw
    if top == -np.inf:
        return 0.0
    s = 0.0
    s2 = 0.0
    for i in range(n):
        lw = _log_weight(log_lik, beta, offset, has_offset, i)
        if lw != -np.inf:
            e = math.exp(lw - top)
            s += e
            s2 += e * e
    return s * s / (s2 * n)


@njit(cache=True, inline="always")
def _log_weight(log_lik, beta, offset, has_offset, i):
    v = log_lik[i]
    if not math.isfinite(v):
        return -np.inf
    lw = beta * v
    if has_offset:
        o = offset[i]
        if o == -np.inf:
            return -np.inf
        lw += o
    return lw
