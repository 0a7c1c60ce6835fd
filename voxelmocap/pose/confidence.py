"""Per-landmark confidence of a tracked frame: the particles' spread and the voxels' support.

The annealed particle filter ends every frame with a weighted particle set (its last layer). Two
things say how far a landmark of the estimate can be trusted:

* the **spread** of that landmark over the last layer's particles (:func:`landmark_spread`): the
  weighted root-mean-square distance of the particles' landmark from its weighted mean, in mm;
  with the hierarchical search, over the last layer of every partition that moves it, their
  variances added (:func:`searched_spread`).
  A landmark the voxels pin down (a free hand) collapses to a few mm; one they cannot (a hand
  inside the torso's silhouette, a mirrored leg) stays spread;
* the **support** of the body parts that meet at the landmark (:data:`LANDMARK_PARTS`): the
  share of each part's volume the carved voxels confirm, ``1 − ρ_Empty`` (paper 002 eq 5),
  averaged over the parts. A limb placed where no voxel is has support near 0, however sure the
  particles are of it.

:func:`landmark_confidence` combines them into one number in [0, 1]:

    confidence = support × P(|e| < δ),   e ~ N(0, (spread² / 3) · I₃)

the probability, if the landmark's error were an isotropic Gaussian of the particles' spread,
that it lies within δ (default 100 mm, the MMTA threshold) of the estimate — the chi distribution
with 3 degrees of freedom, :func:`within_probability` — weighted by the voxels' support. It is a
ranking heuristic, not a calibrated probability: the annealing narrows the last layer on purpose
(paper 002 §2), so the spread understates the error of a track that is wrong but sure. The
ingredients are stored beside it in every result (``landmark_spread``, ``part_scores``), so
other combinations can be computed afterwards.

>>> import numpy as np
>>> round(float(within_probability(np.array([0.0, 100.0]), delta=100.0)[1]), 3)
0.608
"""

from __future__ import annotations

import numpy as np
from scipy.special import erf

from ..joints import LANDMARK_NAMES
from ..portable import exp, weighted_sum

__all__ = ["DEFAULT_DELTA_MM", "LANDMARK_PARTS", "landmark_confidence", "landmark_spread",
           "landmark_support", "searched_spread", "within_probability"]

#: δ of the confidence (mm): MMTA's matching threshold (paper 002 §3).
DEFAULT_DELTA_MM = 100.0

#: The body parts that meet at each landmark (``voxelmocap.body.PART_NAMES`` names).
LANDMARK_PARTS: dict[str, tuple[str, ...]] = {
    "thorax": ("torso", "head"),
    "pelvis": ("torso",),
    "l_shoulder": ("torso", "l_upper_arm"),
    "l_elbow": ("l_upper_arm", "l_forearm"),
    "l_wrist": ("l_forearm",),
    "r_shoulder": ("torso", "r_upper_arm"),
    "r_elbow": ("r_upper_arm", "r_forearm"),
    "r_wrist": ("r_forearm",),
    "l_hip": ("torso", "l_thigh"),
    "l_knee": ("l_thigh", "l_shin"),
    "l_ankle": ("l_shin",),
    "r_hip": ("torso", "r_thigh"),
    "r_knee": ("r_thigh", "r_shin"),
    "r_ankle": ("r_shin",),
    "head": ("head",),
}

_EMPTY = 2  # index of ρ_Empty in the score axis (Out, DO, Empty, Surf)


def landmark_spread(landmarks, weights) -> np.ndarray:
    """Weighted RMS distance of each landmark from its weighted mean over the particles.

    Parameters
    ----------
    landmarks : (P, M, 3) array_like
        Every particle's landmarks (mm).
    weights : (P,) array_like
        Normalised particle weights (summing to 1).

    Returns
    -------
    (M,) ndarray
        ``sqrt(Σ_i w_i |x_i − x̄|²)`` with ``x̄ = Σ_i w_i x_i`` (mm); the per-axis standard
        deviation of an isotropic spread is this over √3.
    """
    x = np.asarray(landmarks, dtype=float)
    w = np.asarray(weights, dtype=float)
    if x.ndim != 3 or x.shape[2] != 3 or w.shape != (x.shape[0],):
        raise ValueError(f"landmark_spread: expected (P, M, 3) and (P,), got {x.shape} and "
                         f"{w.shape}")
    mean = np.einsum("p,pmk->mk", w, x)
    d2 = np.sum((x - mean) ** 2, axis=2)
    return np.sqrt(np.maximum(weighted_sum(w, d2), 0.0))


