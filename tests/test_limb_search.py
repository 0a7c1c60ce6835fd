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


def test_a_limb_moves_only_when_it_gains_more_than_min_gain():
    """With ``min_gain`` between the limbs' gains, the limbs below it keep the start's angles
    exactly and every reported gain exceeds it; above every gain nothing moves."""
    model = BodyModel()
    truth = _random_limbs(model, np.random.default_rng(11))
    seen = Measurement(rasterise(model, truth[None], GRID) > 0, GRID)
    start = model.default_state()
    _, free = sweep_limbs(seen, model, start, samples=256, sweeps=1)
    positive = sorted(g for g in free.values() if g > 0)
    assert len(positive) >= 2, free
    margin = 0.5 * (positive[0] + positive[1])
    found, gains = sweep_limbs(seen, model, start, samples=256, sweeps=1, min_gain=margin)
    for name, (dims, _) in LIMBS.items():
        if gains[name] == 0.0:
            np.testing.assert_array_equal(found[list(dims)], start[list(dims)])
        else:
            assert gains[name] > margin
    assert any(g == 0.0 for g in gains.values()) and any(g > 0 for g in gains.values())
    before, after = log_likelihood(seen, model, np.stack([start, found]))
    assert np.isclose(after - before, sum(gains.values()), atol=1e-9)
    same, none = sweep_limbs(seen, model, start, samples=256, sweeps=1,
                             min_gain=positive[-1] + 1.0)
    np.testing.assert_array_equal(same, model.clip(start[None])[0])
    assert not any(none.values())


def test_min_gain_must_not_be_negative():
    import pytest

    with pytest.raises(ValueError, match="min_gain"):
        sweep_limbs(Measurement(np.zeros(GRID.shape, bool), GRID), BodyModel(),
                    BodyModel().default_state(), min_gain=-1.0)
