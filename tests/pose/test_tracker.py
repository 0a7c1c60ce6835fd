"""The body tracker on rasterised poses: records, initialisation, checkpoints, observers."""

import re

import numpy as np
import pytest

from voxelmocap.body import BodyModel
from voxelmocap.config import TrackConfig, with_overrides
from voxelmocap.errors import InputError
from voxelmocap.grid import VoxelGrid
from voxelmocap.pose.filter_setup import noise_profile
from voxelmocap.pose.records import Collector
from voxelmocap.pose.tracker import BodyTracker
from voxelmocap.score.likelihood import Measurement, log_likelihood, part_scores, rasterise

# the joint search (paper 002) with no settling: these tests check the tracker against the
# filter it assembles; the hierarchical search has its own (tests/tracking/test_partitioned.py)
SMALL = with_overrides(TrackConfig(), **{"filter.layers": 2, "filter.particles": 40,
                                         "filter.search": "joint", "init.settle_steps": 0})
MODEL = BodyModel()
GRID = VoxelGrid((-1200.0, -1200.0, 0.0), 40.0, (60, 60, 50))


def walk_states(n=4):
    """Standing poses sliding 30 mm per frame along +Y with a swinging right knee."""
    x = np.repeat(MODEL.default_state()[None], n, axis=0)
    x[:, 1] += 30.0 * np.arange(n)
    x[:, list(MODEL.state_names).index("r_knee")] = np.linspace(0.0, 0.6, n)
    return MODEL.clip(x)


def observations(states):
    return [Measurement(rasterise(MODEL, s[None], GRID) > 0, GRID) for s in states]


@pytest.fixture(scope="module")
def walk():
    states = walk_states()
    return states, observations(states)


def test_record_describes_the_estimate(walk):
    states, obs = walk
    tracker = BodyTracker(MODEL, SMALL, seed=3)
    assert tracker.initialise(obs[0], MODEL.landmarks(states[:1])[0], frame=7) \
        == "the ground truth of frame 7"
    record = tracker.step(obs[0], frame=7)
    est = record.state[None]
    # Every field against the model and the likelihood called directly on the estimate.
    assert record.frame == 7
    np.testing.assert_array_equal(record.landmarks, MODEL.landmarks(est)[0])
    np.testing.assert_array_equal(record.endpoints, MODEL.endpoints(est)[0])
    np.testing.assert_array_equal(record.part_scores, part_scores(obs[0], MODEL, est)[0])
    assert record.log_likelihood == pytest.approx(
        float(log_likelihood(obs[0], MODEL, est, variances=SMALL.likelihood.variances)[0]),
        abs=1e-12)
    np.testing.assert_array_equal(record.map_state, tracker.filter.map_particle)
    assert record.ess.shape == record.betas.shape == (2,)
    assert np.all((record.ess >= 1.0) & (record.ess <= 40.0))
    assert 0.0 <= record.likelihood_seconds <= record.seconds


def test_tracker_equals_the_filter_it_assembles(walk):
    """The tracker adds nothing to the filter's numbers: same seed, same estimates."""
    from voxelmocap.body import fit_to_landmarks
    from voxelmocap.pose.filter_setup import build_filter

    states, obs = walk
    gt = MODEL.landmarks(states[:1])[0]
    tracker = BodyTracker(MODEL, SMALL, seed=5)
    records = tracker.track(obs, frames=range(1, len(obs) + 1), ground_truth=gt)
    pf = build_filter(MODEL, SMALL, np.random.default_rng(5))
    pf.initialise(fit_to_landmarks(MODEL, gt), SMALL.init.spread * noise_profile(MODEL, SMALL))
    for record, o in zip(records, obs, strict=True):
        est = pf.step(lambda x, o=o: log_likelihood(o, MODEL, x,
                                                    variances=SMALL.likelihood.variances,
                                                    coverage=SMALL.likelihood.coverage))
        np.testing.assert_array_equal(record.state, MODEL.clip(est[None])[0])


