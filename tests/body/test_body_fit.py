import numpy as np
import pytest

from voxelmocap.body import BodyDimensions, BodyModel, analytic_state, fit_to_landmarks, retarget
from voxelmocap.body.kinematics import (
    L_ELBOW,
    L_SHOULDER,
    L_WRIST,
    R_ANKLE,
    R_HIP,
    R_KNEE,
)
from voxelmocap.errors import InputError


def random_legal(model, rng, n):
    x = rng.uniform(model.low, model.high, (n, 27))
    x[:, 3] = rng.uniform(-np.pi, np.pi, n)
    return x


def test_fit_recovers_random_legal_poses():
    rng = np.random.default_rng(11)
    model = BodyModel(BodyDimensions.average(1650.0).replace(upper_arm=(280.0, 300.0)))
    for x in random_legal(model, rng, 25):
        target = model.landmarks(x[None])[0]
        fit = fit_to_landmarks(model, target)
        assert np.all(fit >= model.low) and np.all(fit <= model.high)
        err = np.linalg.norm(model.landmarks(fit[None])[0] - target, axis=1)
        assert err.max() < 5.0


def test_fit_with_noise_and_initial():
    rng = np.random.default_rng(12)
    model = BodyModel()
    x = random_legal(model, rng, 1)[0]
    target = model.landmarks(x[None])[0]
    noisy = target + rng.normal(0, 5.0, target.shape)
    fit = fit_to_landmarks(model, noisy, initial=x)
    err = np.linalg.norm(model.landmarks(fit[None])[0] - target, axis=1)
    assert np.sqrt(np.mean(err ** 2)) < 8.0   # least squares does not amplify 5 mm noise much


def test_analytic_state_exact_for_own_landmarks():
    rng = np.random.default_rng(13)
    model = BodyModel()
    for x in random_legal(model, rng, 20):
        target = model.landmarks(x[None])[0]
        a = analytic_state(model, target)
        np.testing.assert_allclose(model.landmarks(a[None])[0], target, atol=1e-6)


def test_fit_other_skeleton_is_legal_and_close():
    # landmarks of a different body: the fit is the best compromise, still legal
    rng = np.random.default_rng(14)
    truth = BodyModel(BodyDimensions.average(1850.0))
    model = BodyModel()
    x = random_legal(truth, rng, 1)[0]
    target = truth.landmarks(x[None])[0]
    fit = fit_to_landmarks(model, target)
    assert np.all(fit >= model.low) and np.all(fit <= model.high)
    err = np.linalg.norm(model.landmarks(fit[None])[0] - target, axis=1)
    assert err.mean() < 60.0


def test_bad_landmarks():
    model = BodyModel()
    with pytest.raises(InputError, match="15, 3"):
        fit_to_landmarks(model, np.zeros((14, 3)))
    lm = model.landmarks(model.default_state()[None])[0]
    lm[3, 1] = np.nan
    with pytest.raises(InputError, match="finite"):
        fit_to_landmarks(model, lm)


def test_retarget_identity_and_aim():
    """On the same skeleton nothing moves; on another, each upper segment points from the new
    shoulder (hip) at the old elbow (knee) and each lower segment keeps its old direction, checked
    by vector geometry on the forward kinematics of both skeletons, for legal random poses."""
    rng = np.random.default_rng(13)
    a = BodyModel(BodyDimensions.average(1750.0))
    b = BodyModel(BodyDimensions.average(1750.0).replace(
        shoulder_offset=(120.0, 130.0), torso=560.0, hip_drop=(5.0, 10.0), hip_offset=(80.0, 85.0),
        thigh=(400.0, 410.0)))
    x = random_legal(a, rng, 40)
    # keep the elbows and knees away from straight, where the limb's twist is free
    x[:, [17, 18]] = rng.uniform(0.4, 2.0, (40, 2))
    x[:, [25, 26]] = rng.uniform(0.4, 2.0, (40, 2))
    assert np.allclose(a.landmarks(retarget(a, a, x)), a.landmarks(x), atol=1e-6)
    y = retarget(a, b, x)
    assert np.all(y >= b.low) and np.all(y <= b.high)
    old, new = a.landmarks(x), b.landmarks(y)
    assert np.array_equal(y[:, :11], x[:, :11])          # root, trunk and head angles kept

    def unit(v):
        return v / np.linalg.norm(v, axis=-1, keepdims=True)

    # only states whose re-aimed limb stayed inside the joint ranges can aim exactly
    def check(top, mid, end, cols):
        inside = np.all((y[:, cols] > b.low[cols] + 1e-9) & (y[:, cols] < b.high[cols] - 1e-9),
                        axis=1)
        assert inside.sum() >= 10
        aim = np.einsum("pi,pi->p", unit(new[:, mid] - new[:, top]),
                        unit(old[:, mid] - new[:, top]))
        keep = np.einsum("pi,pi->p", unit(new[:, end] - new[:, mid]),
                         unit(old[:, end] - old[:, mid]))
        assert np.all(aim[inside] > 1 - 1e-9) and np.all(keep[inside] > 1 - 1e-9)

    check(L_SHOULDER, L_ELBOW, L_WRIST, [11, 12, 13, 17])
    check(R_HIP, R_KNEE, R_ANKLE, [22, 23, 24, 26])
    # with the angles held instead, the elbows would have moved by the shoulder's shift
    held = b.landmarks(x)
    assert np.median(np.linalg.norm(held[:, L_ELBOW] - old[:, L_ELBOW], axis=1)) > 40.0
