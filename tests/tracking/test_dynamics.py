"""Dynamics models on hand-worked numbers (paper 000 eqs 14-16)."""

import numpy as np
import pytest

from voxelmocap.tracking import DYNAMICS, RandomWalk, TwoStateElbow, VelocityModel


def test_random_walk():
    x = np.array([[1.0, 2.0], [3.0, -4.0]])
    m = RandomWalk()
    np.testing.assert_array_equal(m.drift(x, np.empty((0, 2))), x)
    np.testing.assert_array_equal(m.noise_std(x, [0.1, 2.0], layer_scale=0.5),
                                  [[0.05, 1.0], [0.05, 1.0]])


def test_velocity_model_eq14():
    x = np.array([[0.0, 0.0], [10.0, 10.0]])
    hist = np.array([[1.0, 2.0], [2.0, 0.0]])  # s̄_{k-2}, s̄_{k-1}: step (1, -2)
    np.testing.assert_allclose(VelocityModel(0.7).drift(x, hist), [[0.7, -1.4], [10.7, 8.6]])
    np.testing.assert_allclose(VelocityModel(0.7, indices=[1]).drift(x, hist),
                               [[0.0, -1.4], [10.0, 8.6]])
    # Only the last two estimates count; fewer than two means zero velocity.
    hist3 = np.array([[100.0, 100.0], [1.0, 2.0], [2.0, 0.0]])
    np.testing.assert_allclose(VelocityModel(0.5).drift(x, hist3[-2:]), [[0.5, -1.0],
                                                                         [10.5, 9.0]])
    np.testing.assert_array_equal(VelocityModel().drift(x, hist[:1]), x)
    np.testing.assert_array_equal(VelocityModel().drift(x, np.empty((0, 2))), x)


def test_two_state_elbow_eq16():
    # State: [tx, ty, twist, elbow]; φ = 0.2 rad, β̂ = 0.4 rad.
    m = TwoStateElbow([2], [3], threshold=0.2, singular_std=0.4, factor=0.7)
    x = np.array([[0.0, 0.0, 0.3, 0.1],     # elbow nearly straight -> singular noise
                  [0.0, 0.0, 0.3, 0.5],     # bent -> base noise
                  [0.0, 0.0, 0.3, -0.15],   # |θ_e| < φ on either side
                  [0.0, 0.0, 0.3, 0.2]])    # at the threshold: not singular (θ_e < φ is strict)
    base = np.array([3.0, 3.0, 0.05, 0.06])
    std = m.noise_std(x, base, layer_scale=0.5)
    np.testing.assert_allclose(std[:, 2], [0.2, 0.025, 0.2, 0.025])
    np.testing.assert_allclose(std[:, [0, 1, 3]], np.tile([1.5, 1.5, 0.03], (4, 1)))
    hist = np.array([[0.0, 0.0, 0.0, 0.0], [10.0, 0.0, 0.1, 0.0]])
    np.testing.assert_allclose(m.drift(x, hist)[0], [7.0, 0.0, 0.37, 0.1])


def test_two_state_elbow_two_arms():
    m = TwoStateElbow([0, 2], [1, 3])
    x = np.array([[0.0, 0.05, 0.0, 1.0]])
    std = m.noise_std(x, np.full(4, 0.01))
    np.testing.assert_allclose(std, [[0.4, 0.01, 0.01, 0.01]])
    with pytest.raises(ValueError):
        TwoStateElbow([0, 2], [1])


def test_registry_names_build_the_named_behaviour():
    """Each name gives a model that moves particles the way the name says (hand-worked)."""
    x = np.array([[0.0, 0.0, 0.3, 0.1],    # elbow (dim 3) nearly straight
                  [1.0, 1.0, 0.3, 0.9]])   # bent
    hist = np.array([[0.0, 0.0, 0.0, 0.0], [2.0, -4.0, 0.0, 0.0]])  # last step (2, -4, 0, 0)
    base = np.full(4, 0.05)
    assert set(DYNAMICS) == {"random_walk", "velocity", "elbow"}
    walk = DYNAMICS["random_walk"]()
    np.testing.assert_array_equal(walk.drift(x, hist), x)  # ignores the history
    np.testing.assert_array_equal(walk.noise_std(x, base), np.tile(base, (2, 1)))
    velocity = DYNAMICS["velocity"](0.5)
    np.testing.assert_allclose(velocity.drift(x, hist), x + [1.0, -2.0, 0.0, 0.0])
    np.testing.assert_array_equal(velocity.noise_std(x, base), np.tile(base, (2, 1)))
    elbow = DYNAMICS["elbow"]([2], [3], factor=0.5)
    np.testing.assert_allclose(elbow.drift(x, hist), x + [1.0, -2.0, 0.0, 0.0])
    np.testing.assert_allclose(elbow.noise_std(x, base),
                               [[0.05, 0.05, 0.4, 0.05], [0.05, 0.05, 0.05, 0.05]])


def test_velocity_factor_range():
    for bad in (-0.1, 1.5, float("nan")):
        with pytest.raises(ValueError, match="factor must be in"):
            VelocityModel(bad)
        with pytest.raises(ValueError, match="factor must be in"):
            TwoStateElbow([0], [1], factor=bad)
    assert VelocityModel(0.0).factor == 0.0 and VelocityModel(1.0).factor == 1.0