def test_checkpoint_resumes_bit_identically(walk):
    states, obs = walk
    gt = MODEL.landmarks(states[:1])[0]
    full = BodyTracker(MODEL, SMALL, seed=11).track(obs, ground_truth=gt)
    first = BodyTracker(MODEL, SMALL, seed=11)
    first.track(obs[:2], ground_truth=gt)
    checkpoint = first.get_state()
    second = BodyTracker(MODEL, SMALL, seed=999)  # the seed is overwritten by the checkpoint
    second.set_state(checkpoint)
    rest = second.track(obs[2:])
    for a, b in zip(full[2:], rest, strict=True):
        np.testing.assert_array_equal(a.state, b.state)
        np.testing.assert_array_equal(a.map_state, b.map_state)
        np.testing.assert_array_equal(a.ess, b.ess)


def test_observers_see_every_record(walk):
    states, obs = walk
    seen = []
    kept = Collector("frame", "state")
    tracker = BodyTracker(MODEL, SMALL, seed=0,
                          observers=[kept, lambda rec, trk: seen.append((rec.frame, trk))])
    records = tracker.track(obs, frames=[3, 4, 5, 6], ground_truth=MODEL.landmarks(states[:1])[0])
    assert [f for f, _ in seen] == [3, 4, 5, 6] and all(t is tracker for _, t in seen)
    out = kept.stacked()
    np.testing.assert_array_equal(out["frame"], [3, 4, 5, 6])
    np.testing.assert_array_equal(out["state"], np.array([r.state for r in records]))


def test_noise_override_replaces_the_profile():
    # the profile itself: tests/pose/test_filter_setup.py
    profile = noise_profile(MODEL, SMALL)
    custom = np.full(27, 0.01)
    tracker = BodyTracker(MODEL, SMALL, noise_std=custom)
    np.testing.assert_array_equal(tracker.filter.noise_std, custom)
    np.testing.assert_array_equal(BodyTracker(MODEL, SMALL).filter.noise_std, profile)
    with pytest.raises(InputError, match="noise_std"):
        BodyTracker(MODEL, SMALL, noise_std=np.ones(26))
    with pytest.raises(InputError, match="noise_std"):
        BodyTracker(MODEL, SMALL, noise_std=-custom)


def test_initialisation_methods(walk):
    states, obs = walk
    gt = MODEL.landmarks(states[:1])[0]
    vox = BodyTracker(MODEL, with_overrides(SMALL, **{"init.method": "voxels"}))
    method, state = vox.initial_state(obs[0], gt, frame=1)
    assert method.startswith("the voxels of frame 1")
    # the blob's centroid, standing, facing one of the 36 headings
    assert abs(state[0] - states[0, 0]) < 60.0 and abs(state[1] - states[0, 1]) < 60.0
    auto = BodyTracker(MODEL, SMALL)
    assert auto.initial_state(obs[0], None, frame=2)[0].startswith("the voxels of frame 2")
    assert auto.initial_state(obs[0], gt, frame=2)[0] == "the ground truth of frame 2"
    strict = BodyTracker(MODEL, with_overrides(SMALL, **{"init.method": "ground_truth"}))
    with pytest.raises(InputError, match="ground truth of frame 4 is not available"):
        strict.initialise(obs[0], None, frame=4)
    empty = Measurement(np.zeros(GRID.shape, bool), GRID)
    with pytest.raises(InputError, match="no occupied voxel"):
        vox.initialise(empty, None, frame=1)
    with pytest.raises(RuntimeError, match="initialise"):
        BodyTracker(MODEL, SMALL).step(obs[0])


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("survival = 0.0", "'filter.survival' must be in (0, 1]"),
        ("survival = 1.2", "'filter.survival' must be in (0, 1]"),
        ("particles = 1", "'filter.particles' must be an integer >= 2"),
        ("betas = [0.1, 1.0]", "'filter.betas' must be 6 finite numbers"),
        ("alphas = [1.0, 0.0, 1.0, 1.0, 1.0, 1.0]", "'filter.alphas'"),
        ("noise_decay = 1.5", "'filter.noise_decay'"),
        ("beta_max = -1.0", "'filter.beta_max' must be > 0"),
        ("resampling = 'magic'", "'filter.resampling' must be one of"),
        ("iapf_fractions = [0.8, 0.5]", "'filter.iapf_fractions' must be two fractions"),
        ("velocity_factor = 1.5", "factor must be in [0, 1]"),
        ("elbow_singular_std_rad = -0.1", "must be >= 0"),
    ],
)
def test_filter_options_are_checked_by_the_filters_own_rules(text, message):
    from voxelmocap.config import config_from_toml

    with pytest.raises(InputError, match=re.escape(message)):
        config_from_toml(f"[filter]\n{text}\n", source="cfg.toml")


