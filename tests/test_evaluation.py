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


# ---------------------------------------------------------------------- MMTA / MMTP, worked by hand
def test_mmta_mmtp_hand_worked_with_delta_boundary():
    from voxelmocap.evaluation import mmta_mmtp

    errors = np.array([
        [50.0, 100.0, 150.0, 20.0],  # matched: 50, 20 (100 is not < 100) → 50 %, MMTP 35
        [99.9, 300.0, 400.0, 500.0],  # matched: 99.9 → 25 %, MMTP 99.9
        [200.0, 200.0, 200.0, 200.0],  # none → 0 %, MMTP undefined (excluded)
    ])
    mmta, mmtp, (per_a, per_p) = mmta_mmtp(errors, delta=100.0)
    np.testing.assert_allclose(per_a, [50.0, 25.0, 0.0])
    np.testing.assert_allclose(per_p[:2], [35.0, 99.9])
    assert np.isnan(per_p[2])
    assert mmta == pytest.approx(25.0)
    assert mmtp == pytest.approx((35.0 + 99.9) / 2)
    # a larger δ includes the boundary value 100 in frame 0
    _, _, (per_a2, _) = mmta_mmtp(errors, delta=100.0001)
    assert per_a2[0] == pytest.approx(75.0)


def test_evaluate_sequence_skips_disabled_frames_and_computes_mu_sigma():
    from voxelmocap.evaluation import evaluate_sequence

    gt = np.stack([base_pose()] * 3)
    shifts = np.array([30.0, 70.0, 500.0])
    est = gt + shifts[:, None, None] * np.array([0.0, 0.0, 1.0])
    enabled = np.ones((3, 20), bool)
    enabled[2, 7] = False  # third frame skipped
    scores, per = evaluate_sequence(est, gt, enabled, delta=50.0)
    assert scores.frames == 2 and scores.skipped == 1
    assert scores.mu_mm == pytest.approx(50.0)  # mean of 30 and 70
    assert scores.sigma_mm == pytest.approx(20.0)  # population std of {30, 70}
    assert scores.mmta_pct == pytest.approx(50.0)  # frame 1: all matched, frame 2: none
    assert scores.mmtp_mm == pytest.approx(30.0)
    assert scores.humaneva_error_mm == pytest.approx(50.0)
    np.testing.assert_array_equal(per["valid"], [True, True, False])
    assert np.isnan(per["mean_error"][2])


def test_disabled_estimate_endpoints_are_left_out():
    from voxelmocap.evaluation import evaluate_sequence

    gt = np.stack([base_pose()] * 2)
    est = gt + np.array([0.0, 0.0, 40.0])
    est[:, E["headDistal"]] = 0.0  # a placeholder the other tracker did not estimate
    enabled = np.ones((2, 20), bool)
    enabled[:, E["headDistal"]] = False
    scores, _ = evaluate_sequence(est, gt, delta=100.0, est_enabled=enabled)
    assert scores.humaneva_error_mm == pytest.approx(40.0)  # head dropped, as error() does
    assert scores.mu_mm == pytest.approx(40.0)  # head left out of μ
    assert scores.mmta_pct == pytest.approx(100.0 * 14 / 15)  # head counts as a miss
