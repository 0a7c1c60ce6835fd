"""Per-landmark confidence: spread against brute force, within-δ probability against scipy."""

import numpy as np
import pytest
from scipy import stats

from voxelmocap.body import PART_NAMES
from voxelmocap.joints import LANDMARK_NAMES
from voxelmocap.pose.confidence import (
    LANDMARK_PARTS,
    landmark_confidence,
    landmark_spread,
    landmark_support,
    searched_spread,
    within_probability,
)


def test_spread_is_the_weighted_rms_distance():
    rng = np.random.default_rng(0)
    x = rng.normal(size=(50, 15, 3)) * 30.0
    w = rng.random(50)
    w /= w.sum()
    expected = np.empty(15)
    for m in range(15):  # brute force, one landmark at a time
        mean = sum(w[i] * x[i, m] for i in range(50))
        expected[m] = np.sqrt(sum(w[i] * np.sum((x[i, m] - mean) ** 2) for i in range(50)))
    np.testing.assert_allclose(landmark_spread(x, w), expected, rtol=1e-12)
    # an isotropic Gaussian cloud of per-axis std s has RMS 3-D spread s·√3
    cloud = rng.normal(size=(200000, 1, 3)) * 20.0
    uniform = np.full(len(cloud), 1.0 / len(cloud))
    assert landmark_spread(cloud, uniform)[0] == pytest.approx(20.0 * np.sqrt(3), rel=5e-3)
    assert landmark_spread(np.ones((4, 15, 3)), np.full(4, 0.25)).max() == 0.0


def test_within_probability_is_the_chi3_cdf():
    spread = np.array([10.0, 50.0, 100.0, 173.2, 400.0])
    sigma = spread / np.sqrt(3)
    np.testing.assert_allclose(within_probability(spread, delta=100.0),
                               stats.chi(3).cdf(100.0 / sigma), rtol=1e-10, atol=1e-14)
    assert within_probability(np.array([0.0]))[0] == 1.0
    assert np.isnan(within_probability(np.array([np.nan]))[0])


def test_support_and_confidence_follow_the_parts():
    assert set(LANDMARK_PARTS) == set(LANDMARK_NAMES)
    assert all(set(p) <= set(PART_NAMES) for p in LANDMARK_PARTS.values())
    scores = np.zeros((len(PART_NAMES), 4))
    scores[PART_NAMES.index("l_forearm"), 2] = 1.0  # forearm entirely outside the voxels
    scores[PART_NAMES.index("l_upper_arm"), 2] = 0.5
    support = landmark_support(scores, PART_NAMES)
    lm = list(LANDMARK_NAMES)
    assert support[lm.index("l_wrist")] == 0.0
    assert support[lm.index("l_elbow")] == pytest.approx(0.25)  # mean of 0.5 and 0
    assert support[lm.index("r_wrist")] == 1.0
    spread = np.full(15, 50.0)
    conf = landmark_confidence(spread, scores, PART_NAMES)
    np.testing.assert_allclose(conf, support * stats.chi(3).cdf(100.0 / (50.0 / np.sqrt(3))))
    # parts the model does not have are left out; a landmark with none is unknown
    partial = landmark_support(scores[:1], PART_NAMES[:1])
    assert partial[lm.index("pelvis")] == 1.0 and np.isnan(partial[lm.index("head")])


def test_searched_spread_of_one_group_over_every_dimension_is_the_particles_spread():
    rng = np.random.default_rng(1)
    A = rng.normal(size=(15 * 3, 6))

    def landmarks_of(x):
        return (x @ A.T).reshape(len(x), 15, 3)

    particles = rng.normal(size=(40, 6))
    w = rng.random(40)
    w /= w.sum()
    estimate = rng.normal(size=6)  # unused: every dimension comes from the particles
    np.testing.assert_allclose(searched_spread(landmarks_of, estimate,
                                               [(np.arange(6), particles, w)]),
                               landmark_spread(landmarks_of(particles), w), rtol=1e-12)
    assert np.isnan(searched_spread(landmarks_of, estimate, [])).all()


