"""``pose.hierarchy``: the partitions of the hierarchical search, their sizes, the root-pitch
prior and each partition's likelihood.

That a partition moves only the parts it names is checked by forward kinematics (moving its
dimensions and seeing which cones change); its likelihood against the full likelihood of the
whole states.
"""

import numpy as np
import pytest

from voxelmocap.body import BodyModel
from voxelmocap.config import FilterConfig
from voxelmocap.grid import VoxelGrid
from voxelmocap.pose.hierarchy import (
    BODY_PARTITIONS,
    LIMBS,
    body_partitions,
    log_likelihood_for,
    pitch_prior,
)
from voxelmocap.score.likelihood import Measurement, log_likelihood, rasterise

MODEL = BodyModel()
GRID = VoxelGrid((-1200.0, -1200.0, 0.0), 40.0, (60, 60, 50))


def test_the_partitions_split_the_state_and_name_the_parts_they_move():
    dims = [d for part_dims, _ in BODY_PARTITIONS for d in part_dims]
    assert sorted(dims) == list(range(27))                         # every dimension once
    assert [len(d) for d, _ in BODY_PARTITIONS] == [11, 8, 4, 4]
    assert BODY_PARTITIONS[1] == (LIMBS["l_leg"][0] + LIMBS["r_leg"][0],
                                  LIMBS["l_leg"][1] + LIMBS["r_leg"][1])
    rng = np.random.default_rng(3)
    base = MODEL.default_state()
    for part_dims, parts in BODY_PARTITIONS[1:]:
        # move only this partition's dimensions: exactly its parts' cones change
        moved = base.copy()
        moved[list(part_dims)] += rng.uniform(0.2, 0.4, len(part_dims))
        moved = MODEL.clip(moved[None])[0]
        assert _moved_parts(base, moved) == set(parts), parts
    # the first partition (parts "all"): the root moves every cone
    moved = base.copy()
    moved[0] += 50.0
    assert _moved_parts(base, moved) == set(range(MODEL.n_parts))


def _moved_parts(a, b):
    """The parts whose cone (base, axis, cross-section axes) differs between states a and b."""
    k = MODEL.forward(np.stack([a, b]))
    cones = np.concatenate([k.base, k.axis, k.u1, k.u2], axis=2)          # (2, parts, 12)
    return {p for p in range(MODEL.n_parts) if not np.allclose(cones[0, p], cones[1, p])}


def test_sizes_default_to_the_joint_searchs_budget():
    fc = FilterConfig(layers=7, particles=500)
    sizes = [(len(p.dims), p.layers, p.particles) for p in body_partitions(fc)]
    # trunk: layers // 2 of all the particles; each limb: layers // 3 of 3/8 of them, the legs
    # (two limbs) twice as many
    assert sizes == [(11, 3, 500), (8, 2, 2 * 188), (4, 2, 188), (4, 2, 188)]
    tiny = FilterConfig(layers=1, particles=3)
    assert [(p.layers, p.particles) for p in body_partitions(tiny)] == \
        [(1, 3), (1, 2 * 2), (1, 2), (1, 2)]                     # at least 1 layer, 2 particles
    chosen = FilterConfig(layers=7, particles=500, trunk_layers=5, trunk_particles=90,
                          limb_layers=4, limb_particles=30)
    assert [(p.layers, p.particles) for p in body_partitions(chosen)] == \
        [(5, 90), (4, 60), (4, 30), (4, 30)]


def test_the_pitch_prior_is_a_zero_mean_gaussian_in_degrees():
    states = np.zeros((3, 27))
    states[:, 4] = np.deg2rad([0.0, 10.0, -20.0])                  # root_pitch
    np.testing.assert_allclose(pitch_prior(states, 10.0), [0.0, -0.5, -2.0], rtol=1e-12)
    assert pitch_prior(states, None) == 0.0


@pytest.mark.parametrize("k", [0, 1, 2, 3])
def test_each_partitions_likelihood_is_the_full_one_of_the_whole_states(k):
    """Partition k's callable, on particles equal to the reference outside its dimensions, is
    the full log-likelihood plus the pitch prior (the limbs' at the cost of their own cones)."""
    rng = np.random.default_rng(10 + k)
    truth = MODEL.default_state()
    observation = Measurement(rasterise(MODEL, truth[None], GRID) > 0, GRID)
    reference = MODEL.clip((truth + rng.normal(size=27) * np.r_[np.full(3, 40.0),
                                                                np.full(24, 0.15)])[None])[0]
    dims = list(BODY_PARTITIONS[k][0])
    states = np.repeat(reference[None], 6, axis=0)
    states[:, dims] += rng.normal(size=(6, len(dims))) * np.where(np.isin(dims, [0, 1, 2]),
                                                                  60.0, 0.3)
    states = MODEL.clip(states)
    variances = (0.4, 0.8, 1.5, 2.5)
    ll = log_likelihood_for(observation, MODEL, variances, 12.0, k, reference, coverage=0.3)
    full = log_likelihood(observation, MODEL, states, variances=variances, coverage=0.3)
    np.testing.assert_allclose(ll(states), full + pitch_prior(states, 12.0), rtol=1e-12,
                               atol=1e-12)
