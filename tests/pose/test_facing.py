"""The turned-round hypothesis and the evidence of which way a body faces (issue 33)."""

import numpy as np
import pytest

from voxelmocap.body import BodyModel
from voxelmocap.grid import VoxelGrid
from voxelmocap.joints import LANDMARK_NAMES
from voxelmocap.measure.observation import VoxelObservation
from voxelmocap.pose.facing import (
    FOOT_BOX_MM,
    facing_direction,
    foot_evidence,
    travel_evidence,
    turned_round,
)

MODEL = BodyModel()
#: left ↔ right landmark permutation
SWAP = [LANDMARK_NAMES.index(n.replace("l_", "R_").replace("r_", "l_").replace("R_", "r_"))
        for n in LANDMARK_NAMES]
#: ranges whose half-turned image is legal too (flexions and side bends within the smaller of
#: their two limits, knees and elbows straight)
SYMMETRIC = {"root_pitch": 0.3, "root_roll": 0.3, "waist_flex": 0.4, "waist_side": 0.5,
             "waist_twist": 0.7, "neck_flex": 0.7, "neck_side": 0.7, "l_shoulder_flex": 1.0,
             "r_shoulder_flex": 1.0, "l_shoulder_rot": 1.2, "r_shoulder_rot": 1.2,
             "l_hip_flex": 0.5, "r_hip_flex": 0.5, "l_hip_rot": 0.7, "r_hip_rot": 0.7}


def random_pose(rng, **fixed):
    x = MODEL.default_state()
    names = list(MODEL.state_names)
    x[names.index("root_yaw")] = rng.uniform(-np.pi, np.pi)
    x[:2] = rng.uniform(-500, 500, 2)
    for name, half in SYMMETRIC.items():
        x[names.index(name)] = rng.uniform(-half, half)
    for name in ("l_shoulder_abd", "r_shoulder_abd"):
        x[names.index(name)] = rng.uniform(0.0, 1.5)
    for name in ("l_hip_abd", "r_hip_abd"):
        x[names.index(name)] = rng.uniform(-0.4, 0.5)
    for name, value in fixed.items():
        x[names.index(name)] = value
    return x


@pytest.mark.parametrize("seed", range(5))
def test_the_turned_pose_is_the_same_body_facing_the_other_way(seed):
    """Forward kinematics: every landmark of the turned pose lies where the other side's landmark
    of the pose lay (thorax, pelvis, head top where they were), and the facing is reversed."""
    x = random_pose(np.random.default_rng(seed))
    y = turned_round(MODEL, x)
    before, after = MODEL.landmarks(x[None])[0], MODEL.landmarks(y[None])[0]
    np.testing.assert_allclose(after, before[SWAP], atol=1e-9)
    np.testing.assert_allclose(facing_direction(y), -facing_direction(x), atol=1e-12)
    # turning round twice is the pose again (the heading up to a full turn)
    z = turned_round(MODEL, y)
    np.testing.assert_allclose(MODEL.landmarks(z[None])[0], before, atol=1e-9)


def test_a_bent_knee_cannot_turn_round_exactly():
    """The knee bends one way only: turned round, the leg is refitted within its limits, legal,
    and lands nearer the other side's knee and ankle than the clipped angles alone do."""
    x = random_pose(np.random.default_rng(7), l_knee=1.0, l_hip_flex=0.2)
    refit, clipped = turned_round(MODEL, x), turned_round(MODEL, x, refit=False)
    assert np.all(refit >= MODEL.low) and np.all(refit <= MODEL.high)
    before = MODEL.landmarks(x[None])[0]
    rows = [LANDMARK_NAMES.index(n) for n in ("r_knee", "r_ankle")]
    targets = before[[LANDMARK_NAMES.index(n) for n in ("l_knee", "l_ankle")]]

    def miss(state):
        return np.linalg.norm(MODEL.landmarks(state[None])[0, rows] - targets, axis=1).sum()

    assert miss(refit) < miss(clipped)
    assert miss(refit) > 1.0         # a knee bent backwards for one facing is forwards for the other
    # the other limbs were legal: exactly where the other side's were
    for name in ("l_knee", "l_ankle", "l_wrist", "r_wrist"):
        i = LANDMARK_NAMES.index(name)
        np.testing.assert_allclose(MODEL.landmarks(refit[None])[0, i], before[SWAP[i]],
                                   atol=1e-9)


