"""Log-weights and resampling schemes.

Overview
--------
:class:`Weights` is an immutable value built from log-weights (any real numbers or ``-inf``): it
computes the normalised weights ``W``, the effective sample size ``ESS = 1 / Σ W²`` and
``log_mean = log((1/N) Σ exp(log_w))`` once, in a numerically safe way (log-sum-exp), and never
divides by zero. When *every* log-weight is ``-inf`` no particle is preferred: ``W`` is uniform,
``ESS = N`` and ``log_mean = -inf`` (callers can detect this through :attr:`Weights.degenerate`).

Resampling schemes share one signature, ``ancestors = scheme(W, M, rng)`` returning ``(M,)`` int
indices, and are registered by name in :data:`SCHEMES` (as in ``particles.resampling``), so that a
configuration string selects one through :func:`get_scheme`:

>>> import numpy as np
>>> w = Weights(np.log([0.1, 0.2, 0.7]))
>>> float(round(w.ess, 4))
1.8519
>>> get_scheme("systematic")(w.W, 10, np.random.default_rng(0)).shape
(10,)
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from ..portable import exp, logsumexp

__all__ = [
    "SCHEMES",
    "Weights",
    "get_scheme",
    "log_mean_exp",
    "multinomial",
    "residual",
    "stratified",
    "systematic",
]

Scheme = Callable[[np.ndarray, int, np.random.Generator], np.ndarray]
SCHEMES: dict[str, Scheme] = {}


def _register(func: Scheme) -> Scheme:
    SCHEMES[func.__name__] = func
    return func


def get_scheme(name: str) -> Scheme:
    """Return the resampling scheme registered under ``name`` (``ValueError`` if unknown)."""
    try:
        return SCHEMES[name]
    except KeyError:
        raise ValueError(
            f"unknown resampling scheme {name!r}; known: {', '.join(sorted(SCHEMES))}"
        ) from None


class Weights:
    """Immutable normalised importance weights built from log-weights.

    Parameters
    ----------
    log_w : (N,) array_like
        Log-weights; ``-inf`` marks impossible particles. ``NaN`` and ``+inf`` are rejected.

    Attributes
    ----------
    log_w : (N,) ndarray
        The log-weights (a read-only copy).
    W : (N,) ndarray
        Normalised weights, summing to 1.
    ess : float
        Effective sample size ``1 / Σ W²``, in ``[1, N]``.
    log_mean : float
        ``log((1/N) Σ exp(log_w))`` (``-inf`` when every weight is zero).
    degenerate : bool
        True when every log-weight is ``-inf`` (then ``W`` is uniform).
    """

    __slots__ = ("W", "degenerate", "ess", "log_mean", "log_w")

    def __init__(self, log_w):
        log_w = np.array(log_w, dtype=np.float64).ravel()
        if log_w.size == 0:
            raise ValueError("Weights: need at least one particle")
        if np.any(np.isnan(log_w)) or np.any(log_w == np.inf):
            raise ValueError("Weights: log-weights must not be NaN or +inf")
        log_w.setflags(write=False)
        n = log_w.size
        top = log_w.max()
        if top == -np.inf:
            W = np.full(n, 1.0 / n)
            log_mean = -np.inf
            degenerate = True
        else:
            # Shift by the maximum before exponentiating: the largest term is exactly 1.
            e = exp(log_w - top)
            total = e.sum()
            W = e / total
            log_mean = float(top + math.log(total) - math.log(n))
            degenerate = False
        W.setflags(write=False)
        object.__setattr__(self, "log_w", log_w)
        object.__setattr__(self, "W", W)
        object.__setattr__(self, "ess", float(1.0 / np.sum(W * W)))
        object.__setattr__(self, "log_mean", log_mean)
        object.__setattr__(self, "degenerate", degenerate)

    def __setattr__(self, name, value):
        raise AttributeError("Weights is immutable")

    def __len__(self) -> int:
        return self.log_w.size

    def add(self, delta) -> Weights:
        """Return new weights with log-weights ``log_w + delta`` (``-inf`` stays ``-inf``)."""
        delta = np.asarray(delta, dtype=np.float64)
        with np.errstate(invalid="ignore"):
            new = self.log_w + delta
        # -inf + +inf would be NaN: an impossible particle stays impossible.
        return Weights(np.where(np.isneginf(self.log_w), -np.inf, new))

    def __repr__(self) -> str:
        return f"Weights(N={len(self)}, ess={self.ess:.4g}, log_mean={self.log_mean:.6g})"


def log_mean_exp(values) -> float:
    """``log(mean(exp(values)))`` computed stably; ``-inf`` for an all ``-inf`` input."""
    values = np.asarray(values, dtype=np.float64)
    if np.all(np.isneginf(values)):
        return -np.inf
    return float(logsumexp(values) - math.log(values.size))


def _inverse_cdf(uniforms: np.ndarray, W: np.ndarray) -> np.ndarray:
    """Indices j with C_{j-1} <= u < C_j for sorted uniforms in [0, 1), C = cumsum(W)."""
    cdf = np.cumsum(W)
    cdf[-1] = 1.0  # guard against rounding leaving cdf[-1] slightly below 1
    idx = np.searchsorted(cdf, uniforms, side="right")
    return np.minimum(idx, W.size - 1)


@_register
def systematic(W: np.ndarray, M: int, rng: np.random.Generator) -> np.ndarray:
    """Systematic resampling: one uniform, points ``(U + m) / M``, ``m = 0 … M-1``.

    Parameters
    ----------
    W : (N,) ndarray
        Normalised weights.
    M : int
        Number of ancestors to draw.
    rng : numpy.random.Generator
        Source of randomness (one uniform is drawn).

    Returns
    -------
    ancestors : (M,) int ndarray
        Sorted indices into ``W``; particle ``n`` appears ``floor(M W_n)`` or ``ceil(M W_n)``
        times, and ``M W_n`` times in expectation.
    """
    return _inverse_cdf((rng.random() + np.arange(M)) / M, np.asarray(W, dtype=np.float64))


@_register
def stratified(W: np.ndarray, M: int, rng: np.random.Generator) -> np.ndarray:
    """Stratified resampling: one uniform per stratum ``[m/M, (m+1)/M)``; same signature."""
    return _inverse_cdf((rng.random(M) + np.arange(M)) / M, np.asarray(W, dtype=np.float64))


@_register
def multinomial(W: np.ndarray, M: int, rng: np.random.Generator) -> np.ndarray:
    """Multinomial resampling: ``M`` i.i.d. draws from ``W`` (sorted); same signature."""
    return _inverse_cdf(np.sort(rng.random(M)), np.asarray(W, dtype=np.float64))


@_register
def residual(W: np.ndarray, M: int, rng: np.random.Generator) -> np.ndarray:
    """Residual resampling: ``floor(M W)`` copies, the rest multinomial; same signature."""
    W = np.asarray(W, dtype=np.float64)
    counts = np.floor(M * W).astype(np.int64)
    rest = M - int(counts.sum())
    out = np.repeat(np.arange(W.size), counts)
    if rest > 0:
        r = M * W - counts
        extra = _inverse_cdf(np.sort(rng.random(rest)), r / r.sum())
        out = np.sort(np.concatenate([out, extra]))
    return out
