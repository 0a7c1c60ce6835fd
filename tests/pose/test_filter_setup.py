"""``pose.filter_setup``: the noise profile, the motion model, the filter and its layers per frame.

The profile is checked name by name against its rule; which search a config gets and how many
layers a frame has are checked against the filter actually built and stepped once (a quadratic
log-likelihood: no body, no voxels).
"""

import numpy as np
import pytest

from voxelmocap.body import BodyModel
from voxelmocap.config import TrackConfig, with_overrides
from voxelmocap.pose.filter_setup import (
    TRUNK_ANGLES,
    annealing_layers,
    build_dynamics,
    build_filter,
    noise_profile,
    searches_hierarchically,
)
from voxelmocap.tracking import RandomWalk, TwoStateElbow, VelocityModel
from voxelmocap.tracking.partitioned import PartitionedParticleFilter

SMALL = with_overrides(TrackConfig(), **{"filter.layers": 2, "filter.particles": 40,
                                         "filter.search": "joint", "init.settle_steps": 0})
MODEL = BodyModel()


def test_noise_profile_follows_its_rule_name_by_name():
    """Translation on its std, the root's three angles and the trunk's five on the rotation std
    (the trunk moves as slowly as the root), every limb angle on the joints' std."""
    config = with_overrides(TrackConfig(), **{"filter.translation_std_mm": 37.0,
                                              "filter.rotation_std_rad": 0.05,
                                              "filter.joint_std_rad": 0.21})
    trunk = {"root_yaw", "root_pitch", "root_roll", "waist_flex", "waist_side", "waist_twist",
             "neck_flex", "neck_side"}
    assert trunk >= set(TRUNK_ANGLES)
    expected = [37.0 if name in ("root_x", "root_y", "root_z") else
                0.05 if name in trunk else 0.21 for name in MODEL.state_names]
    profile = noise_profile(MODEL, config)
    assert profile.shape == (27,)
    np.testing.assert_array_equal(profile, expected)
    assert sum(v == 0.21 for v in expected) == 16          # 4 per limb


@pytest.mark.parametrize("rate", [30.0, 25.0, 120.0])
def test_the_noise_reaches_as_far_as_the_body_moves_between_frames_at_any_rate(rate):
    # a limb turning at a constant speed moves 60/rate times as far between two frames as at
    # 60 Hz, the rate the settings are stated at: the noise keeps that proportion
    from voxelmocap.pose.filter_setup import REFERENCE_RATE
    from voxelmocap.pose.multistart import MultiStart
    from voxelmocap.pose.tracker import BodyTracker

    speed = 3.0                                             # rad/s
    step_60, step = speed / REFERENCE_RATE, speed / rate
    at_60 = noise_profile(MODEL, SMALL)
    at_rate = noise_profile(MODEL, SMALL, rate)
    np.testing.assert_allclose(at_rate / step, at_60 / step_60, rtol=1e-12)
    np.testing.assert_array_equal(noise_profile(MODEL, SMALL, REFERENCE_RATE), at_60)
    tracker = BodyTracker(MODEL, SMALL, seed=0, frame_rate=rate)
    np.testing.assert_array_equal(tracker.noise_std, at_rate)
    np.testing.assert_array_equal(tracker.filter.noise_std, at_rate)
    starts = MultiStart(MODEL, SMALL, 0, np.zeros((2, 27)), 3, frame_rate=rate)
    for t in starts.trackers:
        np.testing.assert_array_equal(t.noise_std, at_rate)
    with pytest.raises(ValueError, match="frame_rate"):
        noise_profile(MODEL, SMALL, 0.0)


def test_dynamics_built_by_name():
    for name, cls in [("random_walk", RandomWalk), ("velocity", VelocityModel),
                      ("elbow", TwoStateElbow)]:
        dyn = build_dynamics(MODEL, with_overrides(SMALL, **{"filter.dynamics": name}).filter)
        assert type(dyn) is cls
    elbow = build_dynamics(MODEL, with_overrides(SMALL, **{"filter.dynamics": "elbow"}).filter)
    names = list(MODEL.state_names)
    assert list(elbow.twist_indices) == [names.index("l_shoulder_rot"),
                                         names.index("r_shoulder_rot")]
    assert list(elbow.elbow_indices) == [names.index("l_elbow"), names.index("r_elbow")]


