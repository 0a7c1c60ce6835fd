"""A global search of each limb on one frame: the limbs a start placed wrong, found again.

A start fitted to the voxels' extremities (:mod:`voxelmocap.pose.initialise`) places the trunk well
and often a limb badly: a bent leg taken for a straight one, a forearm turned the wrong way. The
annealed search then moves that limb by small steps and never leaves the wrong optimum
(``docs/benchmarks.md``: the jog without the answer kept a knee 285 mm off for 60 frames). A limb
has four angles (shoulder 3 + elbow, hip 3 + knee), few enough to cover its whole legal box:
:func:`sweep_limbs` scores a scrambled Sobol sample of each limb's box with the rest of the body
held (exact partial re-scoring, :class:`~voxelmocap.score.partial.PartialScorer`, two cones
per sample), refines the best few by compass search (:func:`~voxelmocap.tracking.refine.
pattern_search`) and keeps the best when it beats the limb's current angles. The limbs interact
only through double occupancy, so two sweeps over the four limbs settle them.

>>> import numpy as np
>>> from voxelmocap.body import BodyModel
>>> from voxelmocap.grid import VoxelGrid
>>> from voxelmocap.score.likelihood import Measurement, rasterise
>>> model = BodyModel()
>>> grid = VoxelGrid((-1000.0, -1000.0, 0.0), 30.0, (67, 67, 67))
>>> truth = model.default_state(); truth[[19, 25]] = (1.0, 1.2)   # left knee raised
>>> seen = Measurement(rasterise(model, truth[None], grid) > 0, grid)
>>> found, gains = sweep_limbs(seen, model, model.default_state())
>>> bool(abs(found[25] - 1.2) < 0.2 and gains["l_leg"] > 0)
True
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..score.likelihood import DEFAULT_VARIANCES
from ..score.partial import PartialScorer
from ..tracking.refine import pattern_search
from .hierarchy import LIMBS

__all__ = ["LIMBS", "LimbScoring", "swapped_limbs", "sweep_limbs"]

#: the limb pairs a swap exchanges, with the landmarks each limb's angles place
_PAIRS = {("l_leg", "r_leg"): (("l_knee", "r_knee"), ("l_ankle", "r_ankle")),
          ("l_arm", "r_arm"): (("l_elbow", "r_elbow"), ("l_wrist", "r_wrist"))}



@dataclass(frozen=True)
class LimbScoring:
    """What a limb search scores: the voxel cue's partial log-likelihood at its fused weight,
    plus the other cues on whole states.

    Attributes
    ----------
    variances : 4 floats
        The likelihood's σ² (``LikelihoodConfig.variances``).
    coverage : float
        Weight of its coverage term (``LikelihoodConfig.coverage``).
    voxel_weight : float
        Weight of the voxel cue's scores in the sum (the fused likelihood's; 0 when the voxel
        cue is not selected).
    others : callable or None
        The log-likelihood ``(P, 27) -> (P,)`` of the other cues on whole states (e.g. the
        silhouette cue) on this frame: a visual hull several times the body offers phantom
        volume that only the images rule out.
    partial : callable or None
        ``(scorer, (P, 27)) -> (P,)``: cues re-scored on the scorer's moving parts only (its
        ``reference`` and ``parts``), added after ``others`` (the periodic sweep's silhouette
        cue, :meth:`voxelmocap.pose.tracker.BodyTracker.sweep_scoring`).
    """

    variances: tuple = DEFAULT_VARIANCES
    coverage: float = 0.0
    voxel_weight: float = 1.0
    others: Callable[[np.ndarray], np.ndarray] | None = None
    partial: Callable[[PartialScorer, np.ndarray], np.ndarray] | None = None

    def __call__(self, scorer: PartialScorer, states) -> np.ndarray:
        """``(P,)`` scores of ``(P, 27)`` states that differ from the scorer's pose only in its
        limb's dimensions."""
        out = self.voxel_weight * scorer.log_likelihood(states, variances=self.variances,
                                                        coverage=self.coverage)
        extra = None if self.others is None else self.others(states)
        if self.partial is not None:
            more = self.partial(scorer, states)
            extra = more if extra is None else extra + more
        return out if extra is None else out + extra


