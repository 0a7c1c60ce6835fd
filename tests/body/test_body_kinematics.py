import numpy as np
import pytest

from voxelmocap.body import STATE_INDEX, BodyModel
from voxelmocap.joints import ENDPOINT_NAMES, LANDMARK_NAMES, endpoints_to_landmarks

L = {n: i for i, n in enumerate(LANDMARK_NAMES)}
DEG = np.pi / 180


def pose(**angles):
    model = BodyModel()
    x = model.default_state()
    x[:3] = (100.0, -200.0, 1000.0)
    for name, value in angles.items():
        x[STATE_INDEX[name]] = value
    return model, model.landmarks(x[None])[0]


def test_zero_pose_by_hand():
    _, lm = pose()
    p = np.array([100.0, -200.0, 1000.0])
    expect = {
        "pelvis": p, "thorax": p + (0, 0, 520), "head": p + (0, 0, 770),
        "l_shoulder": p + (-185, 0, 490), "r_shoulder": p + (185, 0, 490),
        "l_elbow": p + (-185, 0, 200), "l_wrist": p + (-185, 0, -55),
        "r_hip": p + (95, 0, -60), "r_knee": p + (95, 0, -500), "r_ankle": p + (95, 0, -930),
    }
    for name, value in expect.items():
        np.testing.assert_allclose(lm[L[name]], value, atol=1e-9, err_msg=name)


def test_single_joints_by_hand():
    p = np.array([100.0, -200.0, 1000.0])
    # right elbow flexed 90°: forearm points forward (+Y when facing +Y)
    _, lm = pose(r_elbow=90 * DEG)
    np.testing.assert_allclose(lm[L["r_wrist"]], p + (185, 255, 200), atol=1e-9)
    # left knee flexed 90°: shin points backwards
    _, lm = pose(l_knee=90 * DEG)
    np.testing.assert_allclose(lm[L["l_ankle"]], p + (-95, -430, -500), atol=1e-9)
    # shoulders abducted 90°: arms horizontal, away from the body on both sides
    _, lm = pose(l_shoulder_abd=90 * DEG, r_shoulder_abd=90 * DEG)
    np.testing.assert_allclose(lm[L["l_elbow"]], p + (-475, 0, 490), atol=1e-9)
    np.testing.assert_allclose(lm[L["r_wrist"]], p + (730, 0, 490), atol=1e-9)
    # hip flexed 90°: thigh forward
    _, lm = pose(r_hip_flex=90 * DEG)
    np.testing.assert_allclose(lm[L["r_knee"]], p + (95, 440, -60), atol=1e-9)
    # waist flexed 90°: torso, head and arms lean forward; legs unchanged
    _, lm = pose(waist_flex=90 * DEG)
    np.testing.assert_allclose(lm[L["thorax"]], p + (0, 520, 0), atol=1e-9)
    np.testing.assert_allclose(lm[L["head"]], p + (0, 770, 0), atol=1e-9)
    np.testing.assert_allclose(lm[L["l_shoulder"]], p + (-185, 490, 0), atol=1e-9)
    np.testing.assert_allclose(lm[L["l_ankle"]], p + (-95, 0, -930), atol=1e-9)
    # yaw 90°: facing −X, the subject's right is +Y
    _, lm = pose(root_yaw=90 * DEG)
    np.testing.assert_allclose(lm[L["r_shoulder"]], p + (0, 185, 490), atol=1e-9)
    # internal rotation with a bent elbow swings the forearm towards the midline
    _, lm = pose(r_elbow=90 * DEG, r_shoulder_rot=90 * DEG * 0.7)
    assert lm[L["r_wrist"], 0] < lm[L["r_elbow"], 0]
    _, lm = pose(l_elbow=90 * DEG, l_shoulder_rot=90 * DEG * 0.7)
    assert lm[L["l_wrist"], 0] > lm[L["l_elbow"], 0]
    # neck bent to the right, trunk to the right, whole body rolled to the right
    for name in ("neck_side", "waist_side", "root_roll"):
        _, lm = pose(**{name: 20 * DEG})
        assert lm[L["head"], 0] > p[0] + 1.0