def test_every_filter_option_reaches_the_filter_from_toml():
    import dataclasses

    from voxelmocap.config import config_from_toml

    text = """
    [filter]
    search = "joint"
    layers = 3
    particles = 50
    survival = 0.3
    noise_decay = 0.7
    betas = [0.1, 0.4, 1.0]
    alphas = [1.0, 4.0, 25.0]
    beta_max = 50.0
    resampling = "residual"
    iapf_fractions = [0.7, 0.1]
    dynamics = "elbow"
    velocity_factor = 0.5
    elbow_threshold_rad = 0.3
    elbow_singular_std_rad = 0.6
    """
    cfg = config_from_toml(text)
    pf = build_filter(MODEL, cfg, 0)
    assert (pf.n_layers, pf.n_particles, pf.survival, pf.beta_max) == (3, 50, 0.3, 50.0)
    np.testing.assert_array_equal(pf._betas, [0.1, 0.4, 1.0])
    np.testing.assert_allclose(pf._scales, 1.0 / np.sqrt([1.0, 4.0, 25.0]))  # alphas win
    assert pf.resampling == "residual" and pf.iapf_fractions == (0.7, 0.1)
    dyn = pf.dynamics
    assert (type(dyn), dyn.factor, dyn.threshold, dyn.singular_std) == (TwoStateElbow, 0.5, 0.3,
                                                                       0.6)
    # noise_decay reaches the filter when no alphas are given
    pf = build_filter(MODEL, dataclasses.replace(cfg, filter=dataclasses.replace(
        cfg.filter, alphas=None)), 0)
    np.testing.assert_allclose(pf._scales, np.sqrt(0.7 ** np.arange(3)))
    # every FilterConfig field is one of the above or a noise / size / strategy setting
    used = {"layers", "particles", "survival", "noise_decay", "betas", "alphas", "beta_max",
            "resampling", "iapf_fractions", "dynamics", "velocity_factor", "elbow_threshold_rad",
            "elbow_singular_std_rad", "strategy", "translation_std_mm", "rotation_std_rad",
            "joint_std_rad", "search", "trunk_layers", "trunk_particles", "limb_layers",
            "limb_particles", "refine_evaluations", "limb_explore", "limb_proposal",
            "limb_sweep_every", "limb_sweep_gain", "limb_sweep_max_hull",
            "limb_sweep_samples", "limb_swaps",
            # the tracker's periodic sweep (tests/pose/test_sweep_silhouette.py)
            "limb_sweep_silhouette",
            # the tracker's facing check, not the filter's (tests/pose/test_facing.py)
            "facing_check_every", "facing_margin", "facing_weight"}
    assert {f.name for f in dataclasses.fields(cfg.filter)} == used
    # the hierarchical search's own options
    hier = config_from_toml("""
    [filter]
    search = "hierarchical"
    trunk_layers = 4
    trunk_particles = 300
    limb_layers = 3
    limb_particles = 120
    refine_evaluations = 24
    survival = 0.4
    """)
    pf = build_filter(MODEL, hier, 0)
    assert [(len(p.dims), p.layers, p.particles) for p in pf.partitions] == \
        [(11, 4, 300), (8, 3, 240), (4, 3, 120), (4, 3, 120)]
    assert (pf.refine_evaluations, pf.survival, pf.n_total) == (24, 0.4, 300)


def _stepped(config):
    """The filter ``config`` builds, initialised at the standing pose and stepped once on a
    quadratic log-likelihood around it."""
    x0 = MODEL.default_state()
    scale = np.r_[np.full(3, 100.0), np.full(24, 0.3)]

    def ll(x):
        return -0.5 * np.sum(((x - x0) / scale) ** 2, axis=1)

    pf = build_filter(MODEL, config, np.random.default_rng(1))
    pf.initialise(x0, 0.1 * noise_profile(MODEL, config))
    if isinstance(pf, PartitionedParticleFilter):
        pf.step_partitioned(lambda k, reference: ll)
    else:
        pf.step(ll)
    return pf


SMALLER = {"filter.particles": 30, "filter.layers": 3, "filter.trunk_particles": 30,
           "filter.limb_particles": 20, "filter.trunk_layers": 3, "filter.limb_layers": 2}


@pytest.mark.parametrize("overrides, hierarchical, layers", [
    ({}, True, 3 + 3 * 2),                             # trunk, then legs and each arm
    ({"filter.search": "joint"}, False, 3),
    ({"filter.strategy": "sir"}, False, 1),           # one weighting, no annealing
    ({"filter.strategy": "sir", "filter.search": "joint"}, False, 1),
    ({"cues.weights": {"voxel": 2.0}}, False, 3),     # a limb is re-scored at weight 1 only
    ({"cues.weights": {"edges": 1.0}}, False, 3),     # no voxel cue: all dimensions at once
    ({"cues.weights": {"voxel": 1.0, "edges": 0.5}}, True, 9),
])
def test_the_search_and_the_layers_of_a_frame(overrides, hierarchical, layers):
    """``searches_hierarchically`` is whether the built filter is the partitioned one, and
    ``annealing_layers`` how many ESS and β one step of it gives (a record's row shape)."""
    config = with_overrides(TrackConfig(), **{**SMALLER, **overrides})
    assert searches_hierarchically(config) is hierarchical
    assert annealing_layers(config) == layers
    pf = _stepped(config)
    assert isinstance(pf, PartitionedParticleFilter) is hierarchical
    assert len(pf.layer_ess) == len(pf.layer_betas) == layers
