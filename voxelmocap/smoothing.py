"""Zero-lag Butterworth low-pass filtering of landmark trajectories (for the exports).

:func:`butterworth` runs a Butterworth low-pass forward and backward (``scipy.signal.sosfiltfilt``),
so the trajectories are smoothed without delay. The conventions are the biomechanics ones
Pose2Sim follows: ``order`` is the order of the *combined* zero-lag filter (4 = a 2nd-order
Butterworth run twice, Winter's "4th-order zero-lag"), and the cut-off is the single pass's
−3 dB frequency, not corrected for the double pass. The double pass squares the magnitude
response, so a sinusoid of frequency ``f`` keeps

    1 / (1 + (tan(π f / f_s) / tan(π f_c / f_s))^(2 n)),   n = order / 2

of its amplitude (half at ``f_c``; :func:`zero_lag_gain`).

Gaps. A frame whose value is NaN (a landmark not estimated, a frame without a person) is never
invented: the trajectory is cut at every NaN and each finite stretch is filtered on its own,
and the NaN frames stay NaN. Interpolating across a gap would export positions nobody measured.

Short stretches. ``sosfiltfilt`` pads each end (odd reflection) with ``padlen`` samples to damp
the start-up transients, and needs more samples than that. A stretch no longer than the default
``padlen`` is filtered with ``padlen`` = its length − 1 (weaker edge handling, still zero lag);
a stretch of one sample is left as it is.

>>> import numpy as np
>>> x = np.sin(2 * np.pi * 1.0 * np.arange(600) / 60.0)[:, None, None]
>>> y = butterworth(x, 60.0, cutoff_hz=6.0)
>>> bool(np.abs(y - x)[100:-100].max() < 1e-3)
True
"""

from __future__ import annotations

import numpy as np
from scipy import signal

from .errors import InputError

__all__ = ["MAX_ORDER", "butterworth", "check_filter", "design", "zero_lag_gain"]

#: Highest zero-lag order accepted (a Butterworth of order > 10 per pass is numerically fragile
#: and no motion-capture filter uses one).
MAX_ORDER = 20


def check_filter(frame_rate: float, cutoff_hz: float, order: int, source="smoothing") -> None:
    """Refuse a cut-off at or above Nyquist, a non-positive cut-off or an odd or small order."""
    if not (np.isfinite(frame_rate) and frame_rate > 0):
        raise InputError(source, f"the frame rate must be > 0, got {frame_rate!r}")
    if not (np.isfinite(cutoff_hz) and 0 < cutoff_hz < frame_rate / 2):
        raise InputError(source, f"the cut-off must be between 0 and half the frame rate "
                                 f"({frame_rate / 2:g} Hz), got {cutoff_hz!r} Hz")
    if isinstance(order, bool) or int(order) != order or order < 2 or order % 2 \
            or order > MAX_ORDER:
        raise InputError(source, f"the order must be an even integer from 2 to {MAX_ORDER} (the "
                                 f"zero-lag filter's total order), got {order!r}")


def design(frame_rate: float, cutoff_hz: float, order: int = 4) -> np.ndarray:
    """Second-order sections of the single pass: ``butter(order // 2, f_c / (f_s / 2))``."""
    check_filter(frame_rate, cutoff_hz, order)
    return signal.butter(int(order) // 2, cutoff_hz / (frame_rate / 2.0), "low", output="sos")


def zero_lag_gain(f_hz, frame_rate: float, cutoff_hz: float, order: int = 4) -> np.ndarray:
    """Amplitude gain of the zero-lag filter at ``f_hz`` (closed form; module docstring)."""
    n = int(order) // 2
    r = np.tan(np.pi * np.asarray(f_hz, dtype=float) / frame_rate) / np.tan(
        np.pi * cutoff_hz / frame_rate)
    return 1.0 / (1.0 + r ** (2 * n))


def _segments(finite: np.ndarray) -> list[tuple[int, int]]:
    """``[start, stop)`` of every run of True in a 1-D bool array."""
    edges = np.diff(np.concatenate([[0], finite.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1), strict=True))


def butterworth(x, frame_rate: float, *, cutoff_hz: float, order: int = 4) -> np.ndarray:
    """Zero-lag Butterworth low-pass of trajectories along axis 0 (frames).

    Parameters
    ----------
    x : (F, ...) array_like
        Trajectories, frames along axis 0 (e.g. landmarks ``(F, 15, 3)`` in mm); NaN marks a
        missing value (module docstring: gaps).
    frame_rate : float
        Sampling rate ``f_s`` (Hz) of consecutive rows.
    cutoff_hz : float
        Cut-off ``f_c`` (Hz), ``0 < f_c < f_s / 2``.
    order : int
        Order of the zero-lag filter (even; the single pass has half of it).

    Returns
    -------
    (F, ...) ndarray
        The filtered trajectories, NaN where ``x`` is NaN.

    Raises
    ------
    InputError
        On a bad cut-off, order or frame rate (:func:`check_filter`).
    """
    sos = design(frame_rate, cutoff_hz, order)
    x = np.asarray(x, dtype=float)
    flat = x.reshape(len(x), -1)
    out = flat.copy()
    # scipy's default for sosfiltfilt (its padlen argument's documentation)
    default_pad = 3 * (2 * len(sos) + 1 - min((sos[:, 2] == 0).sum(), (sos[:, 5] == 0).sum()))
    for c in range(flat.shape[1]):
        column = flat[:, c]
        for start, stop in _segments(np.isfinite(column)):
            n = stop - start
            if n < 2:
                continue
            out[start:stop, c] = signal.sosfiltfilt(sos, column[start:stop],
                                                    padlen=min(default_pad, n - 1))
    return out.reshape(x.shape)
