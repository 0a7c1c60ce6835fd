"""A global search of each limb on one frame: the limbs a start placed wrong, found again.

A start fitted to the voxels' extremities (:mod:`voxelmocap.initialise`) places the trunk well
and often a limb badly: a bent leg taken for a straight one, a forearm turned the wrong way. The
annealed search then moves that limb by small steps and never leaves the wrong optimum
(``docs/benchmarks.md``: the jog without the answer kept a knee 285 mm off for 60 frames). A limb
has four angles (shoulder 3 + elbow, hip 3 + knee), few enough to cover its whole legal box:
:func:`sweep_limbs` scores a scrambled Sobol sample of each limb's box with the rest of the body
held (exact partial re-scoring, :class:`~voxelmocap.partial_likelihood.PartialScorer`, two cones
per sample), refines the best few by compass search (:func:`~voxelmocap.tracking.refine.
pattern_search`) and keeps the best when it beats the limb's current angles. The limbs interact
only through double occupancy, so two sweeps over the four limbs settle them.

>>> import numpy as np
>>> from voxelmocap.body import BodyModel
>>> from voxelmocap.grid import VoxelGrid
>>> from voxelmocap.likelihood import Measurement, rasterise
>>> model = BodyModel()
>>> grid = VoxelGrid((-1000.0, -1000.0, 0.0), 30.0, (67, 67, 67))
>>> truth = model.default_state(); truth[[19, 25]] = (1.0, 1.2)   # left knee raised
>>> seen = Measurement(rasterise(model, truth[None], grid) > 0, grid)
>>> found, gains = sweep_limbs(seen, model, model.default_state())
>>> bool(abs(found[25] - 1.2) < 0.2 and gains["l_leg"] > 0)
True
"""

from __future__ import annotations

import numpy as np

from .hierarchy import LIMBS
from .likelihood import DEFAULT_VARIANCES
from .partial_likelihood import PartialScorer
from .tracking.refine import pattern_search

__all__ = ["LIMBS", "sweep_limbs"]


def sweep_limbs(observation, model, state, *, variances=DEFAULT_VARIANCES, coverage: float = 0.0,
                samples: int = 1024,
                sweeps: int = 2, keep: int = 4, refine_evaluations: int = 40, seed: int = 0,
                min_gain: float = 0.0) -> tuple[np.ndarray, dict[str, float]]:
    """Search every limb over its legal box on one frame, the rest of the body held.

    Parameters
    ----------
    observation : voxelmocap.observation.VoxelObservation
        The frame.
    model : BodyModel
    state : (27,) array_like
        The pose to improve (legal).
    variances : 4 floats
        The likelihood's σ² (``LikelihoodConfig.variances``).
    coverage : float
        Weight of its coverage term (``LikelihoodConfig.coverage``).
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
    x = model.clip(np.asarray(state, dtype=float)[None])[0]
    gains = dict.fromkeys(LIMBS, 0.0)
    m = int(np.ceil(np.log2(max(int(samples), 2))))
    for sweep in range(int(sweeps)):
        for j, (name, (dims, parts)) in enumerate(LIMBS.items()):
            dims_a = np.asarray(dims)
            scorer = PartialScorer(observation, model, x, parts, dims)

            def ll(states, scorer=scorer):
                return scorer.log_likelihood(states, variances=variances, coverage=coverage)

            current = float(ll(x[None])[0])
            u = qmc.Sobol(len(dims), seed=seed + 7 * sweep + 97 * j).random_base2(m)
            cand = np.repeat(x[None], len(u), axis=0)
            lo, hi = model.low[dims_a], model.high[dims_a]
            cand[:, dims_a] = lo + u * (hi - lo)
            scores = ll(cand)
            best_x, best_f = x, current
            steps = 0.05 * (hi - lo)
            for i in np.argsort(scores)[::-1][:int(keep)]:
                xi, fi, _ = pattern_search(ll, cand[i], dims_a, steps, low=model.low,
                                           high=model.high, max_evaluations=refine_evaluations,
                                           f0=float(scores[i]))
                if fi > best_f:
                    best_x, best_f = xi, fi
            if best_f > current + min_gain:
                gains[name] += best_f - current
                x = best_x.copy()
    return x, gains
