"""``pose.starts``: a frame's true landmarks, the start from the voxels, several starts at once.

Ground truth is a :class:`~voxelmocap.io.body_pose_xml.BodyPoseSequence` built from a body's
own endpoints; the start from the voxels is checked against the body rasterised at a known place
and heading; the multi-start against lone trackers fed the same random streams.
"""

import numpy as np
import pytest

from voxelmocap.body import BodyModel
from voxelmocap.config import TrackConfig, with_overrides
from voxelmocap.errors import InputError
from voxelmocap.grid import VoxelGrid
from voxelmocap.io.body_pose_xml import BodyPoseSequence
from voxelmocap.joints import endpoints_to_landmarks
from voxelmocap.pose.multistart import MultiStart
from voxelmocap.pose.starts import ground_truth_landmarks, initial_state_from_voxels
from voxelmocap.pose.tracker import BodyTracker
from voxelmocap.score.likelihood import Measurement, rasterise

MODEL = BodyModel()
GRID = VoxelGrid((-1200.0, -1200.0, 0.0), 40.0, (60, 60, 50))
YAW = list(MODEL.state_names).index("root_yaw")
RING = np.linspace(-np.pi, np.pi, 36, endpoint=False)


def test_a_frames_true_landmarks_when_the_truth_has_them_all():
    rng = np.random.default_rng(2)
    states = MODEL.clip(MODEL.default_state() + rng.normal(size=(3, 27)) * np.r_[
        np.full(3, 100.0), np.full(24, 0.3)])
    enabled = np.ones((3, 20), bool)
    enabled[1, 7] = False                       # one endpoint of frame 6 missing
    gt = BodyPoseSequence(frames=np.array([4, 6, 9]), endpoints=MODEL.endpoints(states),
                          enabled=enabled)
    np.testing.assert_allclose(ground_truth_landmarks(gt, 4), MODEL.landmarks(states[:1])[0],
                               atol=1e-9)
    np.testing.assert_array_equal(ground_truth_landmarks(gt, 9),
                                  endpoints_to_landmarks(gt.endpoints[2]))
    assert ground_truth_landmarks(gt, 6) is None         # a disabled endpoint
    assert ground_truth_landmarks(gt, 5) is None         # a frame the truth does not have
    assert ground_truth_landmarks(None, 4) is None


@pytest.mark.parametrize("k", [0, 9, 23])
def test_the_start_from_the_voxels_stands_at_their_centre_facing_the_body_or_away(k):
    """A body standing at a known place, turned to heading ``k`` of the ring: the start is the
    standing pose at the voxels' centroid, turned to that heading or its opposite (a standing
    body looks nearly the same turned round: why several starts are tracked)."""
    truth = MODEL.default_state()
    truth[0], truth[1], truth[YAW] = 130.0, -260.0, RING[k]
    occupancy = rasterise(MODEL, truth[None], GRID) > 0
    state = initial_state_from_voxels(Measurement(occupancy, GRID), MODEL, (1.0, 1.0, 1.0, 1.0))
    centre = GRID.centre_of(np.argwhere(occupancy)).mean(axis=0)
    np.testing.assert_allclose(state[:2], centre[:2], rtol=0, atol=1e-9)
    others = [i for i in range(27) if i not in (0, 1, YAW)]
    np.testing.assert_array_equal(state[others], MODEL.default_state()[others])
    chosen = int(np.flatnonzero(RING == state[YAW])[0])
    assert chosen in (k, (k + 18) % 36), chosen
    with pytest.raises(InputError, match="no occupied voxel"):
        initial_state_from_voxels(Measurement(np.zeros(GRID.shape, bool), GRID), MODEL,
                                  (1.0, 1.0, 1.0, 1.0))


#: a small joint search: three frames of two starts stay quick
SMALL = with_overrides(TrackConfig(), **{"filter.search": "joint", "filter.layers": 2,
                                         "filter.particles": 60, "init.settle_steps": 0})


def test_multistart_keeps_the_likeliest_start():
    """Each start is an independent tracker; the kept one is the likeliest over the frames and
    its records equal a lone tracker started from the same pose with the same random stream."""
    truth = MODEL.default_state()
    obs = Measurement(rasterise(MODEL, truth[None], GRID) > 0, GRID)
    wrong = truth.copy()
    wrong[0] += 300.0  # 30 cm off: clearly less likely
    multi = MultiStart(MODEL, SMALL, 5, np.array([wrong, truth]), 3)
    with pytest.raises(RuntimeError, match="no start chosen yet"):
        _ = multi.tracker
    assert multi.step(obs, frame=1) is None and multi.step(obs, frame=2) is None
    records = multi.step(obs, frame=3)
    assert multi.chosen == 1 and len(records) == 3 and multi.tracker is multi.trackers[1]
    assert multi.totals == [sum(r.log_likelihood for r in rs) for rs in multi.records]
    assert multi.totals[1] > multi.totals[0]
    assert [len(c) for c in multi.checkpoints] == [3, 3]
    lone = BodyTracker(MODEL, SMALL, seed=np.random.default_rng([5, 1]))
    lone.start("truth", truth)
    for k in range(3):
        np.testing.assert_array_equal(lone.step(obs, frame=k + 1).state, records[k].state)
    # each start's checkpoint after each frame resumes exactly where that start was
    again = BodyTracker(MODEL, SMALL, seed=0)
    again.set_state(multi.checkpoints[1][1])
    np.testing.assert_array_equal(again.step(obs, frame=3).state, records[2].state)