def test_one_statement_of_the_ranges_and_names():
    """The config accepts exactly what the filter accepts, and offers the registries' names."""
    import dataclasses

    from voxelmocap.config import FilterConfig, config_from_toml
    from voxelmocap.tracking import (
        DYNAMICS,
        SCHEMES,
        SEARCHES,
        STRATEGIES,
        AnnealedParticleFilter,
    )

    cfg = config_from_toml("[filter]\nsurvival = 1.0\n")  # the filter's (0, 1], not (0, 1)
    AnnealedParticleFilter(10, 2, [0.0], [1.0], 0.1, survival=cfg.filter.survival)
    choices = {f.name: set(f.metadata["choices"]) for f in dataclasses.fields(FilterConfig)
               if "choices" in f.metadata}
    assert choices == {"strategy": set(STRATEGIES), "dynamics": set(DYNAMICS),
                       "resampling": set(SCHEMES), "search": set(SEARCHES)}
    iapf = config_from_toml("[filter]\nstrategy = 'iapf'\niapf_fractions = [0.8, 0.0]\n"
                            "layers = 2\nparticles = 20\n")
    states = walk_states(2)  # tracks: 80 % from the dynamics, 20 % from the prior, corrected
    tracker = BodyTracker(MODEL, iapf, seed=0)
    tracker.track(observations(states), ground_truth=MODEL.landmarks(states[:1])[0])
    assert tracker.filter.iapf_corrected


def test_settling_steps_bring_a_rough_start_closer_before_the_first_record():
    deg = np.pi / 180
    grid = VoxelGrid((-1000.0, -1000.0, 0.0), 30.0, (67, 67, 67))
    truth = MODEL.default_state()
    truth[[11, 17, 19, 25]] = (30 * deg, 40 * deg, 25 * deg, 30 * deg)
    seen = Measurement(rasterise(MODEL, truth[None], grid) > 0, grid)
    start = truth.copy()
    start[[0, 3, 11, 19]] += (60.0, 12 * deg, -15 * deg, -15 * deg)
    errors = {}
    for steps in (0, 6):
        # the default (hierarchical) search, small: with the joint search at 3 × 150 the
        # first step alone is a coin toss (settled or not, 52–75 mm over three seeds)
        config = with_overrides(TrackConfig(), **{"filter.trunk_particles": 150,
                                                  "filter.limb_particles": 60,
                                                  "init.settle_steps": steps})
        tracker = BodyTracker(MODEL, config, seed=1)
        tracker.start("test", start)
        record = tracker.step(seen, frame=1)
        errors[steps] = np.linalg.norm(record.landmarks - MODEL.landmarks(truth[None])[0],
                                       axis=1).mean()
        # the settling steps are not motion: one estimate in the history, frame count 1
        assert tracker.filter.history.shape[0] == 1 and tracker.filter.frame == 1
    assert errors[6] < 0.9 * errors[0], errors


def test_the_limb_proposal_reaches_the_hierarchical_search(walk):
    """``filter.limb_proposal`` builds the frame's detector proposal and hands it to the
    partitioned filter; 0 builds none."""
    states, obs = walk
    for share, built in ((0.0, False), (0.2, True)):
        cfg = with_overrides(SMALL, **{"filter.search": "hierarchical",
                                       "filter.trunk_particles": 40,
                                       "filter.limb_particles": 20,
                                       "filter.limb_proposal": share})
        tracker = BodyTracker(MODEL, cfg, seed=1)
        tracker.initialise(obs[0], MODEL.landmarks(states[:1])[0])
        seen = []
        step = tracker.filter.step_partitioned
        tracker.filter.step_partitioned = (
            lambda f, seen=seen, step=step, **kw: seen.append(kw) or step(f, **kw))
        for o in obs[:3]:
            tracker.step(o)
        assert (tracker.last_proposal is not None) == built
        # the first step has no estimate to propose around yet
        assert [bool(kw) for kw in seen] == [False, built, built]
        if built:
            assert seen[1]["proposal_share"] == 0.2 and callable(seen[1]["proposal"])


