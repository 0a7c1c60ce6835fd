"""β by bisection hits the target ESS; fixed schedules and layer noise scales."""

import numpy as np
import pytest

from voxelmocap.tracking import (
    FONTMARTY_ALPHAS,
    ess_fraction,
    find_beta,
    layer_noise_scales,
    tempered_log_weights,
)


@pytest.mark.parametrize("survival", [0.1, 0.3, 0.5, 0.8])
@pytest.mark.parametrize("scale", [0.01, 1.0, 1e4])
def test_find_beta_hits_target_ess(survival, scale):
    rng = np.random.default_rng(int(survival * 10) + int(np.log10(scale)) * 7 + 100)
    ll = -scale * rng.chisquare(5, size=600)
    beta = find_beta(ll, survival)
    assert beta > 0
    # Brute force: the ESS fraction computed directly from the definition.
    w = np.exp(beta * (ll - ll.max()))
    direct = w.sum() ** 2 / (len(ll) * np.sum(w**2))
    assert direct == pytest.approx(survival, abs=1e-6)
    assert ess_fraction(ll, beta) >= survival
    assert ess_fraction(ll, beta * (1 + 1e-6)) < survival + 1e-6


def test_ess_is_monotone_in_beta():
    ll = np.random.default_rng(3).normal(size=300) * 5
    fr = [ess_fraction(ll, b) for b in np.linspace(0, 5, 60)]
    assert np.all(np.diff(fr) <= 1e-12)


def test_minus_inf_particles_keep_zero_weight_even_at_beta_zero():
    ll = np.array([-np.inf, -1.0, -2.0, -np.inf])
    np.testing.assert_array_equal(tempered_log_weights(ll, 0.0), [-np.inf, 0, 0, -np.inf])
    assert ess_fraction(ll, 0.0) == pytest.approx(0.5)
    # Only half the particles are possible: a survival of 0.6 is out of reach -> β = 0.
    assert find_beta(ll, 0.6) == 0.0
    assert ess_fraction(np.full(3, -np.inf), 1.0) == 0.0
    assert find_beta(np.full(3, -np.inf), 0.5) == 0.0


def test_constant_likelihood_and_caps():
    assert find_beta(np.full(10, -3.0), 0.5) == 1.0
    ll = np.random.default_rng(0).normal(size=100)
    assert find_beta(ll, 0.5, beta_max=1e-3) == 1e-3
    # More than half share the maximum: the ESS can never fall below 0.5, β saturates.
    tied = np.r_[np.zeros(70), -np.ones(30)]
    beta = find_beta(tied, 0.5)
    assert np.isfinite(beta) and ess_fraction(tied, beta) >= 0.5


def test_offset_enters_unscaled():
    ll = np.random.default_rng(1).normal(size=200)
    off = np.random.default_rng(2).normal(size=200) * 0.3
    beta = find_beta(ll, 0.5, offset=off)
    w = np.exp(beta * ll + off)
    assert w.sum() ** 2 / (200 * np.sum(w**2)) == pytest.approx(0.5, abs=1e-6)


def test_find_beta_rejects_nan():
    with pytest.raises(ValueError):
        find_beta([0.0, np.nan], 0.5)
    with pytest.raises(ValueError):
        find_beta([0.0, 1.0], 0.0)


def test_layer_noise_scales():
    np.testing.assert_allclose(layer_noise_scales(3, noise_decay=0.5), [1, 0.5**0.5, 0.5])
    np.testing.assert_allclose(layer_noise_scales(3, alphas=FONTMARTY_ALPHAS), [1, 0.5, 0.2])
    with pytest.raises(ValueError):
        layer_noise_scales(2, alphas=FONTMARTY_ALPHAS)


def test_ess_kernel_equals_the_numpy_expression():
    """The one-pass ESS kernel against the tempered weights' NumPy expression, with impossible
    particles, -inf offsets, β = 0 and a scalar offset."""
    rng = np.random.default_rng(21)
    for n in (1, 2, 7, 600):
        for _ in range(20):
            ll = rng.normal(-500.0, 40.0, n)
            ll[rng.random(n) < 0.1] = -np.inf
            offset = rng.normal(0.0, 2.0, n)
            offset[rng.random(n) < 0.1] = -np.inf
            for beta in (0.0, rng.uniform(0.0, 0.2), rng.uniform(0.0, 5.0)):
                for off in (None, offset, 0.7):
                    lw = tempered_log_weights(ll, beta, None if off is None
                                              else np.broadcast_to(off, ll.shape))
                    if lw.max() == -np.inf:
                        want = 0.0
                    else:
                        e = np.exp(lw - lw.max())
                        want = e.sum() ** 2 / (np.sum(e * e) * n)
                    assert ess_fraction(ll, beta, off) == pytest.approx(want, rel=1e-12, abs=0)
