"""The partitioned (hierarchical) annealing and the compass refinement."""

import numpy as np
import pytest

from voxelmocap.body import BodyModel
from voxelmocap.config import TrackConfig, with_overrides
from voxelmocap.errors import InputError
from voxelmocap.grid import VoxelGrid
from voxelmocap.pose.tracker import BodyTracker
from voxelmocap.score.likelihood import Measurement, log_likelihood, rasterise
from voxelmocap.tracking.partitioned import Partition, PartitionedParticleFilter
from voxelmocap.tracking.refine import pattern_search

DEG = np.pi / 180


def test_partitions_find_a_separable_optimum_and_count_evaluations():
    target = np.array([1.0, -2.0, 0.5, 3.0])
    seen = []

    def ll_for(k, ref):
        seen.append((k, ref.copy()))

        def ll(x):
            if k > 0:   # the contract: outside partition k the particles equal the reference
                others = [d for d in range(4) if d not in parts[k].dims]
                assert np.all(x[:, others] == ref[others])
            return -0.5 * np.sum((x - target) ** 2, axis=1) / 0.05 ** 2
        return ll

    parts = [Partition((0, 1), 4, 200), Partition((2,), 3, 100), Partition((3,), 3, 50)]
    f = PartitionedParticleFilter(parts, -5 * np.ones(4), 5 * np.ones(4), 0.3, rng=3)
    f.initialise(np.zeros(4), 1.0)
    for _ in range(8):
        est = f.step_partitioned(ll_for)
    np.testing.assert_allclose(est, target, atol=0.05)
    assert f.step_evaluations == 4 * 200 + 3 * 100 + 3 * 50
    assert f.particles.shape == (200, 4) and f.layer_ess.shape == (10,)
    assert [k for k, _ in seen[:3]] == [0, 1, 2]


def test_searched_holds_each_partitions_last_layer_and_moves_with_the_estimate():
    target = np.array([1.0, -2.0, 0.5, 3.0])

    def ll_for(k, ref):
        return lambda x: -0.5 * np.sum((x - target) ** 2, axis=1) / 0.05 ** 2

    parts = [Partition((0, 1), 2, 60), Partition((2,), 2, 40), Partition((3,), 2, 30)]
    f = PartitionedParticleFilter(parts, -5 * np.ones(4), 5 * np.ones(4), 0.3, rng=1)
    f.initialise(np.zeros(4), 1.0)
    assert f.searched == []                      # nothing searched before a step
    f.step_partitioned(ll_for)
    groups = f.searched
    assert [tuple(d) for d, _, _ in groups] == [(0, 1), (2,), (3,)]
    assert [own.shape for _, own, _ in groups] == [(60, 2), (40, 1), (30, 1)]
    for _, _, w in groups:
        assert w.min() >= 0 and w.sum() == pytest.approx(1.0)
    delta = np.array([0.5, -0.25, 0.0, 1.0])
    f.move_estimate(f.estimate + delta)
    for (dims, before, _), (_, after, _) in zip(groups, f.searched, strict=True):
        np.testing.assert_allclose(after, np.clip(before + delta[dims], -5, 5))
    f.initialise(np.zeros(4), 1.0)
    assert f.searched == []


def test_refinement_improves_the_estimate_within_its_budget():
    target = np.array([0.7, -0.4])

    def ll_for(k, ref):
        return lambda x: -0.5 * np.sum((x - target) ** 2, axis=1) / 0.01 ** 2

    errors = {}
    for budget in (0, 40):
        f = PartitionedParticleFilter([Partition((0,), 2, 30), Partition((1,), 2, 30)],
                                      -2 * np.ones(2), 2 * np.ones(2), 0.2, rng=7,
                                      refine_evaluations=budget)
        f.initialise(np.zeros(2), 0.5)
        est = f.step_partitioned(ll_for)
        errors[budget] = np.abs(est - target).max()
        assert f.step_evaluations <= 120 + 2 * budget
    assert errors[40] < errors[0] and errors[40] < 0.01


