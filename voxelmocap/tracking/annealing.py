"""Annealing schedules: likelihood exponents β per layer and noise scales per layer.

Overview
--------
In layer ``l`` of an annealed particle filter the particles are weighted by
``exp(β_l · log p(z | x))`` (Deutscher; paper 004 Table I). β_l is either

* chosen *adaptively* by :func:`find_beta`: the largest β whose weights keep an effective sample
  size of ``survival · N`` (Deutscher's particle survival rate, 0.5 by default; paper 002 §2). The
  ESS of ``exp(β · ll)`` is non-increasing in β (log ESS/N = 2K(β) - K(2β) with K the convex
  cumulant function of ``ll``), so bisection finds it; or
* taken from a *fixed* schedule, e.g. Fontmarty's :data:`FONTMARTY_BETAS` = (0.1, 0.4, 1) with the
  dynamics exponents :data:`FONTMARTY_ALPHAS` = (1, 4, 25) (paper 004 Table II).

The propagation noise of layer ``l`` is the dynamics noise times :func:`layer_noise_scales`: either
the covariance shrinks by ``noise_decay`` per layer (×0.5 is the usual rule), i.e. the standard
deviation by ``sqrt(noise_decay)``, or, with dynamics exponents α_l, sampling from
``p(x_l | x_{l-1})^α_l`` of a Gaussian random walk means dividing its covariance by α_l.

>>> import numpy as np
>>> ll = np.random.default_rng(0).normal(size=1000) * 10
>>> beta = find_beta(ll, 0.5)
>>> round(ess_fraction(ll, beta), 3)
0.5
"""

from __future__ import annotations

import numpy as np

from . import _annealing_kernels as _ak

__all__ = [
    "FONTMARTY_ALPHAS",
    "FONTMARTY_BETAS",
    "ess_fraction",
    "find_beta",
    "layer_noise_scales",
    "tempered_log_weights",
]

FONTMARTY_BETAS = (0.1, 0.4, 1.0)
"""Fontmarty et al.'s likelihood exponents for 3 layers (paper 004 Table II)."""
FONTMARTY_ALPHAS = (1.0, 4.0, 25.0)
"""Fontmarty et al.'s dynamics exponents for 3 layers (paper 004 Table II)."""

# exp(-750) underflows relative to the maximum weight: beyond a β with β·spread above this, the
# weights no longer change and neither does the ESS.
_SATURATION = 750.0


def tempered_log_weights(log_lik, beta: float, offset=None) -> np.ndarray:
    """Log-weights ``beta · log_lik + offset`` with ``-inf`` likelihoods kept at ``-inf``.

    Parameters
    ----------
    log_lik : (N,) array_like
        Log-likelihoods; ``-inf`` for impossible states (zero weight for every β, even β = 0).
    beta : float
        Exponent, ``>= 0``.
    offset : (N,) array_like, optional
        Extra log-weights (importance corrections); ``-inf`` allowed.

    Returns
    -------
    log_w : (N,) ndarray
    """
    log_lik = np.asarray(log_lik, dtype=np.float64)
    finite = np.isfinite(log_lik)
    log_w = np.where(finite, beta * np.where(finite, log_lik, 0.0), -np.inf)
    if offset is not None:
        offset = np.asarray(offset, dtype=np.float64)
        log_w = np.where(np.isneginf(offset), -np.inf, log_w + np.where(
            np.isneginf(offset), 0.0, offset))
    return log_w


def ess_fraction(log_lik, beta: float, offset=None) -> float:
    """ESS / N of the weights ``exp(beta · log_lik + offset)``; 0 when every weight is zero.

    Parameters
    ----------
    log_lik : (N,) array_like
        Log-likelihoods (``-inf`` allowed).
    beta : float
        Exponent, ``>= 0``.
    offset : (N,) array_like, optional
        Extra log-weights.

    Returns
    -------
    fraction : float
        In ``[0, 1]``.
    """
    ll, off = _prepared(log_lik, offset)
    return float(_ak.ess_fraction(ll, float(beta), off))


def _prepared(log_lik, offset):
    """``log_lik`` and ``offset`` as contiguous float64 vectors for the kernel (offset empty
    when None)."""
    ll = np.ascontiguousarray(log_lik, dtype=np.float64).ravel()
    off = _NO_OFFSET if offset is None else np.ascontiguousarray(offset, dtype=np.float64).ravel()
    if off.size == 1 and ll.size != 1:
        off = np.full(ll.size, off[0])
    if off.size and off.size != ll.size:
        raise ValueError(f"offset has {off.size} values for {ll.size} log-likelihoods")
    return ll, off