def sweep_limbs(observation, model, state, *, scoring: LimbScoring | None = None,
                samples: int = 1024, sweeps: int = 2, keep: int = 4,
                refine_evaluations: int = 40, seed: int = 0, min_gain: float = 0.0,
                swaps: bool = False, limbs: tuple[str, ...] | None = None
                ) -> tuple[np.ndarray, dict[str, float]]:
    """Search every limb over its legal box on one frame, the rest of the body held.

    Parameters
    ----------
    observation : voxelmocap.measure.observation.VoxelObservation
        The frame.
    model : BodyModel
    state : (27,) array_like
        The pose to improve (legal).
    scoring : LimbScoring, optional
        How states are scored (default: the voxel cue alone, paper 002's σ², no coverage term).
    samples : int
        Sobol points per limb and sweep (rounded up to a power of two).
    sweeps : int
        Passes over the four limbs.
    keep : int
        Best samples refined by compass search.
    refine_evaluations : int
        Evaluations of each of those refinements.
    seed : int
        Scrambling of the Sobol sequence.
    min_gain : float
        A limb moves only when the best angles found beat its current ones by more than this
        (log-likelihood units, ≥ 0): a tracked limb is not flipped into a configuration the
        frame's voxels barely prefer.
    swaps : bool
        Before the sweeps, try each pair's limbs exchanged (:func:`swapped_limbs`): legs
        crossed onto each other's voxels, or the left arm raised for the right, are one move
        away from right, which a search of one limb with the other held cannot make.
    limbs : tuple of str, optional
        Search only these limbs (names of :data:`LIMBS`; default all); each keeps the Sobol
        sequence it has in a search of all of them.

    Returns
    -------
    state : (27,) ndarray
        The improved pose (``state`` where no limb improved).
    gains : dict
        Limb name → log-likelihood gained over all sweeps (0 where kept).
    """
    from scipy.stats import qmc

    if not min_gain >= 0:
        raise ValueError(f"min_gain must be >= 0, got {min_gain!r}")
    if limbs is not None and not set(limbs) <= set(LIMBS):
        raise ValueError(f"unknown limbs {sorted(set(limbs) - set(LIMBS))}: not in {list(LIMBS)}")
    scoring = LimbScoring() if scoring is None else scoring
    x = model.clip(np.asarray(state, dtype=float)[None])[0]
    gains = dict.fromkeys(LIMBS, 0.0)
    if swaps:
        x = _try_swaps(observation, model, x, gains, scoring, min_gain)
    m = int(np.ceil(np.log2(max(int(samples), 2))))
    for sweep in range(int(sweeps)):
        for j, (name, (dims, parts)) in enumerate(LIMBS.items()):
            if limbs is not None and name not in limbs:
                continue
            dims_a = np.asarray(dims)
            scorer = PartialScorer(observation, model, x, parts, dims)

            def ll(states, scorer=scorer):
                return scoring(scorer, states)

            current = float(ll(x[None])[0])
            u = qmc.Sobol(len(dims), seed=seed + 7 * sweep + 97 * j).random_base2(m)
            cand = np.repeat(x[None], len(u), axis=0)
            lo, hi = model.low[dims_a], model.high[dims_a]
            cand[:, dims_a] = lo + u * (hi - lo)
            scores = ll(cand)
            best_x, best_f = x, current
            steps = 0.05 * (hi - lo)
            for i in np.argsort(scores, kind="stable")[::-1][:int(keep)]:
                xi, fi, _ = pattern_search(ll, cand[i], dims_a, steps, low=model.low,
                                           high=model.high, max_evaluations=refine_evaluations,
                                           f0=float(scores[i]))
                if fi > best_f:
                    best_x, best_f = xi, fi
            if best_f > current + min_gain:
                gains[name] += best_f - current
                x = best_x.copy()
    return x, gains


def swapped_limbs(model, state, pair: tuple[str, str]) -> np.ndarray:
    """Two poses with the limbs of ``pair`` exchanged, the rest of the body held.

    1. *angles*: each limb takes the other's angles (they are mirror-symmetric, so each limb
       does the mirror of what the other did: the left arm raised instead of the right);
    2. *places*: the limbs' angles refitted (least squares within the joint limits) so that
       each limb's elbow and wrist, or knee and ankle, land where the other limb's are: legs
       crossed onto each other's voxels uncrossed.

    Parameters
    ----------
    model : BodyModel
    state : (27,) array_like
        A legal pose.
    pair : (str, str)
        ``("l_leg", "r_leg")`` or ``("l_arm", "r_arm")``.

    Returns
    -------
    (2, 27) ndarray
        The two legal poses (the joint limits may keep a limb short of the other's place).
    """
    from scipy.optimize import least_squares

    from ..joints import LANDMARK_NAMES

    x = model.clip(np.asarray(state, dtype=float)[None])[0]
    now = model.landmarks(x[None])[0]
    moved, target = [], []
    for a, b in _PAIRS[pair]:
        i, j = LANDMARK_NAMES.index(a), LANDMARK_NAMES.index(b)
        moved += [i, j]
        target += [now[j], now[i]]
    target = np.asarray(target).ravel()
    dims = np.asarray(LIMBS[pair[0]][0] + LIMBS[pair[1]][0])
    low, high = model.low[dims], model.high[dims]
    high_ls = np.where(high > low, high, low + 1e-12)

    def residual(v):
        y = x.copy()
        y[dims] = v
        return model.landmarks(y[None])[0, moved].ravel() - target

    n = len(dims) // 2
    exchanged = np.clip(np.concatenate([x[dims[n:]], x[dims[:n]]]), low, high)
    # the places fitted from both the limbs as they are and their exchanged angles
    best, best_cost = x[dims], np.inf
    for v0 in (x[dims], exchanged):
        sol = least_squares(residual, np.clip(v0, low, high), bounds=(low, high_ls),
                            x_scale=np.maximum(high - low, 1e-3), max_nfev=200)
        if sol.cost < best_cost:
            best, best_cost = sol.x, sol.cost
    out = np.repeat(x[None], 2, axis=0)
    out[0, dims] = exchanged
    out[1, dims] = np.clip(best, low, high)
    return out


def _try_swaps(observation, model, x, gains, scoring, min_gain):
    """``x`` with each limb pair exchanged where that beats it by more than ``min_gain``."""
    for pair in _PAIRS:
        dims = LIMBS[pair[0]][0] + LIMBS[pair[1]][0]
        parts = LIMBS[pair[0]][1] + LIMBS[pair[1]][1]
        scorer = PartialScorer(observation, model, x, parts, dims)
        cand = np.concatenate([x[None], swapped_limbs(model, x, pair)])
        scores = scoring(scorer, cand)
        k = 1 + int(np.argmax(scores[1:]))
        if scores[k] > scores[0] + min_gain:
            for name in pair:                       # the gain shared by the two limbs
                gains[name] += 0.5 * float(scores[k] - scores[0])
            x = cand[k]
    return x