def test_pattern_search_matches_scipy_on_a_quadratic():
    from scipy.optimize import minimize

    a = np.array([[3.0, 0.5], [0.5, 1.0]])
    c = np.array([0.2, -0.3])

    def ll(x):
        d = x - c
        return -np.einsum("pi,ij,pj->p", d, a, d)

    x, _f, n = pattern_search(ll, np.zeros(2), [0, 1], np.array([0.4, 0.4]),
                             low=-np.ones(2), high=np.ones(2), max_evaluations=200,
                             min_step=1e-4)
    ref = minimize(lambda v: -ll(v[None])[0], np.zeros(2), method="Nelder-Mead",
                   options={"xatol": 1e-8, "fatol": 1e-12})
    np.testing.assert_allclose(x, ref.x, atol=1e-3)
    assert n <= 200


def test_partitions_must_cover_every_dimension_once():
    with pytest.raises(InputError, match="exactly once"):
        PartitionedParticleFilter([Partition((0,), 1, 10), Partition((0, 1), 1, 10)],
                                  np.zeros(3), np.ones(3), 0.1)


def test_hierarchical_tracker_recovers_a_pose_rendered_from_the_model():
    """The hierarchical search reaches a known optimum: the model's own rasterised pose."""
    model = BodyModel()
    grid = VoxelGrid((-1000.0, -1000.0, 0.0), 30.0, (67, 67, 67))
    truth = model.default_state()
    truth[[11, 12, 14, 17, 19, 25]] = (50 * DEG, 20 * DEG, -30 * DEG, 60 * DEG, 35 * DEG,
                                       40 * DEG)
    seen = Measurement(rasterise(model, truth[None], grid) > 0, grid)
    config = with_overrides(TrackConfig(), **{"filter.search": "hierarchical",
                                              "filter.trunk_particles": 200,
                                              "filter.limb_particles": 100,
                                              "filter.limb_layers": 3,
                                              "filter.refine_evaluations": 30,
                                              # voxels of the model itself: its own overlaps
                                              # are all there is, so the paper's σ²_DO (the
                                              # tracker's 0.1 allows for real bodies' joints)
                                              "likelihood.variances": (0.01, 0.01, 0.1, 0.1),
                                              # the search alone (the periodic limb sweep at
                                              # step 10 moved a wrist 118 mm off here)
                                              "filter.limb_sweep_every": 0})
    tracker = BodyTracker(model, config, seed=0)
    rng = np.random.default_rng(4)
    start = model.clip((truth + np.r_[rng.choice([-50.0, 50.0], 3),
                                      rng.choice([-15 * DEG, 15 * DEG], 24)])[None])[0]
    tracker.start("test", start)
    for _ in range(12):
        record = tracker.step(seen)
    err = np.linalg.norm(record.landmarks - model.landmarks(truth[None])[0], axis=1)
    # started 50 mm and 15° (every angle) away; 30 mm voxels
    assert np.median(err) < 25.0 and err.max() < 70.0, err.round()
    best = float(log_likelihood(seen, model, truth[None])[0])
    assert record.log_likelihood > best - 3.0


def test_a_proposal_lets_a_later_partition_leave_a_local_optimum():
    """Dimension 1 sits in a local mode at 0 (the global one is at 3, beyond the noise's reach);
    a proposal around 3 for a share of the first layer moves it there, and partition 1's
    particles still equal the reference outside their dimension."""
    def ll_for(k, ref):
        def ll(x):
            if k == 1:
                assert np.all(x[:, 0] == ref[0])
            near = -0.5 * (x[:, 1] / 0.2) ** 2
            far = -0.5 * ((x[:, 1] - 3.0) / 0.2) ** 2 + 5.0
            return np.logaddexp(near, far) - 0.5 * (x[:, 0] / 0.2) ** 2
        return ll

    def proposal(n, rng):
        return np.column_stack([rng.normal(5.0, 1.0, n), rng.normal(3.0, 0.1, n)])

    ends = {}
    for share in (0.0, 0.2):
        f = PartitionedParticleFilter([Partition((0,), 2, 100), Partition((1,), 2, 100)],
                                      -5 * np.ones(2), 5 * np.ones(2), 0.05, rng=1)
        f.initialise(np.zeros(2), 1.0)
        for _ in range(3):
            est = f.step_partitioned(ll_for, proposal=proposal, proposal_share=share)
        ends[share] = est
    assert abs(ends[0.0][1]) < 0.3 and abs(ends[0.2][1] - 3.0) < 0.3
    assert abs(ends[0.2][0]) < 0.3          # partition 0 takes nothing from the proposal
    with pytest.raises(InputError, match="proposal_share"):
        f.step_partitioned(ll_for, proposal=proposal, proposal_share=1.0)