def test_searched_spread_adds_each_groups_variance_of_a_linear_map():
    """Landmarks linear in the state: each group's spread² is trace(A_g Σ_g A_gᵀ) per landmark
    (Σ_g the weighted covariance of its own dimensions), whatever the estimate."""
    rng = np.random.default_rng(2)
    A = rng.normal(size=(4 * 3, 7))

    def landmarks_of(x):
        return (x @ A.T).reshape(len(x), 4, 3)

    groups = []
    for dims in (np.array([0, 1, 2]), np.array([3, 4]), np.array([5, 6])):
        n = int(rng.integers(20, 60))
        w = rng.random(n)
        groups.append((dims, rng.normal(size=(n, len(dims))) * rng.uniform(1, 5), w / w.sum()))
    expected = np.zeros(4)
    for dims, own, w in groups:
        mean = w @ own
        cov = (own - mean).T @ np.diag(w) @ (own - mean)
        for m in range(4):
            rows = A[3 * m: 3 * m + 3][:, dims]
            expected[m] += np.trace(rows @ cov @ rows.T)
    for estimate in (np.zeros(7), rng.normal(size=7) * 100):
        np.testing.assert_allclose(searched_spread(landmarks_of, estimate, groups),
                                   np.sqrt(expected), rtol=1e-10)


def test_tracker_records_spread_and_confidence():
    """The hierarchical search's spread comes from every partition: no landmark is 0 (the last
    layer of the step alone moves only the last limb: 13 of 15 landmarks were exactly 0)."""
    from voxelmocap.body import BodyModel
    from voxelmocap.config import TrackConfig, with_overrides
    from voxelmocap.grid import VoxelGrid
    from voxelmocap.pose.tracker import BodyTracker
    from voxelmocap.score.likelihood import Measurement, rasterise

    model = BodyModel()
    grid = VoxelGrid((-1000.0, -1000.0, 0.0), 40.0, (50, 50, 50))
    truth = model.default_state()
    seen = Measurement(rasterise(model, truth[None], grid) > 0, grid)
    config = with_overrides(TrackConfig(), **{"filter.layers": 2, "filter.particles": 40})
    assert config.filter.search == "hierarchical"
    tracker = BodyTracker(model, config, seed=0)
    tracker.initialise(seen, model.landmarks(truth[None])[0], frame=1)
    record = tracker.step(seen, frame=1)
    pf = tracker.filter
    last_layer = landmark_spread(model.forward(pf.particles).joints, pf.weights)
    assert np.sum(last_layer < 1e-6) >= 13      # why the last layer alone says little
    groups = pf.searched
    assert len(groups) == len(pf.partitions)
    assert sorted(np.concatenate([g[0] for g in groups]).tolist()) == list(range(27))
    variance = np.zeros(15)
    for dims, own, w in groups:                 # the definition, written out
        states = np.tile(record.state, (len(w), 1))
        states[:, dims] = own
        lm = model.forward(states).joints
        mean = np.einsum("p,pmk->mk", w, lm)
        variance += np.einsum("p,pm->m", w, np.sum((lm - mean) ** 2, axis=2))
    np.testing.assert_allclose(record.landmark_spread, np.sqrt(variance), rtol=1e-9)
    assert np.all(record.landmark_spread > 0)
    np.testing.assert_array_equal(
        record.confidence,
        landmark_confidence(record.landmark_spread, record.part_scores, model.part_names))
    assert record.observed is True


def test_joint_search_spread_is_the_last_layers():
    from voxelmocap.body import BodyModel
    from voxelmocap.config import TrackConfig, with_overrides
    from voxelmocap.grid import VoxelGrid
    from voxelmocap.pose.tracker import BodyTracker
    from voxelmocap.score.likelihood import Measurement, rasterise

    model = BodyModel()
    grid = VoxelGrid((-1000.0, -1000.0, 0.0), 40.0, (50, 50, 50))
    truth = model.default_state()
    seen = Measurement(rasterise(model, truth[None], grid) > 0, grid)
    config = with_overrides(TrackConfig(), **{"filter.layers": 2, "filter.particles": 40,
                                              "filter.search": "joint"})
    tracker = BodyTracker(model, config, seed=0)
    tracker.initialise(seen, model.landmarks(truth[None])[0], frame=1)
    record = tracker.step(seen, frame=1)
    pf = tracker.filter
    np.testing.assert_allclose(record.landmark_spread,
                               landmark_spread(model.forward(pf.particles).joints, pf.weights),
                               rtol=1e-12)
