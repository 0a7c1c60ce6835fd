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


# ---------------------------------------------------------------- facing and left/right
def _standing(n=3, seed=0):
    """Landmarks (n, 15, 3) of a body facing +x (its left towards +y), jittered per frame."""
    from voxelmocap.joints import LANDMARK_NAMES

    base = {"thorax": (0, 0, 1400), "pelvis": (0, 0, 950), "head": (0, 0, 1700),
            "l_shoulder": (0, 180, 1400), "l_elbow": (0, 220, 1120), "l_wrist": (60, 230, 880),
            "r_shoulder": (0, -180, 1400), "r_elbow": (0, -220, 1120), "r_wrist": (60, -230, 880),
            "l_hip": (0, 100, 950), "l_knee": (40, 110, 500), "l_ankle": (0, 110, 80),
            "r_hip": (0, -100, 950), "r_knee": (40, -110, 500), "r_ankle": (0, -110, 80)}
    pts = np.array([base[name] for name in LANDMARK_NAMES], dtype=float)
    rng = np.random.default_rng(seed)
    return pts[None] + rng.normal(0.0, 3.0, (n, 15, 3)) * [1, 1, 0]


def _turn(pts, degrees):
    a = np.deg2rad(degrees)
    rot = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    return pts @ rot.T


def test_hip_axis_angle_of_a_turned_body_is_the_turn():
    from voxelmocap.evaluation import hip_axis_angle
    from voxelmocap.joints import LANDMARK_NAMES

    gt = _standing(4)
    for degrees in (0.0, 30.0, -90.0, 135.0, 180.0):
        # turned about any vertical, moved and raised: only the floor-plane direction counts
        est = _turn(gt, degrees) + [500.0, -300.0, 40.0]
        np.testing.assert_allclose(hip_axis_angle(est, gt), degrees, atol=1e-9)
    assert hip_axis_angle(gt, _turn(gt, 60.0)) == pytest.approx([-60.0] * 4)
    # left and right hips swapped: facing backwards
    swap = gt.copy()
    li, ri = LANDMARK_NAMES.index("l_hip"), LANDMARK_NAMES.index("r_hip")
    swap[:, [li, ri]] = gt[:, [ri, li]]
    np.testing.assert_allclose(np.abs(hip_axis_angle(swap, gt)), 180.0, atol=1e-9)
    # hips one above the other: no floor direction
    flat = gt.copy()
    flat[0, ri, :2] = flat[0, li, :2]
    assert np.isnan(hip_axis_angle(flat, gt)[0]) and not np.isnan(hip_axis_angle(flat, gt)[1:]).any()
    with pytest.raises(ValueError):
        hip_axis_angle(gt[:, :14], gt[:, :14])


def test_left_right_correct_hand_cases():
    from voxelmocap.evaluation import LIMB_PAIRS, left_right_correct
    from voxelmocap.joints import LANDMARK_NAMES

    idx = {name: i for i, name in enumerate(LANDMARK_NAMES)}
    gt = _standing(5, seed=1)
    keys = [f"{a}/{b}" for a, b in LIMB_PAIRS]
    # 60 mm off everywhere is still the right side (the limbs are ≥ 160 mm apart)
    assert left_right_correct(gt + [0.0, 0.0, 60.0], gt) == dict.fromkeys(keys, True)
    # the wrists exchanged: only that pair is wrong
    est = gt.copy()
    est[:, [idx["l_wrist"], idx["r_wrist"]]] = gt[:, [idx["r_wrist"], idx["l_wrist"]]]
    got = left_right_correct(est, gt)
    assert list(got) == keys and got == {**dict.fromkeys(keys, True), "l_wrist/r_wrist": False}
    # both knees on the true left knee: the right one is wrong, so the pair is
    est = gt.copy()
    est[:, idx["r_knee"]] = gt[:, idx["l_knee"]]
    assert left_right_correct(est, gt)["l_knee/r_knee"] is False
    # a whole body turned round (a mirrored start): every pair wrong
    assert not any(left_right_correct(_turn(gt, 180.0), gt).values())
    # averaged over frames: one swapped frame of five does not flip the verdict, three do
    est = gt.copy()
    est[:1, [idx["l_ankle"], idx["r_ankle"]]] = gt[:1, [idx["r_ankle"], idx["l_ankle"]]]
    assert left_right_correct(est, gt)["l_ankle/r_ankle"] is True
    est[:3, [idx["l_ankle"], idx["r_ankle"]]] = gt[:3, [idx["r_ankle"], idx["l_ankle"]]]
    assert left_right_correct(est, gt)["l_ankle/r_ankle"] is False
    # frames with NaN left out; nothing left is not right
    est = gt.copy()
    est[:4] = np.nan
    assert left_right_correct(est, gt) == dict.fromkeys(keys, True)
    est[4] = np.nan
    assert left_right_correct(est, gt) == dict.fromkeys(keys, False)
    # another choice of pairs
    assert left_right_correct(gt, gt, pairs=[("l_hip", "r_hip")]) == {"l_hip/r_hip": True}


def test_first_lasting_frame():
    from voxelmocap.evaluation import first_lasting_frame

    assert first_lasting_frame([False, False, True, False, True, True]) == 4
    assert first_lasting_frame([True, True, True]) == 0
    assert first_lasting_frame([True, True, False]) is None
    assert first_lasting_frame([]) is None
    assert first_lasting_frame(np.abs(np.array([170.0, 90.0, 44.0, 46.0, 30.0, 10.0])) <= 45) == 4


def test_knee_and_hip_flexion_of_hand_built_legs():
    """Hips along +x, trunk up +z (so forward is +y); thigh and shank placed by hand."""
    from voxelmocap.evaluation import hip_flexion, knee_flexion
    from voxelmocap.joints import LANDMARK_NAMES

    i = {n: k for k, n in enumerate(LANDMARK_NAMES)}
    lm = np.zeros((3, 15, 3))
    lm[:, i["pelvis"]] = (0, 0, 1000)
    lm[:, i["thorax"]] = (0, 0, 1500)
    lm[:, i["l_hip"]] = (-100, 0, 1000)
    lm[:, i["r_hip"]] = (100, 0, 1000)
    # frame 0: left leg straight down; frame 1: thigh forward, shank down (90°, 90°);
    # frame 2: thigh 30° forward, shank straight on from it
    s30, c30 = np.sin(np.radians(30)), np.cos(np.radians(30))
    lm[0, i["l_knee"]], lm[0, i["l_ankle"]] = (-100, 0, 600), (-100, 0, 200)
    lm[1, i["l_knee"]], lm[1, i["l_ankle"]] = (-100, 400, 1000), (-100, 400, 600)
    lm[2, i["l_knee"]] = (-100, 400 * s30, 1000 - 400 * c30)
    lm[2, i["l_ankle"]] = (-100, 800 * s30, 1000 - 800 * c30)
    np.testing.assert_allclose(knee_flexion(lm, "l"), [0.0, 90.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(hip_flexion(lm, "l"), [0.0, 90.0, 30.0], atol=1e-9)
