"""Zero-lag Butterworth: against scipy directly, against the closed-form gain, gaps and short runs."""

import numpy as np
import pytest
from scipy import signal

from voxelmocap.errors import InputError
from voxelmocap.smoothing import butterworth, zero_lag_gain


def test_equals_scipy_filtfilt_of_the_half_order_butterworth():
    rng = np.random.default_rng(0)
    x = np.cumsum(rng.normal(size=(200, 15, 3)), axis=0) * 10.0
    y = butterworth(x, 60.0, cutoff_hz=6.0, order=4)
    # Pose2Sim's call (filtering.py: butterworth_filter_1d): butter(order/2) then filtfilt
    b, a = signal.butter(2, 6.0 / 30.0, "low")
    expected = signal.filtfilt(b, a, x, axis=0, padlen=3 * max(len(a), len(b)))
    np.testing.assert_allclose(y, expected, atol=1e-6 * np.abs(x).max())


@pytest.mark.parametrize(("f", "fc", "order"), [(3.0, 6.0, 4), (6.0, 6.0, 4), (9.0, 6.0, 4),
                                                 (10.0, 10.0, 2), (15.0, 10.0, 6)])
def test_sinusoid_attenuation_is_the_closed_form(f, fc, order):
    fs = 60.0
    t = np.arange(3000) / fs
    y = butterworth(np.sin(2 * np.pi * f * t), fs, cutoff_hz=fc, order=order)
    middle = slice(1000, 2000)  # far from the ends' transients
    amplitude = np.sqrt(2.0 * np.mean(y[middle] ** 2))
    # 1 / (1 + (tan(pi f/fs) / tan(pi fc/fs))^(2n)), n = order/2; 1/2 at the cut-off
    expected = 1.0 / (1.0 + (np.tan(np.pi * f / fs) / np.tan(np.pi * fc / fs)) ** order)
    assert amplitude == pytest.approx(expected, rel=2e-3)
    assert zero_lag_gain(f, fs, fc, order) == pytest.approx(expected, rel=1e-12)
    # zero lag: the filtered wave is y = A sin + B cos with B = 0 (no phase shift)
    basis = np.stack([np.sin(2 * np.pi * f * t), np.cos(2 * np.pi * f * t)], axis=1)[middle]
    (a, b), *_ = np.linalg.lstsq(basis, y[middle], rcond=None)
    assert abs(b) < 1e-6 and a == pytest.approx(expected, rel=2e-3)


def test_gaps_split_the_trajectory_and_stay_nan():
    rng = np.random.default_rng(1)
    x = rng.normal(size=(60, 2))
    x[20:23, 0] = np.nan
    y = butterworth(x, 60.0, cutoff_hz=8.0)
    assert np.isnan(y[20:23, 0]).all() and np.isfinite(y[:20, 0]).all()
    np.testing.assert_allclose(y[:20, 0], butterworth(x[:20, 0], 60.0, cutoff_hz=8.0))
    np.testing.assert_allclose(y[23:, 0], butterworth(x[23:, 0], 60.0, cutoff_hz=8.0))
    np.testing.assert_allclose(y[:, 1], butterworth(x[:, 1], 60.0, cutoff_hz=8.0))


def test_short_stretches():
    sos = signal.butter(2, 6.0 / 30.0, output="sos")
    x = np.array([1.0, 3.0, 2.0, 5.0, 4.0])  # shorter than the default padlen (9)
    np.testing.assert_allclose(butterworth(x, 60.0, cutoff_hz=6.0),
                               signal.sosfiltfilt(sos, x, padlen=4))
    one = np.array([np.nan, 7.0, np.nan])
    np.testing.assert_array_equal(butterworth(one, 60.0, cutoff_hz=6.0), one)


@pytest.mark.parametrize(("cutoff", "order", "message"), [
    (30.0, 4, "between 0 and half the frame rate"), (0.0, 4, "between 0"),
    (6.0, 3, "even integer"), (6.0, 0, "even integer")])
def test_bad_filters_are_refused(cutoff, order, message):
    with pytest.raises(InputError, match=message):
        butterworth(np.zeros(10), 60.0, cutoff_hz=cutoff, order=order)
