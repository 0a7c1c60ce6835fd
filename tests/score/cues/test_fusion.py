"""``score.cues.fusion``: the weighted sum of the cues, to the bit, whichever way it is reached.

The tracker's record takes the voxel cue's value from part scores it has already counted and asks
:meth:`CueSet.combine` for the sum; that must equal :meth:`CueSet.log_likelihood` exactly (the
multi-start compares such sums). The cues here read voxels only (voxel, blob3d): no images.
The image cues' values and the fusion's weights are in ``test_cues.py``.
"""

import numpy as np
import pytest

from voxelmocap.body import BodyModel
from voxelmocap.config import CuesConfig
from voxelmocap.errors import InputError
from voxelmocap.grid import VoxelGrid
from voxelmocap.measure.observation import VoxelObservation
from voxelmocap.score.cues import CueSet
from voxelmocap.score.likelihood import log_likelihood_from_scores, part_scores_of, rasterise

MODEL = BodyModel()
GRID = VoxelGrid((-1000.0, -1000.0, 0.0), 40.0, (50, 50, 50))
VARIANCES = (0.3, 0.7, 1.9, 2.3)


def _frame_and_states(seed=0, n=7):
    rng = np.random.default_rng(seed)
    x = MODEL.default_state()
    observation = VoxelObservation(rasterise(MODEL, x[None], GRID) > 0, GRID)
    states = MODEL.clip(x + rng.normal(size=(n, 27)) * np.r_[np.full(3, 60.0),
                                                               np.full(24, 0.2)])
    return observation, states


@pytest.mark.parametrize("weights", [{"voxel": 1.0}, {"voxel": 0.7, "blob3d": 1.5},
                                     {"blob3d": 2.0, "voxel": 3.0}])
def test_the_voxel_value_from_counted_part_scores_gives_the_same_sum_to_the_bit(weights):
    observation, states = _frame_and_states()
    cues = CueSet(MODEL, CuesConfig(weights=weights), voxel={"variances": VARIANCES})
    values = cues.evaluate(observation, states, [n for n in cues.names if n != "voxel"])
    scores = part_scores_of(observation, MODEL.geometry(states))
    values["voxel"] = log_likelihood_from_scores(scores, variances=VARIANCES)
    np.testing.assert_array_equal(cues.combine(values, len(states)),
                                  cues.log_likelihood(observation, states))
    # the sum, written out in the selection's order
    by_hand = np.zeros(len(states))
    for name, w in weights.items():
        by_hand += w * values[name]
    np.testing.assert_array_equal(cues.combine(values, len(states)), by_hand)


def test_the_sum_is_taken_in_the_selections_order_whatever_order_the_values_come_in():
    """In floating point the order of a sum matters: 1 + 1e16 − 1e16 is 0, −1e16 + 1e16 + 1 is
    1. The values may come in any order (the voxel cue's is added last by the tracker)."""
    cues = CueSet(MODEL, CuesConfig(weights={"voxel": 1.0, "blob3d": 1.0, "silhouette": 1.0}))
    assert cues.names == ("voxel", "blob3d", "silhouette")
    values = {"silhouette": np.array([-1e16]), "blob3d": np.array([1e16]),
              "voxel": np.array([1.0])}
    assert (1.0 + 1e16) - 1e16 == 0.0 and (-1e16 + 1e16) + 1.0 == 1.0
    np.testing.assert_array_equal(cues.combine(values, 1), [0.0])


def test_cues_left_out_are_not_summed():
    observation, states = _frame_and_states(seed=3, n=4)
    cues = CueSet(MODEL, CuesConfig(weights={"voxel": 0.5, "blob3d": 2.0}))
    parts = cues.evaluate(observation, states)
    np.testing.assert_array_equal(cues.log_likelihood(observation, states, without=("voxel",)),
                                  2.0 * parts["blob3d"])
    np.testing.assert_array_equal(cues.combine({"voxel": parts["voxel"]}, 4), 0.5 * parts["voxel"])
    np.testing.assert_array_equal(cues.combine({}, 4), np.zeros(4))
    # the filter's callable without a cue is the same sum
    np.testing.assert_array_equal(cues.frame(observation, without=("blob3d",))(states),
                                  0.5 * parts["voxel"])


def test_the_voxel_cues_need_two_cameras_by_name():
    CueSet.check_weights_for_cameras({"edges": 1.0}, ["C1"])
    CueSet.check_weights_for_cameras({"voxel": 1.0, "blob3d": 1.0}, ["C1", " C2 "])
    with pytest.raises(InputError) as info:
        CueSet.check_weights_for_cameras({"voxel": 1.0, "blob3d": 1.0, "edges": 1.0},
                                         ["C1", " "])
    assert str(info.value) == ("cues: the voxel and blob3d cues need voxels carved from at least "
                               "two cameras, this run has 1 (C1); use image cues only, e.g. "
                               "--cues edges,roi")
