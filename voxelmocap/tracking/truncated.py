"""Exact sampling and log-density of Gaussians truncated to an interval.

Overview
--------
The annealed particle filter propagates particles with Gaussian noise restricted to the legal range
of every state variable (joint-angle limits; paper 002 §2.3, Fig. 3), so that no particle is ever
illegal. :func:`truncated_normal` draws those samples element-wise: every element has its own
``mean``, ``std`` and bounds ``[low, high]`` (infinite bounds allowed), and the draw is exact,
i.e. it follows the truncated law and not a clipped or re-drawn approximation.

Three regimes are used, chosen per element on the standardised bounds
``a = (low - mean) / std``, ``b = (high - mean) / std``:

* *nearly flat* intervals (the density varies by less than a factor 2 across ``[a, b]``, e.g. a
  narrow interval anywhere, however far in the tail): uniform proposals accepted with probability
  ``exp(-(x² - x_min²) / 2)`` (acceptance ≥ 1/2), computed in the original units so that no
  precision is lost by standardising;
* *one-sided* intervals (``a ≥ 0`` or, mirrored, ``b ≤ 0``): inverse CDF on the log scale of the
  upper tail, ``log Φ(-x) = log Φ(-a) + log1p(-u (1 - Φ(-b)/Φ(-a)))`` with
  :func:`scipy.special.log_ndtr` and :func:`scipy.special.ndtri_exp`; this stays accurate for
  ``a`` in the hundreds or thousands, where ``Φ(-a)`` underflows;
* *straddling* intervals (``a < 0 < b`` and wide): the plain inverse CDF, whose probabilities are
  far from 0 and 1 there.

Every result is finally clipped to ``[low, high]`` to absorb the last ulp of rounding, so a value
outside the bounds is never returned. ``std = 0`` returns the mean clipped to the bounds.

>>> import numpy as np
>>> rng = np.random.default_rng(0)
>>> x = truncated_normal(np.zeros(5), 1.0, 8.0, np.inf, rng)
>>> bool(np.all(x >= 8.0))
True
"""

from __future__ import annotations

import math

import numpy as np
from scipy.special import erf, log_ndtr, ndtr, ndtri, ndtri_exp

from ..portable import expm1, log, log1p

__all__ = ["truncated_normal", "truncated_normal_logpdf"]

_SQRT2 = np.sqrt(2.0)
_LOG_SQRT_2PI = 0.5 * math.log(2.0 * math.pi)
# Uniform draws are kept inside the open interval (0, 1) so that no inverse CDF returns ±inf.
_U_MIN = 2.0**-60
_U_MAX = 1.0 - 2.0**-53
# Threshold on (max² - min²)/2 of the standardised interval below which rejection from a uniform
# proposal is used: the acceptance probability is then at least exp(-log 2) = 1/2.
_FLAT = math.log(2.0)


def _broadcast(mean, std, low, high):
    mean, std, low, high = np.broadcast_arrays(
        *(np.asarray(v, dtype=np.float64) for v in (mean, std, low, high))
    )
    if np.any(np.isnan(mean)) or np.any(np.isnan(std)) or np.any(~np.isfinite(mean)):
        raise ValueError("truncated_normal: mean must be finite and std must not be NaN")
    if np.any(std < 0) or np.any(~np.isfinite(std)):
        raise ValueError("truncated_normal: std must be finite and >= 0")
    if np.any(np.isnan(low)) or np.any(np.isnan(high)) or np.any(low > high):
        raise ValueError("truncated_normal: bounds must satisfy low <= high")
    return mean, std, low, high


def _upper_tail(a, b, u):
    """Inverse CDF of N(0,1) truncated to [a, b] with 0 <= a < b, on the log scale of the tail."""
    log_sa = log_ndtr(-a)
    log_sb = log_ndtr(-b)  # -inf when b = +inf
    # 1 - S(b)/S(a) computed without cancellation: -expm1(log S(b) - log S(a)).
    frac = -expm1(log_sb - log_sa)
    log_s = log_sa + log1p(-u * frac)
    return np.clip(-ndtri_exp(log_s), a, b)


def _log_mass(a, b):
    """log(Φ(b) - Φ(a)) for a <= b, stable in both tails and for narrow intervals."""
    a, b = np.broadcast_arrays(np.asarray(a, float), np.asarray(b, float))
    out = np.empty(a.shape)
    right = a > 0
    left = b < 0
    mid = ~(right | left)
    # Upper tail: Φ(-a) - Φ(-b) = Φ(-a) (1 - Φ(-b)/Φ(-a)).
    for mask, lo, hi in ((right, a, b), (left, -b, -a)):
        if np.any(mask):
            la = log_ndtr(-lo[mask])
            lb = log_ndtr(-hi[mask])
            with np.errstate(divide="ignore"):
                out[mask] = la + log(-expm1(lb - la))
    if np.any(mid):
        # Straddling zero: erf keeps full relative precision even for a tiny interval.
        with np.errstate(divide="ignore"):
            out[mid] = log(0.5 * (erf(b[mid] / _SQRT2) - erf(a[mid] / _SQRT2)))
    return out