_NO_OFFSET = np.empty(0)


def find_beta(
    log_lik,
    survival: float = 0.5,
    *,
    offset=None,
    beta_max: float = np.inf,
    rtol: float = 1e-10,
    max_iter: int = 200,
) -> float:
    """The largest β whose weights ``exp(β · log_lik + offset)`` keep ESS >= ``survival · N``.

    Parameters
    ----------
    log_lik : (N,) array_like
        Log-likelihoods of the current particles (``-inf`` allowed; ``NaN`` rejected).
    survival : float
        Target ESS fraction in ``(0, 1]`` (Deutscher's particle survival rate).
    offset : (N,) array_like, optional
        Log-weights not scaled by β (e.g. an importance correction).
    beta_max : float
        Upper limit returned when the ESS stays above the target for every β up to it.
    rtol : float
        Relative width of the final bracket.
    max_iter : int
        Bound on bisection steps.

    Returns
    -------
    beta : float
        ``0`` when even β = 0 gives an ESS below the target (few finite particles, or a strongly
        uneven ``offset``); ``1`` (capped by ``beta_max``) when the likelihood is constant over
        the particles, since β then does not matter; otherwise the solution of
        ``ESS(β) = survival · N`` to relative precision ``rtol`` (the lower end of the bracket, so
        the ESS is never below the target), or ``beta_max``, or the β beyond which the weights
        stop changing (when more than ``survival · N`` particles share the maximum likelihood).
    """
    if not 0.0 < survival <= 1.0:
        raise ValueError(f"find_beta: survival must be in (0, 1], got {survival}")
    log_lik, off = _prepared(log_lik, offset)
    if np.any(np.isnan(log_lik)) or np.any(log_lik == np.inf):
        raise ValueError("find_beta: log-likelihoods must not be NaN or +inf")

    def ess(beta):
        return _ak.ess_fraction(log_lik, float(beta), off)

    if ess(0.0) < survival:
        return 0.0
    alive = np.isfinite(log_lik)
    if offset is not None:
        alive &= np.isfinite(np.asarray(offset, dtype=np.float64).ravel())
    spread = float(np.ptp(log_lik[alive]))
    if spread == 0.0:
        return float(min(1.0, beta_max))
    lo, hi = 0.0, min(1.0, beta_max)
    while ess(hi) >= survival:
        if hi >= beta_max:
            return float(beta_max)
        if hi * spread > _SATURATION:
            return float(hi)
        lo, hi = hi, min(2.0 * hi, beta_max)
    for _ in range(max_iter):
        if hi - lo <= rtol * hi:
            break
        mid = 0.5 * (lo + hi)
        if ess(mid) >= survival:
            lo = mid
        else:
            hi = mid
    return float(lo)


def layer_noise_scales(n_layers: int, *, noise_decay: float = 0.5, alphas=None) -> np.ndarray:
    """Multipliers of the dynamics noise standard deviation for each annealing layer.

    Parameters
    ----------
    n_layers : int
        Number of layers ``L``.
    noise_decay : float
        Factor applied to the noise *covariance* from one layer to the next (used when ``alphas``
        is None): the scale of layer ``l`` (0-based) is ``sqrt(noise_decay ** l)``.
    alphas : (L,) array_like, optional
        Dynamics exponents α_l >= 1 (Fontmarty): the scale is ``1 / sqrt(α_l)``.

    Returns
    -------
    scales : (L,) ndarray
        Standard-deviation multipliers; layer 0 with ``alphas=None`` is 1.
    """
    if alphas is not None:
        alphas = np.asarray(alphas, dtype=np.float64)
        if alphas.shape != (n_layers,) or np.any(~(alphas > 0)):
            raise ValueError(f"alphas must be {n_layers} positive numbers")
        return 1.0 / np.sqrt(alphas)
    if not 0.0 < noise_decay <= 1.0:
        raise ValueError(f"noise_decay must be in (0, 1], got {noise_decay}")
    # the C library's pow, one layer at a time: NumPy's power loop depends on the CPU
    return np.sqrt(np.array([float(noise_decay) ** k for k in range(n_layers)], dtype=np.float64))
