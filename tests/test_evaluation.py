import numpy as np
import pytest

from voxelmocap.evaluation import humaneva_error, humaneva_error_position_average
from voxelmocap.joints import ENDPOINT_NAMES, endpoints_to_landmarks

E = {n: i for i, n in enumerate(ENDPOINT_NAMES)}


def base_pose():
    rng = np.random.default_rng(7)
    return rng.normal(0, 500, size=(20, 3))


def test_single_joint_offsets():
    gt = base_pose()
    est = gt.copy()
    est[E["lowerLArmDistal"]] += [30.0, 40.0, 0.0]  # L wrist off by 50 mm
    # merged joints whose two errors are exactly 0 are dropped (thorax, both elbows, both
    # knees), leaving the 10 single joints, one of which (the wrist) is 50 mm off
    frame, joints = humaneva_error(est, gt, per_joint=True)
    assert joints[4] == pytest.approx(50.0)
    assert np.isnan(joints[0]) and np.isnan(joints[3])
    assert frame == pytest.approx(50.0 / 10)


def test_merged_joint_averages_errors_not_positions():
    gt = base_pose()
    est = gt.copy()
    # elbow endpoints moved in opposite directions: positions average to the truth,
    # errors average to 20 mm
    est[E["upperLArmDistal"]] += [20.0, 0, 0]
    est[E["lowerLArmProximal"]] -= [20.0, 0, 0]
    frame, joints = humaneva_error(est, gt, per_joint=True)
    assert joints[3] == pytest.approx(20.0)
    assert humaneva_error_position_average(est, gt) == pytest.approx(0.0, abs=1e-9)
    # 10 single joints (error 0) + the L elbow; the other 4 merged joints (error 0) are dropped
    assert frame == pytest.approx(20.0 / 11)


def test_all_joints_shifted_uniformly():
    gt = base_pose()
    est = gt + [0.0, 0.0, 100.0]
    assert humaneva_error(est, gt) == pytest.approx(100.0)
    assert humaneva_error_position_average(est, gt) == pytest.approx(100.0)


def test_disabled_endpoints():
    gt = base_pose()
    est = gt + [0.0, 60.0, 80.0]  # every endpoint 100 mm off
    est[E["upperRArmDistal"]] = gt[E["upperRArmDistal"]] + [0, 0, 300.0]
    enabled = np.ones(20, bool)
    enabled[E["upperRArmDistal"]] = False  # R elbow falls back on lowerRArmProximal alone
    enabled[E["headDistal"]] = False  # head joint absent
    frame, joints = humaneva_error(est, gt, gt_enabled=enabled, per_joint=True)
    assert joints[6] == pytest.approx(100.0)
    assert np.isnan(joints[14])
    assert frame == pytest.approx(100.0)
    # without the flags the R elbow is (300 + 100) / 2
    _, joints_all = humaneva_error(est, gt, per_joint=True)
    assert joints_all[6] == pytest.approx(200.0)


def test_batched_frames():
    gt = np.stack([base_pose(), base_pose()])
    est = gt + np.array([[[0, 0, 10.0]], [[0, 0, 30.0]]])
    np.testing.assert_allclose(humaneva_error(est, gt), [10.0, 30.0])


def test_endpoints_to_landmarks_merges_means():
    pts = base_pose()
    lm = endpoints_to_landmarks(pts)
    np.testing.assert_allclose(lm[0], (pts[E["torsoProximal"]] + pts[E["headProximal"]]) / 2)
    np.testing.assert_allclose(lm[14], pts[E["headDistal"]])
    enabled = np.ones(20, bool)
    enabled[E["headProximal"]] = False
    np.testing.assert_allclose(endpoints_to_landmarks(pts, enabled)[0], pts[E["torsoProximal"]])
