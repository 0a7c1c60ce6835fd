"""Numba kernels of :mod:`voxelmocap.score.likelihood`'s counts → scores and coverage term.

The hierarchical search turns integer counts into log-likelihoods about 25 times a frame, for up
to 600 particles each; in NumPy the chain's temporaries and boolean masks cost more than the
arithmetic (≈ 120 µs a call for the scores and the coverage term). These loops do the same
floating-point operations in the same order per element, so the results are equal bit for bit
(``tests/score/test_likelihood.py``); the weighted sum over parts and terms stays NumPy's ``einsum``.
"""

from __future__ import annotations

from numba import njit


@njit(cache=True)
def scores_from_counts(counts, qmax, scores):
    """Fill ``scores (P, n_parts, 4)`` (Out, DO, Empty, Surf) from ``counts (P, n_parts, 6)``
    int64; a part with no voxel scores ``(0, 0, 1, 1)``."""
    n_particles, n_parts = counts.shape[0], counts.shape[1]
    for i in range(n_particles):
        for q in range(n_parts):
            n = counts[i, q, 0]
            if n == 0:
                scores[i, q, 0] = 0.0
                scores[i, q, 1] = 0.0
                scores[i, q, 2] = 1.0
                scores[i, q, 3] = 1.0
                continue
            nsafe = float(n)
            scores[i, q, 0] = counts[i, q, 1] / nsafe
            scores[i, q, 1] = counts[i, q, 2] / nsafe
            scores[i, q, 2] = (n - counts[i, q, 3]) / nsafe
            scores[i, q, 3] = counts[i, q, 5] / (float(max(counts[i, q, 4], 1)) * qmax)


@njit(cache=True)
def coverage(counts, n_occupied, weight, out):
    """``out (P,) = −½ w u² / 0.1``, ``u`` = clip(1 − (Σ Occ − ½ Σ DO) / n_occupied, 0, 1)."""
    n_particles, n_parts = counts.shape[0], counts.shape[1]
    for i in range(n_particles):
        occ = 0
        do = 0
        for q in range(n_parts):
            occ += counts[i, q, 3]
            do += counts[i, q, 2]
        covered = occ - 0.5 * do
        u = min(max(1.0 - covered / n_occupied, 0.0), 1.0)
        out[i] = -0.5 * weight * u * u / 0.1
