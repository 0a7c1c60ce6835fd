"""truncated_normal against scipy.stats.truncnorm: KS tests, far tails, bounds, log-density."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import integrate, stats

from voxelmocap.tracking import truncated_normal, truncated_normal_logpdf

INF = np.inf

# (mean, std, low, high): one-sided, two-sided, far tails, narrow, mean outside the bounds.
CASES = [
    (0.0, 1.0, -INF, INF),
    (0.0, 1.0, -1.0, 2.0),
    (0.0, 1.0, 0.5, INF),
    (0.0, 1.0, -INF, -0.3),
    (0.0, 1.0, 8.0, INF),
    (0.0, 1.0, -INF, -30.0),
    (0.0, 1.0, 37.0, 38.0),
    (0.0, 1.0, -12.0, -11.5),
    (5.0, 2.0, -1.0, 0.0),  # mean far above the interval
    (-3.0, 0.1, 1.0, 4.0),  # 40 std below the interval
    (0.0, 1.0, 1.0, 1.0 + 1e-6),  # narrow, in the tail
    (0.0, 1.0, -0.2, 0.2),  # nearly flat around the mean
    (0.0, 1.0, -3.0, 0.1),
    (1.7, 0.3, 1.6, INF),
]


@pytest.mark.parametrize(("mean", "std", "low", "high"), CASES)
def test_matches_scipy_truncnorm(mean, std, low, high):
    rng = np.random.default_rng(abs(hash((mean, std, low, high))) % 2**32)
    n = 4000
    x = truncated_normal(np.full(n, mean), std, low, high, rng)
    assert x.shape == (n,)
    assert np.all(x >= low) and np.all(x <= high)
    ref = stats.truncnorm((low - mean) / std, (high - mean) / std, loc=mean, scale=std)
    assert stats.kstest(x, ref.cdf).pvalue > 1e-3
    # The mean and spread too, from quadrature of scipy's density (scipy's closed-form moments
    # fail for very narrow intervals); the KS test alone is weak relative to a far-tail scale.
    lo, hi = max(low, ref.ppf(1e-12)), min(high, ref.isf(1e-12))
    m1 = integrate.quad(lambda t: t * ref.pdf(t), lo, hi, epsabs=1e-12, limit=200)[0]
    m2 = integrate.quad(lambda t: (t - m1) ** 2 * ref.pdf(t), lo, hi, epsabs=1e-12, limit=200)[0]
    assert abs(x.mean() - m1) < 6 * np.sqrt(m2 / n)
    assert x.std() == pytest.approx(np.sqrt(m2), rel=0.1)


def test_extreme_tail_beyond_float_cdf():
    # Φ(-1e4) underflows to 0; the sample - low is Exp(rate = low) to first order.
    rng = np.random.default_rng(3)
    low = 1e4
    x = truncated_normal(np.zeros(20000), 1.0, low, INF, rng)
    assert np.all(x >= low)
    excess = (x - low) * low
    assert stats.kstest(excess, stats.expon().cdf).pvalue > 1e-3
    y = truncated_normal(np.zeros(2000), 1.0, -INF, -1e6, rng)
    assert np.all(y <= -1e6) and np.all(np.isfinite(y))


def test_vectorised_broadcast_and_per_element_parameters():
    rng = np.random.default_rng(7)
    mean = np.array([0.0, 10.0, -4.0])
    low = np.array([-1.0, 11.0, -INF])
    high = np.array([1.0, INF, -5.0])
    x = truncated_normal(np.broadcast_to(mean, (3000, 3)), [1.0, 0.5, 2.0], low, high, rng)
    assert x.shape == (3000, 3)
    for d in range(3):
        s = [1.0, 0.5, 2.0][d]
        ref = stats.truncnorm((low[d] - mean[d]) / s, (high[d] - mean[d]) / s, mean[d], s)
        assert stats.kstest(x[:, d], ref.cdf).pvalue > 1e-3


def test_zero_std_returns_clipped_mean_and_degenerate_interval():
    rng = np.random.default_rng(0)
    x = truncated_normal([0.5, 3.0, -9.0], 0.0, -1.0, 2.0, rng)
    np.testing.assert_array_equal(x, [0.5, 2.0, -1.0])
    y = truncated_normal([0.0, 100.0], [1.0, 5.0], 1.5, 1.5, rng)
    np.testing.assert_array_equal(y, [1.5, 1.5])


def test_deterministic_for_a_seed():
    args = (np.zeros(50), 1.0, np.linspace(-1, 3, 50), np.inf)
    a = truncated_normal(*args, np.random.default_rng(11))
    b = truncated_normal(*args, np.random.default_rng(11))
    np.testing.assert_array_equal(a, b)


def test_bad_arguments_raise():
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError):
        truncated_normal(0.0, -1.0, -1.0, 1.0, rng)
    with pytest.raises(ValueError):
        truncated_normal(0.0, 1.0, 2.0, 1.0, rng)
    with pytest.raises(ValueError):
        truncated_normal(np.nan, 1.0, -1.0, 1.0, rng)


@settings(max_examples=60, deadline=None)
@given(
    mean=st.floats(-1e3, 1e3),
    std=st.floats(0.0, 1e2),
    a=st.floats(-1e4, 1e4),
    width=st.one_of(st.floats(0.0, 1e4), st.just(np.inf)),
    lower_inf=st.booleans(),
    seed=st.integers(0, 2**32 - 1),
)
def test_bounds_never_violated(mean, std, a, width, lower_inf, seed):
    low, high = (-np.inf, a) if lower_inf else (a, a + width)
    x = truncated_normal(np.full(64, mean), std, low, high, np.random.default_rng(seed))
    assert np.all(np.isfinite(x))
    assert np.all(x >= low) and np.all(x <= high)


@pytest.mark.parametrize(("mean", "std", "low", "high"), CASES[:10])
def test_logpdf_matches_scipy(mean, std, low, high):
    ref = stats.truncnorm((low - mean) / std, (high - mean) / std, loc=mean, scale=std)
    x = ref.ppf(np.array([0.01, 0.3, 0.5, 0.9]))
    np.testing.assert_allclose(truncated_normal_logpdf(x, mean, std, low, high), ref.logpdf(x),
                               rtol=1e-7, atol=1e-7)
    outside = low - 1.0 if np.isfinite(low) else high + 1.0
    assert truncated_normal_logpdf(outside, mean, std, low, high) == -np.inf


def test_logpdf_far_tail_is_finite_and_normalised():
    # Φ(-50) underflows in linear scale; the log-density must stay finite and integrate to 1.
    grid = np.linspace(50.0, 52.0, 200001)
    logp = truncated_normal_logpdf(grid, 0.0, 1.0, 50.0, INF)
    assert np.all(np.isfinite(logp))
    assert np.exp(logp).sum() * (grid[1] - grid[0]) == pytest.approx(1.0, rel=1e-3)
