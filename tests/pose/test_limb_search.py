"""The global limb search of a start (voxelmocap.pose.limb_search)."""

import numpy as np
import pytest

from voxelmocap.body import BodyModel
from voxelmocap.grid import VoxelGrid
from voxelmocap.pose.limb_search import LIMBS, LimbScoring, sweep_limbs
from voxelmocap.score.likelihood import Measurement, log_likelihood, rasterise

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


def test_only_the_limbs_named_are_searched():
    """``limbs``: the arms found where the voxels were rasterised, the legs left as they
    started (one straight down, the truth's elsewhere); the arms as a search of all four finds
    them (same Sobol points per limb). Unknown names are refused."""
    model = BodyModel()
    truth = _random_limbs(model, np.random.default_rng(5))
    seen = Measurement(rasterise(model, truth[None], GRID) > 0, GRID)
    start = model.default_state()
    arms = np.r_[LIMBS["l_arm"][0], LIMBS["r_arm"][0]]
    rest = np.setdiff1d(np.arange(model.n_dims), arms)
    found, gains = sweep_limbs(seen, model, start, samples=512, limbs=("l_arm", "r_arm"))
    np.testing.assert_array_equal(found[rest], model.clip(start[None])[0][rest])
    assert gains["l_leg"] == gains["r_leg"] == 0.0 and gains["l_arm"] > 0 and gains["r_arm"] > 0
    err = np.linalg.norm(model.landmarks(found[None])[0] - model.landmarks(truth[None])[0],
                         axis=1)
    wrists = [4, 7]                                # LANDMARK_NAMES: l_wrist, r_wrist
    assert err[wrists].max() < 80.0, err.round()
    with pytest.raises(ValueError, match="unknown limbs"):
        sweep_limbs(seen, model, start, limbs=("l_arm", "tail"))


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
    with pytest.raises(ValueError, match="min_gain"):
        sweep_limbs(Measurement(np.zeros(GRID.shape, bool), GRID), BodyModel(),
                    BodyModel().default_state(), min_gain=-1.0)


def _crossed_legs(model):
    """A pose whose thighs are adducted across each other (the left knee right of the right)."""
    from voxelmocap.body import STATE_INDEX as I

    x = model.default_state()
    x[[I["l_hip_abd"], I["r_hip_abd"]]] = model.low[I["l_hip_abd"]]
    x[[I["l_hip_flex"], I["r_hip_flex"]]] = (0.4, -0.2)
    x[[I["l_knee"], I["r_knee"]]] = (0.6, 0.3)
    return x


def test_swapped_limbs_exchange_angles_and_places():
    """Closed form: the first pose has the two limbs' angles exchanged exactly; the second puts
    each knee and ankle where the other leg's were (to within the joint limits' reach), and
    the rest of the body is untouched in both."""
    from voxelmocap.joints import LANDMARK_NAMES as L
    from voxelmocap.pose.limb_search import swapped_limbs

    model = BodyModel()
    x = _crossed_legs(model)
    angles, places = swapped_limbs(model, x, ("l_leg", "r_leg"))
    left, right = (list(LIMBS[n][0]) for n in ("l_leg", "r_leg"))
    np.testing.assert_array_equal(angles[left], x[right])
    np.testing.assert_array_equal(angles[right], x[left])
    rest = [d for d in range(27) if d not in left + right]
    np.testing.assert_array_equal(places[rest], x[rest])
    np.testing.assert_array_equal(angles[rest], x[rest])
    before, after = model.landmarks(np.stack([x, places]))
    for a, b in (("l_knee", "r_knee"), ("l_ankle", "r_ankle")):
        i, j = L.index(a), L.index(b)
        crossed = np.linalg.norm(before[i] - before[j])
        assert np.linalg.norm(after[i] - before[j]) < 0.4 * crossed
        assert np.linalg.norm(after[j] - before[i]) < 0.4 * crossed
    assert np.all(model.low <= places) and np.all(places <= model.high)


def test_the_swap_uncrosses_legs_a_one_limb_sweep_cannot():
    """Truth: the voxels of the uncrossed legs (the crossed pose's legs moved to each other's
    places); the start has them crossed. A sweep of one leg with the other held stays crossed
    (either leg alone would overlap the other); with ``swaps`` the legs end near the truth."""
    from voxelmocap.pose.limb_search import swapped_limbs

    model = BodyModel()
    crossed = _crossed_legs(model)
    truth = swapped_limbs(model, crossed, ("l_leg", "r_leg"))[1]
    seen = Measurement(rasterise(model, truth[None], GRID) > 0, GRID)

    def leg_error(state):
        idx = [9, 10, 12, 13]                    # knees and ankles
        return np.linalg.norm(model.landmarks(state[None])[0, idx]
                              - model.landmarks(truth[None])[0, idx], axis=1).max()

    plain, _ = sweep_limbs(seen, model, crossed, samples=256, sweeps=1, min_gain=2.0)
    swapped, gains = sweep_limbs(seen, model, crossed, samples=256, sweeps=1, min_gain=2.0,
                                 swaps=True)
    assert leg_error(swapped) < 60.0 < leg_error(plain), (leg_error(swapped), leg_error(plain))
    assert gains["l_leg"] > 0 and gains["r_leg"] > 0
    before, after = log_likelihood(seen, model, np.stack([crossed, swapped]))
    assert np.isclose(after - before, sum(gains.values()), atol=1e-6)


def test_other_cues_are_added_to_the_limb_scores():
    """An added term that only a raised left knee satisfies (voxels of the standing pose):
    without it the knee stays straight, with it the sweep bends it to the term's optimum."""
    from voxelmocap.body import STATE_INDEX as I

    model = BodyModel()
    stand = model.default_state()
    seen = Measurement(rasterise(model, stand[None], GRID) > 0, GRID)
    k = I["l_knee"]

    def others(states):
        return -200.0 * (np.asarray(states)[:, k] - 1.2) ** 2

    alone, _ = sweep_limbs(seen, model, stand, samples=256, sweeps=1)
    pulled, gains = sweep_limbs(seen, model, stand, samples=256, sweeps=1,
                                scoring=LimbScoring(others=others))
    assert abs(alone[k] - stand[k]) < 0.2
    assert abs(pulled[k] - 1.2) < 0.3 and gains["l_leg"] > 0


def test_the_voxel_weight_scales_the_voxel_scores():
    """Scaling every score by 2 changes no decision (``min_gain`` 0): the same pose, gains
    doubled; at weight 0 only the added term counts."""
    model = BodyModel()
    truth = _random_limbs(model, np.random.default_rng(3))
    seen = Measurement(rasterise(model, truth[None], GRID) > 0, GRID)
    start = model.default_state()
    one, g1 = sweep_limbs(seen, model, start, samples=128, sweeps=1)
    two, g2 = sweep_limbs(seen, model, start, samples=128, sweeps=1,
                          scoring=LimbScoring(voxel_weight=2.0))
    np.testing.assert_array_equal(one, two)
    for name in LIMBS:
        assert g2[name] == pytest.approx(2.0 * g1[name])
    k = 25                                                   # left knee

    def others(states):
        return -np.abs(np.asarray(states)[:, k] - 1.0)

    none, gains = sweep_limbs(seen, model, start, samples=128, sweeps=1,
                              scoring=LimbScoring(voxel_weight=0.0, others=others))
    assert abs(none[k] - 1.0) < 0.05
    for name in ("r_leg", "l_arm", "r_arm"):                 # nothing else scores
        assert gains[name] == 0.0
