import numpy as np
import pytest

from voxelmocap.body import BodyDimensions, BodyModel, analytic_state, fit_to_landmarks
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