def truncated_normal(mean, std, low, high, rng: np.random.Generator) -> np.ndarray:
    """Draw from Gaussians truncated to ``[low, high]``, element-wise and exactly.

    Parameters
    ----------
    mean : array_like
        Means of the untruncated Gaussians; broadcast with the other arguments to the output shape.
    std : array_like
        Standard deviations, ``>= 0``. Where ``std == 0`` the result is ``clip(mean, low, high)``.
    low, high : array_like
        Bounds, ``low <= high``; ``-inf`` / ``+inf`` allowed. The mean need not lie inside them.
    rng : numpy.random.Generator
        Source of randomness; the result is a deterministic function of its state.

    Returns
    -------
    x : ndarray
        Samples with the broadcast shape of the arguments, every one inside ``[low, high]``.

    Raises
    ------
    ValueError
        On NaN or infinite means, negative or infinite ``std``, or ``low > high``.

    Notes
    -----
    The regimes are described in the module docstring. One uniform variate is drawn per element,
    plus re-draws for the (rare, acceptance ≥ 1/2) rejected elements of nearly flat intervals.
    """
    mean, std, low, high = _broadcast(mean, std, low, high)
    shape = mean.shape
    mean, std, low, high = (v.ravel() for v in (mean, std, low, high))
    out = np.clip(mean, low, high)  # std == 0 and degenerate intervals
    u = np.clip(rng.random(mean.size), _U_MIN, _U_MAX)

    live = (std > 0) & (low < high)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        a = np.where(live, (low - mean) / np.where(live, std, 1.0), 0.0)
        b = np.where(live, (high - mean) / np.where(live, std, 1.0), 0.0)
    # Beyond ~1e150 std from the mean, the whole mass sits within far less than an ulp of the
    # nearer bound (the excess is ~ std / a); the clipped mean is that bound. This also covers
    # standardised bounds that overflowed to ±inf for a tiny std.
    live &= ~((a > 1e150) | (b < -1e150))
    # Squared distance (in std units) of the interval's closest and farthest points to the mean.
    closest = np.where(a > 0, a, np.where(b < 0, -b, 0.0))
    farthest = np.maximum(np.abs(a), np.abs(b))
    with np.errstate(invalid="ignore", over="ignore"):
        flat = live & (0.5 * (farthest - closest) * (farthest + closest) <= _FLAT)
    right = live & ~flat & (a >= 0)
    left = live & ~flat & (b <= 0)
    mid = live & ~flat & ~right & ~left

    if np.any(right):
        out[right] = mean[right] + std[right] * _upper_tail(a[right], b[right], u[right])
    if np.any(left):
        out[left] = mean[left] - std[left] * _upper_tail(-b[left], -a[left], u[left])
    if np.any(mid):
        pa, pb = ndtr(a[mid]), ndtr(b[mid])
        z = np.clip(ndtri(pa + u[mid] * (pb - pa)), a[mid], b[mid])
        out[mid] = mean[mid] + std[mid] * z
    if np.any(flat):
        idx = np.flatnonzero(flat)
        m, s, lo, hi = mean[idx], std[idx], low[idx], high[idx]
        nearest = np.clip(m, lo, hi)
        pending = np.arange(idx.size)
        v = u[idx]  # the first proposal reuses the element's uniform
        while pending.size:
            x = lo[pending] + v * (hi[pending] - lo[pending])
            d_x = (x - m[pending]) / s[pending]
            d_n = (nearest[pending] - m[pending]) / s[pending]
            log_acc = -0.5 * (d_x - d_n) * (d_x + d_n)
            accept = log(rng.random(pending.size)) <= log_acc
            out[idx[pending[accept]]] = x[accept]
            pending = pending[~accept]
            v = rng.random(pending.size)
    return np.clip(out, low, high).reshape(shape)


def truncated_normal_logpdf(x, mean, std, low, high) -> np.ndarray:
    """Log-density of Gaussians truncated to ``[low, high]``, element-wise.

    Parameters
    ----------
    x, mean, std, low, high : array_like
        Broadcast together; ``std > 0`` and ``low < high`` are required (a point mass has no
        density).

    Returns
    -------
    logpdf : ndarray
        ``log φ((x-mean)/std) - log std - log(Φ(b) - Φ(a))`` inside the bounds, ``-inf`` outside.
    """
    x = np.asarray(x, dtype=np.float64)
    mean, std, low, high = _broadcast(mean, std, low, high)
    if np.any(std <= 0) or np.any(low >= high):
        raise ValueError("truncated_normal_logpdf: needs std > 0 and low < high")
    z = (x - mean) / std
    a = (low - mean) / std
    b = (high - mean) / std
    logp = -0.5 * z * z - _LOG_SQRT_2PI - log(std) - _log_mass(a, b)
    return np.where((x >= low) & (x <= high), logp, -np.inf)