LOST_ARM_GRID = VoxelGrid((-1000.0, -1000.0, 0.0), 30.0, (67, 67, 67))
#: one-step sweep settings of the lost-arm tests: voxels of the model itself, so the paper's
#: σ²_DO (see test_partitioned.py) and the paper's likelihood alone
LOST_ARM_CONFIG = {"filter.limb_sweep_every": 1, "filter.joint_std_rad": 0.01,
                   "likelihood.variances": (0.01, 0.01, 0.1, 0.1), "likelihood.coverage": 0.0}


def _lost_arm_truth():
    """The default pose with the left arm raised forward (shoulder flexed, elbow bent)."""
    truth = MODEL.default_state()
    truth[[11, 17]] = (1.4, 0.6)
    return truth


def _wrist_error_after_one_step(seen, truth, **overrides):
    """Left-wrist error (mm) of one tracker step from the default pose (arm hanging)."""
    cfg = with_overrides(SMALL, **LOST_ARM_CONFIG, **overrides)
    tracker = BodyTracker(MODEL, cfg, seed=0)
    tracker.start("test", MODEL.default_state())
    record = tracker.step(seen)
    return float(np.linalg.norm(record.landmarks[4] - MODEL.landmarks(truth[None])[0, 4]))


def test_the_periodic_limb_sweep_finds_a_lost_arm_and_moves_the_particles():
    """Truth: the rasterised pose has the left arm raised forward; the track starts with the arm
    hanging. One step with ``filter.limb_sweep_every = 1`` finds the arm; the filter's particles
    and estimate follow it."""
    truth = MODEL.default_state()
    truth[[11, 17]] = (1.4, 0.6)                       # left shoulder flexed, elbow bent
    grid = VoxelGrid((-1000.0, -1000.0, 0.0), 30.0, (67, 67, 67))
    seen = Measurement(rasterise(MODEL, truth[None], grid) > 0, grid)
    # voxels of the model itself: the paper's σ²_DO (see test_partitioned.py) and the paper's
    # likelihood alone — with the coverage term the 40-particle step after the sweep spreads the
    # estimate (wrist 113 mm); the sweep itself finds the arm with it too (checked below)
    cfg = with_overrides(SMALL, **{"filter.limb_sweep_every": 1, "filter.joint_std_rad": 0.01,
                                   "likelihood.variances": (0.01, 0.01, 0.1, 0.1),
                                   "likelihood.coverage": 0.0})
    tracker = BodyTracker(MODEL, cfg, seed=0)
    tracker.start("test", MODEL.default_state())
    record = tracker.step(seen)
    wrist = np.linalg.norm(record.landmarks[4] - MODEL.landmarks(truth[None])[0, 4])
    assert wrist < 60.0, wrist
    from voxelmocap.pose.limb_search import LimbScoring, sweep_limbs

    found, _ = sweep_limbs(seen, MODEL, MODEL.default_state(), sweeps=1, scoring=LimbScoring(
        variances=(0.01, 0.01, 0.1, 0.1), coverage=TrackConfig().likelihood.coverage))
    assert np.linalg.norm(MODEL.landmarks(found[None])[0, 4]
                          - MODEL.landmarks(truth[None])[0, 4]) < 60.0
    np.testing.assert_array_equal(tracker.filter.estimate, record.state)
    assert abs(np.median(tracker.filter.particles[:, 11]) - record.state[11]) < 0.2


def test_the_periodic_sweep_keeps_a_limb_whose_gain_is_below_limb_sweep_gain():
    """The same lost arm with ``filter.limb_sweep_gain`` above what finding it gains: the sweep
    leaves the arm hanging (the 40-particle step cannot reach it by itself either)."""
    from voxelmocap.pose.limb_search import LimbScoring, sweep_limbs

    truth = _lost_arm_truth()
    seen = Measurement(rasterise(MODEL, truth[None], LOST_ARM_GRID) > 0, LOST_ARM_GRID)
    _, gains = sweep_limbs(seen, MODEL, MODEL.default_state(), sweeps=1, seed=1,
                           scoring=LimbScoring(variances=LOST_ARM_CONFIG["likelihood.variances"]))
    wrists = [_wrist_error_after_one_step(seen, truth, **{"filter.limb_sweep_gain": gain})
              for gain in (0.0, gains["l_arm"] + 1.0)]
    assert gains["l_arm"] > 0 and wrists[0] < 60.0 and wrists[1] > 200.0, (gains, wrists)