def test_random_poses_keep_bone_lengths_and_orthonormal_frames():
    rng = np.random.default_rng(7)
    model = BodyModel()
    x = rng.uniform(model.low, model.high, (50, 27))
    kin = model.forward(x)
    lm = kin.joints
    d = model.dimensions
    for (a, b), length in (((L["l_shoulder"], L["l_elbow"]), d.upper_arm[0]),
                           ((L["r_elbow"], L["r_wrist"]), d.forearm[1]),
                           ((L["l_knee"], L["l_ankle"]), d.shin[0]),
                           ((L["pelvis"], L["thorax"]), d.torso),
                           ((L["thorax"], L["head"]), d.head)):
        np.testing.assert_allclose(np.linalg.norm(lm[:, b] - lm[:, a], axis=1), length)
    frames = np.stack([kin.u1, kin.u2, kin.axis], axis=-1)  # (P, 10, 3, 3)
    eye = np.einsum("pqji,pqjk->pqik", frames, frames)
    np.testing.assert_allclose(eye, np.broadcast_to(np.eye(3), eye.shape), atol=1e-12)
    # each part runs from its base joint to its far joint
    far = kin.base + np.array([p.L for p in model.parts])[None, :, None] * kin.axis
    np.testing.assert_allclose(far[:, 3], lm[:, L["l_wrist"]], atol=1e-9)
    np.testing.assert_allclose(far[:, 9], lm[:, L["r_ankle"]], atol=1e-9)
    np.testing.assert_allclose(far[:, 1], lm[:, L["head"]], atol=1e-9)


def test_endpoints_duplicate_joints_and_map_back():
    rng = np.random.default_rng(8)
    model = BodyModel()
    x = rng.uniform(model.low, model.high, (5, 27))
    ep = model.endpoints(x)
    assert ep.shape == (5, 20, 3)
    e = {n: i for i, n in enumerate(ENDPOINT_NAMES)}
    np.testing.assert_array_equal(ep[:, e["torsoProximal"]], ep[:, e["headProximal"]])
    np.testing.assert_array_equal(ep[:, e["upperRArmDistal"]], ep[:, e["lowerRArmProximal"]])
    np.testing.assert_array_equal(ep[:, e["upperLLegDistal"]], ep[:, e["lowerLLegProximal"]])
    np.testing.assert_array_equal(endpoints_to_landmarks(ep), model.landmarks(x))


def test_nan_states_rejected():
    from voxelmocap.errors import InputError

    model = BodyModel()
    x = model.default_state()
    x[4] = np.nan
    with pytest.raises(InputError, match="root_pitch"):
        model.landmarks(x[None])


def test_numba_kinematics_match_numpy_reference():
    from voxelmocap.body.kinematics import forward_kinematics, forward_kinematics_numpy

    rng = np.random.default_rng(9)
    model = BodyModel()
    x = rng.uniform(model.low, model.high, (64, 27))
    fast = forward_kinematics(x, model.dimensions)
    ref = forward_kinematics_numpy(x, model.dimensions)
    for name in ("base", "axis", "u1", "u2", "joints"):
        np.testing.assert_allclose(getattr(fast, name), getattr(ref, name), atol=1e-9,
                                   err_msg=name)


def test_one_angles_rotation_is_the_batched_one_and_the_closed_form():
    """The single-angle path (the fits' inner loops) builds the same bytes as the batched stack,
    and both are the right-hand rotations about x, y, z."""
    from voxelmocap.body.kinematics import rotation_x, rotation_y, rotation_z

    rng = np.random.default_rng(3)
    angles = np.concatenate([rng.uniform(-7.0, 7.0, 200), [0.0, -0.0, np.pi, -np.pi / 2]])
    batched = {f: f(angles) for f in (rotation_x, rotation_y, rotation_z)}
    for k, a in enumerate(angles):
        for f in (rotation_x, rotation_y, rotation_z):
            for one in (float(a), np.float64(a), np.array(a)):
                assert f(one).shape == (3, 3)
                assert f(one).tobytes() == batched[f][k].tobytes()
    a = 0.3
    c, s = np.cos(a), np.sin(a)
    # rotating the axes' basis vectors: x stays, y goes towards z, and so on (right hand)
    np.testing.assert_allclose(rotation_x(a) @ [0, 1, 0], [0, c, s])
    np.testing.assert_allclose(rotation_y(a) @ [0, 0, 1], [s, 0, c])
    np.testing.assert_allclose(rotation_z(a) @ [1, 0, 0], [c, s, 0])
