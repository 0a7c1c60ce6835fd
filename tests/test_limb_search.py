"""The global limb search of a start (voxelmocap.limb_search)."""

import numpy as np

from voxelmocap.body import BodyModel
from voxelmocap.grid import VoxelGrid
from voxelmocap.likelihood import Measurement, log_likelihood, rasterise
from voxelmocap.limb_search import LIMBS, sweep_limbs

DEG = np.pi / 180
GRID = VoxelGrid((-1000.0, -1000.0, 0.0), 30.0, (67, 67, 67))


def _random_limbs(model, rng):
    """A pose whose four limbs are drawn over a generous part of their ranges."""
    x = model.default_state()
    for dims, _ in LIMBS.values():
        d = np.asarray(dims)
        lo, hi = model.low[d], model.high[d]
        x[d] = lo + rng.uniform(0.15, 0.6, 4) * (hi - lo)
    return x


def test_the_sweep_finds_limbs_rendered_from_the_model():
    """Truth: the pose the voxels were rasterised from; the start has every limb straight down."""
    model = BodyModel()
    rng = np.random.default_rng(5)
    for _ in range(3):
        truth = _random_limbs(model, rng)
        seen = Measurement(rasterise(model, truth[None], GRID) > 0, GRID)
        found, gains = sweep_limbs(seen, model, model.default_state(), samples=512)
        err = np.linalg.norm(model.landmarks(found[None])[0] - model.landmarks(truth[None])[0],
                             axis=1)
        start = np.linalg.norm(model.landmarks(model.default_state()[None])[0]
                               - model.landmarks(truth[None])[0], axis=1)
        assert np.median(err) < 20.0 and err.max() < 80.0, (err.round(), start.round())
        assert all(g >= 0 for g in gains.values())


def test_the_sweep_never_lowers_the_likelihood_and_keeps_the_optimum():
    model = BodyModel()
    truth = _random_limbs(model, np.random.default_rng(8))
    seen = Measurement(rasterise(model, truth[None], GRID) > 0, GRID)
    found, gains = sweep_limbs(seen, model, truth, samples=256, sweeps=1)
    before, after = log_likelihood(seen, model, np.stack([truth, found]))
    assert after >= before
    # the partial scores are the full ones exactly: the gains add up to the full difference
    assert np.isclose(after - before, sum(gains.values()), atol=1e-9)