def test_the_periodic_sweep_is_skipped_when_the_hull_is_several_times_the_body():
    """The lost arm again, with a block of occupied voxels far from the body that takes the
    occupied volume to about three times the body's: at ``limb_sweep_max_hull = 2`` the sweep
    does not run (the arm stays hanging); allowed any hull, it finds the arm as before."""
    from voxelmocap.pose.recovery import body_volume

    truth = _lost_arm_truth()
    occupancy = rasterise(MODEL, truth[None], LOST_ARM_GRID) > 0
    occupancy[:17, :17, :17] = True                     # a corner 500 mm from the body
    seen = Measurement(occupancy, LOST_ARM_GRID)
    ratio = seen.n_occupied * 30.0 ** 3 / body_volume(MODEL)
    assert 2.5 < ratio < 4.0, ratio
    wrists = [_wrist_error_after_one_step(seen, truth, **{"filter.limb_sweep_max_hull": m})
              for m in (2.0, 100.0)]
    assert wrists[0] > 200.0 and wrists[1] < 60.0, wrists


def test_the_coverage_weight_reaches_every_likelihood_the_tracker_uses(walk):
    """``[likelihood] coverage`` is in the joint filter's callable, in every partition of the
    hierarchical search (full and partial scoring) and in the limb sweep's scores: each equals
    log_likelihood(..., coverage=w) called directly."""
    from voxelmocap.pose.hierarchy import BODY_PARTITIONS
    from voxelmocap.pose.limb_search import LimbScoring, sweep_limbs

    states, obs = walk
    w = 250.0
    cfg = with_overrides(TrackConfig(), **{"likelihood.coverage": w})
    var = cfg.likelihood.variances
    tracker = BodyTracker(MODEL, cfg, seed=0)
    rng = np.random.default_rng(5)
    ref = states[1]
    xs = MODEL.clip(ref + rng.normal(0.0, 0.1, (20, 27)) * np.r_[np.full(3, 50.0), np.ones(24)])
    expect = log_likelihood(obs[1], MODEL, xs, variances=var, coverage=w)
    assert not np.allclose(expect, log_likelihood(obs[1], MODEL, xs, variances=var))
    np.testing.assert_allclose(tracker.log_likelihood(obs[1])(xs), expect, rtol=1e-12)
    factory = tracker.partition_log_likelihood(obs[1])
    for k, (dims, _) in enumerate(BODY_PARTITIONS):
        moved = np.repeat(ref[None], len(xs), axis=0)
        moved[:, list(dims)] = xs[:, list(dims)]
        np.testing.assert_allclose(factory(k, ref)(moved),
                                   log_likelihood(obs[1], MODEL, moved, variances=var,
                                                  coverage=w), rtol=1e-12)
    # the start's limb sweep: the tracker's answer is the sweep's with the same weight
    swept, _ = tracker.sweep_limbs(obs[1], xs[3][None])
    alone, _ = sweep_limbs(obs[1], MODEL, xs[3], scoring=LimbScoring(variances=var, coverage=w),
                           seed=0)
    np.testing.assert_array_equal(swept[0], alone)


def test_the_start_is_scored_without_the_coverage_term(walk, monkeypatch):
    """initial_state (voxel start, extremity hypotheses, limb sweep) never evaluates the
    coverage term; the tracking callables afterwards do."""
    from voxelmocap.score import likelihood

    _, obs = walk
    cfg = with_overrides(TrackConfig(), **{"likelihood.coverage": 250.0,
                                           "init.method": "extremities"})
    tracker = BodyTracker(MODEL, cfg, seed=0)
    calls = []
    real = likelihood.coverage_log_likelihood

    def counted(*args, **kwargs):
        calls.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(likelihood, "coverage_log_likelihood", counted)  # the full and partial paths
    phrase, start = tracker.initial_state(obs[0])
    assert "limbs searched" in phrase and calls == []
    assert tracker.coverage == 250.0
    tracker.log_likelihood(obs[0])(np.atleast_2d(start))
    assert calls
