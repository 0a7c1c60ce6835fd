"""Deterministic local refinement of an estimate: a compass (pattern) search on a few dimensions.

After annealing, the weighted mean sits near a mode but not on it (the last layer still has
noise of a few degrees). A compass search (Kolda, Lewis & Torczon 2003, "Optimization by direct
search", SIAM Review 45(3)) tries ``x ± step_i e_i`` for every searched dimension ``i`` in one
batch, moves to the best candidate if it improves the log-likelihood, and otherwise halves every
step; it stops when the evaluation budget is spent or every step is below ``min_step`` of its
start. It needs no gradient and no randomness, and every batch is one call of the (vectorised)
log-likelihood.

>>> import numpy as np
>>> ll = lambda x: -np.sum((x - np.array([0.3, -0.2])) ** 2, axis=1)
>>> x, f, n = pattern_search(ll, np.zeros(2), [0, 1], np.array([0.5, 0.5]),
...                          low=-np.ones(2), high=np.ones(2), max_evaluations=60)
>>> bool(np.allclose(x, [0.3, -0.2], atol=0.02)), n <= 60
(True, True)
"""

from __future__ import annotations

import numpy as np

__all__ = ["pattern_search"]


def pattern_search(log_likelihood, x0, dims, steps, *, low, high, max_evaluations: int,
                   min_step: float = 1.0 / 16.0, f0: float | None = None):
    """Maximise ``log_likelihood`` over ``x[dims]`` from ``x0`` by compass search.

    Parameters
    ----------
    log_likelihood : callable
        ``(P, D) -> (P,)``.
    x0 : (D,) ndarray
        Start (inside ``[low, high]``).
    dims : sequence of int
        The dimensions searched (the others stay at ``x0``).
    steps : (len(dims),) ndarray
        Initial step per searched dimension (> 0).
    low, high : (D,) ndarray
        Bounds; candidates are clipped into them.
    max_evaluations : int
        Budget of likelihood evaluations (the start's own, when ``f0`` is None, included).
    min_step : float
        Stop when every step is below this fraction of its initial value.
    f0 : float, optional
        ``log_likelihood(x0)`` when already known.

    Returns
    -------
    x : (D,) ndarray
        The best state found.
    f : float
        Its log-likelihood.
    evaluations : int
        Evaluations spent.
    """
    dims = np.asarray(dims, dtype=np.int64)
    x = np.array(x0, dtype=float)
    used = 0
    if f0 is None:
        f0 = float(log_likelihood(x[None])[0])
        used = 1
    f = float(f0)
    step = np.array(steps, dtype=float)
    floor = min_step * step
    n = dims.size
    rows = np.arange(n)
    while used + 2 * n <= max_evaluations and np.any(step >= floor):
        cand = np.repeat(x[None], 2 * n, axis=0)
        cand[rows, dims] += step
        cand[n + rows, dims] -= step
        np.clip(cand, low, high, out=cand)
        fc = np.asarray(log_likelihood(cand), dtype=float)
        used += 2 * n
        best = int(np.argmax(fc))
        if fc[best] > f:
            x, f = cand[best], float(fc[best])
        else:
            step *= 0.5
    return x, f, used