def searched_spread(landmarks_of, estimate, searched) -> np.ndarray:
    """Spread of each landmark over what every group of the search was unsure of.

    A hierarchical filter searches the trunk first and then each limb with the rest held
    (:attr:`voxelmocap.tracking.partitioned.PartitionedParticleFilter.searched`): its last layer
    varies only the last limb, so :func:`landmark_spread` of it is 0 for every other landmark.
    Here each group's last layer is put into the estimate (its own dimensions from its particles,
    the rest at ``estimate``) and the landmarks' spreads of the groups add as variances:
    ``spread² = Σ_g landmark_spread(group g)²`` — a wrist is as unsure as the trunk that carries
    it and its arm together. With one group over every dimension (the joint filter) this is
    :func:`landmark_spread` of its particles.

    Parameters
    ----------
    landmarks_of : callable
        ``(P, D) states -> (P, M, 3)`` landmarks (mm), e.g. the body model's forward kinematics.
    estimate : (D,) array_like
        The frame's estimate.
    searched : list of (dims (K,), particles (P, K), weights (P,))
        The groups of the search, weights normalised.

    Returns
    -------
    (M,) ndarray
        mm; NaN when ``searched`` is empty.
    """
    estimate = np.asarray(estimate, dtype=float)
    total = None
    for dims, own, weights in searched:
        states = np.repeat(estimate[None], len(weights), axis=0)
        states[:, np.asarray(dims)] = own
        variance = landmark_spread(landmarks_of(states), weights) ** 2
        total = variance if total is None else total + variance
    if total is None:
        return np.full(np.shape(landmarks_of(estimate[None]))[1], np.nan)
    return np.sqrt(total)


def within_probability(spread, *, delta: float = DEFAULT_DELTA_MM) -> np.ndarray:
    """P(|e| < δ) for ``e ~ N(0, (spread²/3) I₃)``: the chi(3) distribution's CDF at δ√3/spread.

    Closed form ``erf(u/√2) − √(2/π)·u·exp(−u²/2)``, ``u = δ√3 / spread``; 1 for a spread of
    0, NaN for a NaN spread.

    Parameters
    ----------
    spread : array_like
        RMS 3-D spreads (mm), as from :func:`landmark_spread`.
    delta : float
        The distance (mm).
    """
    s = np.asarray(spread, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        u = np.where(s > 0, delta * np.sqrt(3.0) / s, np.inf)
        p = erf(u / np.sqrt(2.0)) - np.sqrt(2.0 / np.pi) * np.where(
            np.isfinite(u), u * exp(-0.5 * u * u), 0.0)
    return np.where(np.isnan(s), np.nan, np.clip(p, 0.0, 1.0))


def landmark_support(part_scores, part_names) -> np.ndarray:
    """Voxel support of each landmark: mean ``1 − ρ_Empty`` of the parts meeting there.

    Parameters
    ----------
    part_scores : (..., n_parts, 4) array_like
        Out, DO, Empty, Surf per part (``voxelmocap.score.likelihood.part_scores``).
    part_names : sequence of str
        The parts' names, in the order of ``part_scores``; parts of :data:`LANDMARK_PARTS`
        missing from it are left out (a landmark with none gets NaN).

    Returns
    -------
    (..., 15) ndarray
        In ``LANDMARK_NAMES`` order, within [0, 1].
    """
    scores = np.asarray(part_scores, dtype=float)
    index = {name: i for i, name in enumerate(part_names)}
    occupied = 1.0 - scores[..., _EMPTY]
    out = np.full(scores.shape[:-2] + (len(LANDMARK_NAMES),), np.nan)
    for j, name in enumerate(LANDMARK_NAMES):
        parts = [index[p] for p in LANDMARK_PARTS[name] if p in index]
        if parts:
            out[..., j] = occupied[..., parts].mean(axis=-1)
    return np.clip(out, 0.0, 1.0)


def landmark_confidence(spread, part_scores, part_names, *,
                        delta: float = DEFAULT_DELTA_MM) -> np.ndarray:
    """Confidence in [0, 1] of each landmark (module docstring): support × P(|e| < δ).

    Parameters
    ----------
    spread : (..., 15) array_like
        :func:`landmark_spread` (mm).
    part_scores : (..., n_parts, 4) array_like
        The estimate's part scores.
    part_names : sequence of str
    delta : float
        δ (mm).

    Returns
    -------
    (..., 15) ndarray
        NaN where the spread is NaN (unknown).
    """
    return landmark_support(part_scores, part_names) * within_probability(spread, delta=delta)
