"""Weights (log-sum-exp, ESS, degenerate cases) and unbiasedness of the resampling schemes."""

import numpy as np
import pytest

from voxelmocap.tracking import SCHEMES, Weights, get_scheme
from voxelmocap.tracking.resampling import log_mean_exp


def test_weights_against_direct_formulas():
    rng = np.random.default_rng(0)
    lw = rng.normal(size=50) * 3
    w = Weights(lw)
    direct = np.exp(lw) / np.exp(lw).sum()
    np.testing.assert_allclose(w.W, direct, rtol=1e-12)
    assert w.ess == pytest.approx(1.0 / np.sum(direct**2), rel=1e-12)
    assert w.log_mean == pytest.approx(np.log(np.mean(np.exp(lw))), rel=1e-12)
    assert not w.degenerate


def test_weights_huge_log_values_and_minus_inf():
    w = Weights([-1e6, -1e6 + np.log(3.0), -np.inf])
    # -1e6 + log 3 itself is only known to ~1e-10 (the ulp of 1e6).
    np.testing.assert_allclose(w.W, [0.25, 0.75, 0.0], rtol=1e-9)
    assert w.ess == pytest.approx(1.0 / (0.25**2 + 0.75**2), rel=1e-9)
    assert w.log_mean == pytest.approx(-1e6 + np.log(4.0 / 3.0), rel=1e-15)


def test_all_impossible_falls_back_to_uniform_without_dividing_by_zero():
    w = Weights(np.full(4, -np.inf))
    assert w.degenerate
    np.testing.assert_array_equal(w.W, np.full(4, 0.25))
    assert w.ess == 4.0 and w.log_mean == -np.inf
    assert log_mean_exp(np.full(3, -np.inf)) == -np.inf


def test_weights_are_immutable_and_add_returns_new():
    w = Weights([0.0, 0.0])
    with pytest.raises(AttributeError):
        w.ess = 3
    with pytest.raises(ValueError):
        w.W[0] = 1.0
    w2 = w.add([np.log(3.0), 0.0])
    np.testing.assert_allclose(w2.W, [0.75, 0.25])
    np.testing.assert_allclose(w.W, [0.5, 0.5])
    assert Weights([-np.inf, 0.0]).add([np.inf, 0.0]).W[0] == 0.0


@pytest.mark.parametrize("bad", [[0.0, np.nan], [np.inf, 0.0], []])
def test_weights_reject_nan_and_plus_inf(bad):
    with pytest.raises(ValueError):
        Weights(bad)


def test_unknown_scheme():
    with pytest.raises(ValueError, match="systematic"):
        get_scheme("nope")


@pytest.mark.parametrize("name", sorted(SCHEMES))
def test_resampling_is_unbiased(name):
    # E[count_n] = M W_n: the mean count over many draws must match within its standard error.
    rng = np.random.default_rng(42)
    W = rng.dirichlet(np.full(20, 0.5))
    W[3] = 0.0  # a zero-weight particle is never chosen
    W /= W.sum()
    M, reps = 15, 20000
    counts = np.zeros((reps, W.size))
    scheme = get_scheme(name)
    for r in range(reps):
        anc = scheme(W, M, rng)
        assert anc.shape == (M,) and anc.dtype.kind == "i"
        counts[r] = np.bincount(anc, minlength=W.size)
    assert counts[:, 3].max() == 0
    se = counts.std(axis=0) / np.sqrt(reps) + 1e-3
    assert np.all(np.abs(counts.mean(axis=0) - M * W) < 5 * se)


def test_systematic_counts_are_floor_or_ceil():
    rng = np.random.default_rng(1)
    W = rng.dirichlet(np.ones(30))
    for _ in range(200):
        c = np.bincount(get_scheme("systematic")(W, 100, rng), minlength=30)
        assert np.all(c >= np.floor(100 * W) - 1e-9) and np.all(c <= np.ceil(100 * W) + 1e-9)