def _floor_observation(points_mm):
    """An observation whose only occupied voxels contain ``points_mm`` (20 mm voxels)."""
    grid = VoxelGrid((-1000.0, -1000.0, 0.0), 20.0, (100, 100, 100))
    occ = np.zeros(grid.shape, bool)
    for p in np.atleast_2d(points_mm):
        occ[tuple(((np.asarray(p) - grid.origin) // grid.voxel_size).astype(int))] = True
    return VoxelObservation(occ, grid)


def test_feet_in_front_of_the_ankles_say_which_way_the_body_faces():
    """Hand-made floor voxels: a shoe in front of each ankle → +1 for the pose, −1 for its
    turned-round twin; voxels only above the boxes' height or none → 0."""
    x = MODEL.default_state()                 # facing +y
    ankles = MODEL.landmarks(x[None])[0, [LANDMARK_NAMES.index("l_ankle"),
                                           LANDMARK_NAMES.index("r_ankle")]]
    shoes = [a[:2].tolist() + [30.0] for a in ankles + np.array([0.0, 150.0, 0.0])]
    seen = _floor_observation(shoes)
    twin = turned_round(MODEL, x)
    np.testing.assert_allclose(foot_evidence(seen, MODEL, np.stack([x, twin])), [1.0, -1.0])
    # a heel behind one ankle and a toe in front of the other: (1 − 1) / 2
    heel = [ankles[0, 0], ankles[0, 1] - 150.0, 30.0]
    mixed = _floor_observation([shoes[1], heel])
    np.testing.assert_allclose(foot_evidence(mixed, MODEL, x[None]), [0.0])
    high = _floor_observation([[ankles[0, 0], ankles[0, 1] + 150.0,
                                FOOT_BOX_MM["height"] + 40.0]])
    np.testing.assert_allclose(foot_evidence(high, MODEL, x[None]), [0.0])


def test_travel_evidence_is_the_cosine_of_facing_and_travel():
    states = np.repeat(MODEL.default_state()[None], 3, axis=0)
    yaw = list(MODEL.state_names).index("root_yaw")
    states[:, yaw] = [0.0, np.pi / 3, np.pi]     # facing +y, 60° to the left, −y
    path = np.array([[0.0, 0.0], [0.0, 300.0], [0.0, 600.0]])     # 600 mm in 2 frames at 60 Hz
    np.testing.assert_allclose(travel_evidence(path, states, frame_rate=60.0),
                               [1.0, 0.5, -1.0], atol=1e-12)
    # standing nearly still: 10 mm in a second is no evidence
    still = np.array([[0.0, 0.0], [0.0, 10.0]])
    np.testing.assert_allclose(travel_evidence(still, states, frame_rate=1.0), 0.0)


def _cos(a, b):
    """Cosine of the angle between two states' facing directions."""
    return float(facing_direction(a)[0] @ facing_direction(b)[0])


def _tracked_one_frame(every, turned, seed=3):
    """One tracked frame of a body with bent knees and elbows (voxels rasterised from it, 40 mm),
    the track started from the truth or from its turned-round twin: (record, truth)."""
    from voxelmocap.config import TrackConfig, with_overrides
    from voxelmocap.pose.tracker import BodyTracker
    from voxelmocap.score.likelihood import Measurement, rasterise

    truth = random_pose(np.random.default_rng(seed), l_knee=1.0, r_knee=0.5, l_elbow=1.2,
                        r_elbow=0.8, l_hip_flex=0.3)
    grid = VoxelGrid((truth[0] - 1200.0, truth[1] - 1200.0, 0.0), 40.0, (60, 60, 50))
    obs = Measurement(rasterise(MODEL, truth[None], grid) > 0, grid)
    config = with_overrides(TrackConfig(), **{
        "filter.search": "joint", "filter.layers": 2, "filter.particles": 60,
        "init.settle_steps": 0, "filter.limb_sweep_every": 0,
        "filter.facing_check_every": every})
    tracker = BodyTracker(MODEL, config, seed=np.random.default_rng(seed))
    tracker.start("a start", turned_round(MODEL, truth) if turned else truth)
    return tracker.step(obs, frame=1), truth


def test_the_facing_check_turns_a_track_started_the_wrong_way_round():
    """Started facing backwards with limbs swapped, one checked frame faces the right way and
    says so; the same frame unchecked stays turned round (the check, not the filter, did it)."""
    record, truth = _tracked_one_frame(every=1, turned=True)
    assert record.note.startswith("turned round")
    assert _cos(record.state, truth) > np.cos(np.radians(45.0))
    unchecked, _ = _tracked_one_frame(every=0, turned=True)
    assert unchecked.note == ""
    assert _cos(unchecked.state, truth) < 0.0


def test_the_facing_check_leaves_a_track_facing_the_right_way():
    """Started on the truth itself, the turned-round twin does not win: no switch, no note."""
    record, truth = _tracked_one_frame(every=1, turned=False)
    assert record.note == ""
    assert _cos(record.state, truth) > np.cos(np.radians(20.0))
