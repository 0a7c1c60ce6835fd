"""The IAPF's detector proposal (voxelmocap.pose.proposal): its mixture's density against scipy's
truncated normals, and the inverse-kinematics fit to a frame's extremities."""

import numpy as np
import pytest
from scipy import stats

from voxelmocap.body import BodyModel
from voxelmocap.grid import VoxelGrid
from voxelmocap.pose.proposal import MixtureProposal, detector_proposal
from voxelmocap.score.likelihood import Measurement, rasterise

MODEL = BodyModel()
GRID = VoxelGrid((-1200.0, -1200.0, 0.0), 40.0, (60, 60, 50))


def seen(state):
    return Measurement(rasterise(MODEL, np.asarray(state)[None], GRID) > 0, GRID)


def test_mixture_samples_follow_the_density_it_claims():
    low, high = np.array([-1.0, 0.0, -5.0]), np.array([2.0, 10.0, 5.0])
    means = np.array([[0.0, 1.0, 4.5], [1.5, 6.0, -1.0]])
    std = np.array([0.5, 2.0, 1.5])
    mix = MixtureProposal(means, std, low, high)
    x = mix.sample(20000, np.random.default_rng(0))
    assert x.shape == (20000, 3) and np.all(x >= low) and np.all(x <= high)

    # Independent truth: scipy's truncated normals, an equal-weight mixture per dimension.
    def marginal_cdf(d):
        parts = [stats.truncnorm((low[d] - m) / std[d], (high[d] - m) / std[d], loc=m,
                                 scale=std[d]) for m in means[:, d]]
        return lambda v: np.mean([p.cdf(v) for p in parts], axis=0)

    for d in range(3):
        assert stats.kstest(x[:, d], marginal_cdf(d)).pvalue > 1e-3, d
    # The components are sampled jointly (one component per draw, not per dimension): the
    # share of draws with dim 1 > 4 and dim 2 > 2 is the mixture of the components' products,
    # far from the product of the marginals that mixing each dimension alone would give.
    def tail(d, k, v):
        m = means[k, d]
        return stats.truncnorm.sf(v, (low[d] - m) / std[d], (high[d] - m) / std[d], loc=m,
                                  scale=std[d])

    joint = np.mean([tail(1, k, 4.0) * tail(2, k, 2.0) for k in range(2)])
    product = np.mean([tail(1, k, 4.0) for k in range(2)]) * np.mean([tail(2, k, 2.0)
                                                                      for k in range(2)])
    share = np.mean((x[:, 1] > 4.0) & (x[:, 2] > 2.0))
    assert abs(share - joint) < 4 * np.sqrt(joint * (1 - joint) / len(x))
    assert abs(share - product) > 10 * np.sqrt(joint * (1 - joint) / len(x))

    # log_pdf: the mixture of products of scipy's densities.
    pts = np.array([[0.1, 1.2, 4.0], [1.4, 5.0, -0.5], [-0.9, 9.9, 0.0]])
    truth = np.log(np.mean([np.prod([stats.truncnorm.pdf(
        pts[:, d], (low[d] - m[d]) / std[d], (high[d] - m[d]) / std[d], loc=m[d],
        scale=std[d]) for d in range(3)], axis=0) for m in means], axis=0))
    np.testing.assert_allclose(mix.log_pdf(pts), truth, rtol=1e-9)
    assert mix.log_pdf(np.array([[3.0, 1.0, 0.0]]))[0] == -np.inf  # outside the bounds
    proposal, log_pdf = mix  # unpacks as the filter's pair
    np.testing.assert_array_equal(log_pdf(pts), mix.log_pdf(pts))
    assert proposal(5, np.random.default_rng(1)).shape == (5, 3)


def test_detector_proposal_moves_the_limbs_to_the_detected_ends():
    rng = np.random.default_rng(4)
    names = list(MODEL.state_names)
    truth = MODEL.default_state()
    truth[names.index("l_shoulder_abd")] = 1.2  # arms out: tips of their own
    truth[names.index("r_shoulder_abd")] = 1.0
    truth[names.index("r_shoulder_flex")] = 0.6
    truth[names.index("l_hip_flex")] = 0.5
    truth[names.index("l_knee")] = 0.6
    truth = MODEL.clip(truth[None])[0]
    obs = seen(truth)
    previous = truth.copy()
    limbs = [names.index(n) for n in ("l_shoulder_abd", "r_shoulder_abd", "r_shoulder_flex",
                                      "l_hip_flex", "l_knee")]
    previous[limbs] += rng.choice([-1, 1], size=len(limbs)) * 0.35
    previous = MODEL.clip(previous[None])[0]

    def error(state):
        return float(np.linalg.norm(MODEL.landmarks(state[None]) - MODEL.landmarks(truth[None]),
                                    axis=2).mean())

    mix = detector_proposal(obs, MODEL, std=0.01, previous=previous, mirror=True)
    assert mix.labels[0].startswith("fit of")
    # The warm-started fit lands nearer the truth than where it started.
    assert error(mix.means[0]) < 0.6 * error(previous), (error(mix.means[0]), error(previous))
    # The mirrored labelling is there as a second component when asked for (off by default).
    assert len(mix) == 2 and mix.labels[1] == "left/right swapped fit"
    assert len(detector_proposal(obs, MODEL, std=0.01, previous=previous)) == 1
    # The detector runs once per observation (the starts of a MultiStart share it).
    from voxelmocap.measure.detect import find_extremities
    from voxelmocap.pose.proposal import extremities_of

    assert extremities_of(obs) is extremities_of(obs)
    np.testing.assert_array_equal(extremities_of(obs).points,
                                  find_extremities(obs.occupancy, obs.grid).points)


def test_detector_proposal_without_detection_stays_on_the_previous_estimate():
    obs = Measurement(np.zeros(GRID.shape, bool), GRID)
    previous = MODEL.default_state()
    mix = detector_proposal(obs, MODEL, std=0.1, previous=previous)
    np.testing.assert_array_equal(mix.means, previous[None])
    with pytest.raises(ValueError, match="previous estimate"):
        detector_proposal(obs, MODEL, std=0.1)
