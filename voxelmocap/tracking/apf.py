"""The annealed particle filter (Deutscher), with SIR and Fontmarty's IAPF as strategies.

Overview
--------
:class:`AnnealedParticleFilter` estimates an opaque ``D``-dimensional state frame by frame. It sees
the problem only through the state bounds ``[low, high]``, a base noise, a dynamics model
(:mod:`.dynamics`) and, at every frame, a log-likelihood callable mapping ``(P, D)`` states to
``(P,)`` log-likelihoods (``-inf`` for impossible states). Per frame (paper 004 Table I,
paper 002 §2):

1. resample the weighted particles of the previous frame (systematic by default);
2. for each layer ``l = 1 … L``: propagate (layer 1: the dynamics' drift plus its noise; later
   layers: resample, then the noise alone, scaled by :func:`.annealing.layer_noise_scales`), always
   with truncated Gaussians inside ``[low, high]`` (paper 002 §2.3); evaluate the log-likelihood;
   weight by ``exp(β_l · ll)`` with β_l found by bisection for an ESS of ``survival · N``
   (:func:`.annealing.find_beta`) or taken from a fixed schedule;
3. the estimate is the weighted mean of the last layer; the MAP particle (largest last-layer
   weight), the ESS and β of every layer, and the number of likelihood evaluations are recorded.

Strategies:

* ``"sir"``: Condensation / bootstrap filter, one layer of ``n_layers · n_particles`` particles
  weighted with β = 1: the baseline at equal cost.
* ``"apf"``: the annealed particle filter above.
* ``"iapf"``: Fontmarty's I-Annealed PF: in layer 1 a fraction of the particles comes from the
  dynamics, a fraction from a caller-supplied ``proposal(n, rng) -> (n, D)`` (e.g. detector
  driven), the rest from the prior (the distribution given to :meth:`initialise`). When the
  proposal's log-density is supplied too (or no proposal is used), layer 1 carries the importance
  correction ``p(x | x_{k-1}) / q(x | x_{k-1}, z)`` of Table I line 8, with ``q`` the mixture;
  otherwise the layer-1 weights are the tempered likelihood alone (Fontmarty's practice: IAPF "is
  not a mathematically sound Monte Carlo method").

Everything is done with log-weights; nothing is divided by zero. The filter is deterministic for a
seeded generator, and :meth:`get_state` / :meth:`set_state` capture and restore its complete state
(particles, weights, generator state, estimate history) as plain arrays and dicts, so a run can be
checkpointed and resumed bit-identically.

>>> import numpy as np
>>> f = AnnealedParticleFilter(200, 3, -np.inf * np.ones(2), np.inf * np.ones(2), 0.5, rng=0)
>>> f.initialise(np.zeros(2), 1.0)
>>> est = f.step(lambda x: -0.5 * np.sum((x - 1.0) ** 2, axis=1) / 0.1**2)
>>> bool(np.all(np.abs(est - 1.0) < 0.3))
True
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable, Iterable

import numpy as np

from ..errors import InputError
from ..portable import logsumexp, weighted_sum
from .annealing import find_beta, layer_noise_scales, tempered_log_weights
from .dynamics import Dynamics, RandomWalk
from .resampling import Weights, get_scheme
from .truncated import truncated_normal, truncated_normal_logpdf

__all__ = ["STRATEGIES", "AnnealedParticleFilter", "check_options"]

STRATEGIES = ("sir", "apf", "iapf")
"""Names accepted by ``strategy``."""

LogLikelihood = Callable[[np.ndarray], np.ndarray]
Proposal = Callable[[int, np.random.Generator], np.ndarray]
_HISTORY = 2  # estimates kept for the dynamics (Azad's velocity needs the last two)


def check_options(*, n_particles=2, n_layers=1, strategy="apf", survival=0.5, betas=None,
                  alphas=None, noise_decay=0.5, iapf_fractions=(0.8, 0.2),
                  resampling="systematic", beta_max=np.inf) -> None:
    """Check the filter's options (the one statement of their legal ranges).

    :class:`AnnealedParticleFilter` calls it, and so does the configuration
    (``voxelmocap.config.FilterConfig``), so a TOML file is held to the same rules.

    Raises
    ------
    InputError
        Naming the option (its constructor name) and the rule it breaks.
    """
    if strategy not in STRATEGIES:
        raise InputError("strategy", f"unknown {strategy!r}; use one of {', '.join(STRATEGIES)}")
    if isinstance(n_particles, bool) or int(n_particles) != n_particles or n_particles < 2:
        raise InputError("n_particles", f"must be an integer >= 2, got {n_particles}")
    if isinstance(n_layers, bool) or int(n_layers) != n_layers or n_layers < 1:
        raise InputError("n_layers", f"must be an integer >= 1, got {n_layers}")
    if not 0.0 < survival <= 1.0:
        raise InputError("survival", f"must be in (0, 1], got {survival}")
    if not beta_max > 0:
        raise InputError("beta_max", f"must be > 0, got {beta_max}")
    if betas is not None:
        b = np.asarray(betas, dtype=np.float64)
        if b.shape != (int(n_layers),) or np.any(~(b >= 0)) or np.any(~np.isfinite(b)):
            raise InputError("betas", f"must be {int(n_layers)} finite numbers >= 0 (one per "
                                      "layer)")
    try:
        layer_noise_scales(int(n_layers), noise_decay=noise_decay, alphas=alphas)
    except ValueError as exc:
        raise InputError("alphas" if alphas is not None else "noise_decay", str(exc)) from None
    f = np.asarray(iapf_fractions, dtype=np.float64)
    if f.shape != (2,) or np.any(~(f >= 0)) or f.sum() > 1.0 + 1e-12:
        raise InputError("iapf_fractions", "must be two fractions >= 0 summing to <= 1")
    try:
        get_scheme(resampling)
    except ValueError as exc:
        raise InputError("resampling", str(exc)) from None


class AnnealedParticleFilter:
    """Annealed particle filter over a bounded ``D``-dimensional state.

    Parameters
    ----------
    n_particles : int
        Particles per layer ``N_p`` (``>= 2``).
    n_layers : int
        Annealing layers ``N_L`` (``>= 1``). With ``strategy="sir"`` the filter uses one layer of
        ``n_layers · n_particles`` particles instead.
    low, high : (D,) array_like
        State bounds (``±inf`` allowed); particles never leave them.
    noise_std : float or (D,) array_like
        Dynamics noise standard deviation per dimension, in state units (``>= 0``).
    strategy : {"apf", "sir", "iapf"}
        Filtering strategy (module docstring).
    rng : numpy.random.Generator or int or None
        Generator (used and advanced in place) or seed.
    survival : float
        Target ESS fraction for the adaptive β (0.5: about half the particles survive).
    betas : (N_L,) array_like, optional
        Fixed likelihood exponents instead of the adaptive ones, e.g. ``(0.1, 0.4, 1)``.
        ``betas``, ``alphas``, ``noise_decay`` and ``survival`` do not apply to ``"sir"``
        (β = 1, full noise).
    alphas : (N_L,) array_like, optional
        Fontmarty's dynamics exponents (e.g. ``(1, 4, 25)``): layer noise std ``noise_std/√α_l``.
        Overrides ``noise_decay``.
    noise_decay : float
        Factor on the noise *covariance* from one layer to the next (std × ``√noise_decay``).
    dynamics : Dynamics, optional
        Motion model; :class:`~.dynamics.RandomWalk` by default.
    proposal : callable, optional
        ``proposal(n, rng) -> (n, D)`` for the IAPF's measurement-driven particles (results are
        clipped into the bounds). May also be given per step.
    proposal_log_pdf : callable, optional
        ``proposal_log_pdf(x (n, D)) -> (n,)`` log-density of ``proposal``; enables the IAPF
        importance correction.
    iapf_fractions : (2,) tuple of float
        Fractions of layer-1 particles drawn from the dynamics and from ``proposal``; the rest come
        from the prior (Fontmarty: (0.8, 0.2)).
    resampling : str
        Name of a scheme in :data:`~.resampling.SCHEMES`.
    beta_max : float
        Upper limit of the adaptive β.

    Attributes
    ----------
    estimate : (D,) ndarray or None
        Weighted mean of the last layer after the latest :meth:`step`.
    map_particle : (D,) ndarray or None
        Particle of largest last-layer weight; ``map_log_likelihood`` is its log-likelihood.
    layer_ess, layer_betas : (L,) ndarray
        ESS and β of each layer of the latest step (``L = 1`` for SIR).
    particles : (N, D) ndarray
        Particles of the last layer; ``log_weights`` (N,) and ``weights`` (N,) their weights and
        ``log_likelihoods`` (N,) their log-likelihoods.
    mean_log_likelihood : float
        Weighted mean log-likelihood of the last layer (``-inf`` if all particles are impossible).
    n_evaluations : int
        Likelihood evaluations since :meth:`initialise`; ``step_evaluations`` for the latest step.
    frame : int
        Number of steps since :meth:`initialise`.
    """

    def __init__(self, n_particles: int, n_layers: int, low, high, noise_std, *,
                 strategy: str = "apf", rng=None, survival: float = 0.5, betas=None,
                 alphas=None, noise_decay: float = 0.5, dynamics: Dynamics | None = None,
                 proposal: Proposal | None = None, proposal_log_pdf=None,
                 iapf_fractions=(0.8, 0.2), resampling: str = "systematic",
                 beta_max: float = np.inf):
        check_options(n_particles=n_particles, n_layers=n_layers, strategy=strategy,
                      survival=survival, betas=betas, alphas=alphas, noise_decay=noise_decay,
                      iapf_fractions=iapf_fractions, resampling=resampling, beta_max=beta_max)
        self.low = np.asarray(low, dtype=np.float64).ravel()
        self.high = np.asarray(high, dtype=np.float64).ravel()
        if self.low.shape != self.high.shape or self.low.size == 0:
            raise InputError("low/high", "must be non-empty arrays of the same length D")
        if np.any(np.isnan(self.low)) or np.any(np.isnan(self.high)) or np.any(
                self.low > self.high):
            raise InputError("low/high", "need low <= high in every dimension")
        self.dim = self.low.size
        try:
            self.noise_std = np.broadcast_to(np.asarray(noise_std, dtype=np.float64),
                                             (self.dim,)).copy()
        except ValueError:
            raise InputError("noise_std", f"must be a scalar or {self.dim} values") from None
        if np.any(~np.isfinite(self.noise_std)) or np.any(self.noise_std < 0):
            raise InputError("noise_std", "must be finite and >= 0")

        self.strategy = strategy
        self.n_particles = int(n_particles)
        self.n_layers = int(n_layers)
        if strategy == "sir":
            # Equal cost: one layer holding every evaluation the annealed filter would make.
            self._n = self.n_particles * self.n_layers
            self._layers = 1
            self._betas = np.ones(1)
            self._scales = np.ones(1)
        else:
            self._n = self.n_particles
            self._layers = self.n_layers
            self._betas = None if betas is None else np.asarray(betas, dtype=np.float64)
            self._scales = layer_noise_scales(self.n_layers, noise_decay=noise_decay,
                                              alphas=alphas)
        f = np.asarray(iapf_fractions, dtype=np.float64)
        self.iapf_fractions = (float(f[0]), float(f[1]))
        self.survival = float(survival)
        self.beta_max = float(beta_max)
        self.rng = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
        self.dynamics = RandomWalk() if dynamics is None else dynamics
        self.proposal = proposal
        self.proposal_log_pdf = proposal_log_pdf
        self._resample = get_scheme(resampling)
        self.resampling = resampling

        self.particles: np.ndarray | None = None
        self.log_weights: np.ndarray | None = None
        self.log_likelihoods: np.ndarray | None = None
        self._history = np.empty((0, self.dim))
        self._prior: tuple[np.ndarray, np.ndarray] | None = None
        self._clear_records()

    # ------------------------------------------------------------------ set-up and records
    @property
    def n_total(self) -> int:
        """Particles per layer actually used (``n_layers · n_particles`` for SIR)."""
        return self._n

    @property
    def weights(self) -> np.ndarray | None:
        """Normalised weights of the last layer, ``(N,)``."""
        return None if self.log_weights is None else Weights(self.log_weights).W

    @property
    def searched(self) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """What the last step searched: ``[(dims (K,), particles (P, K), weights (P,))]``.

        One entry per group of dimensions searched with the others held: for this joint filter
        its particles over every dimension (the last layer after a step; the drawn or restored
        set after :meth:`initialise` or :meth:`set_state`, empty before). A caller measuring how
        uncertain a function of the state is takes each group's spread with the other
        dimensions at the estimate (:attr:`.partitioned.PartitionedParticleFilter.searched`).
        """
        if self.particles is None or self.log_weights is None:
            return []
        return [(np.arange(self.dim), self.particles, self.weights)]

    @property
    def history(self) -> np.ndarray:
        """Previous estimates kept for the dynamics, ``(H, D)``, oldest first (``H <= 2``)."""
        return self._history.copy()

    def _clear_records(self):
        self.estimate = None
        self.map_particle = None
        self.map_log_likelihood = None
        self.mean_log_likelihood = None
        self.layer_ess = np.empty(0)
        self.layer_betas = np.empty(0)
        self.iapf_corrected = False
        self.step_evaluations = 0
        self.n_evaluations = 0
        self.frame = 0

    def initialise(self, mean, std) -> None:
        """Draw the first particle set from ``N(mean, diag(std²))`` truncated to the bounds.

        Parameters
        ----------
        mean : (D,) or (K, D) array_like
            Initial state guess, in state units; K guesses start a mixture: particle ``i`` is
            drawn around guess ``i mod K`` (equal shares), and the first guess is the IAPF's
            prior mean.
        std : float or (D,) array_like
            Its uncertainty (``>= 0``). ``(mean, std)`` is also the IAPF's prior.

        Notes
        -----
        Weights become uniform, the estimate history and the counters are cleared (the initial
        guess is not taken as an estimate, so the velocity model starts from zero velocity).
        """
        means = np.asarray(mean, dtype=np.float64)
        if means.ndim == 2 and means.shape[0] >= 1 and means.shape[1] == self.dim:
            mean, rows = means[0].copy(), means[np.arange(self._n) % means.shape[0]]
        else:
            rows = None
        try:
            mean = np.broadcast_to(np.asarray(mean, dtype=np.float64), (self.dim,)).copy()
            std = np.broadcast_to(np.asarray(std, dtype=np.float64), (self.dim,)).copy()
        except ValueError:
            raise InputError("initialise", f"mean and std must have {self.dim} values") from None
        if np.any(~np.isfinite(means)) or np.any(~np.isfinite(std)) or np.any(std < 0):
            raise InputError("initialise", "mean must be finite and std finite and >= 0")
        self._prior = (mean, std)
        centres = np.broadcast_to(mean, (self._n, self.dim)) if rows is None else rows
        self.particles = truncated_normal(centres, std, self.low, self.high, self.rng)
        self.log_weights = np.zeros(self._n)
        self.log_likelihoods = None
        self._history = np.empty((0, self.dim))
        self._clear_records()

    def move_estimate(self, state, *, keep_motion: bool = True) -> None:
        """Replace the last estimate by ``state`` (D,) found outside the filter (e.g. a global
        search of a few dimensions), moving every particle by the same offset (clipped to the
        bounds) so that the next step searches around it.

        With ``keep_motion`` False the estimates before it are forgotten too, so the dynamics
        see no velocity across the move (a move that is no motion: the body turned round)."""
        if self.estimate is None:
            raise RuntimeError("move_estimate: no estimate yet")
        state = np.asarray(state, dtype=float)
        delta = state - self.estimate
        self.particles = np.clip(self.particles + delta, self.low, self.high)
        self.estimate = state.copy()
        self.map_particle = np.clip(np.asarray(self.map_particle) + delta, self.low, self.high)
        if len(self._history):
            self._history[-1] = state
            if not keep_motion:
                self._history = self._history[-1:].copy()

    def clear_history(self) -> None:
        """Forget the estimates the dynamics see (e.g. after settling steps on one frame) and
        restart the step count; particles and weights stay."""
        self._history = np.empty((0, self.dim))
        self.frame = 0

    # ------------------------------------------------------------------ one frame
    def _evaluate(self, log_likelihood: LogLikelihood, x: np.ndarray) -> np.ndarray:
        ll = np.asarray(log_likelihood(x), dtype=np.float64)
        if ll.shape != (x.shape[0],):
            raise ValueError(f"log_likelihood returned shape {ll.shape}, expected ({x.shape[0]},)")
        if np.any(np.isnan(ll)) or np.any(ll == np.inf):
            raise ValueError("log_likelihood returned NaN or +inf (use -inf for impossible states)")
        self.step_evaluations += x.shape[0]
        return ll

    def _iapf_layer(self, x, mean, std, proposal, proposal_log_pdf):
        """Layer-1 sampling of the IAPF; returns particles and the log importance correction."""
        n = self._n
        f_dyn, f_prop = self.iapf_fractions
        n_dyn = min(n, round(f_dyn * n))
        n_prop = min(n - n_dyn, round(f_prop * n))
        n_prior = n - n_dyn - n_prop
        if n_prop and proposal is None:
            raise InputError("proposal", "the iapf strategy needs a proposal function")
        # Random assignment: resampled ancestors are sorted, so a fixed split would tie the
        # mixture component to the ancestor's position.
        comp = np.empty(n, dtype=np.int8)
        perm = self.rng.permutation(n)
        comp[perm[:n_dyn]] = 0
        comp[perm[n_dyn:n_dyn + n_prop]] = 1
        comp[perm[n_dyn + n_prop:]] = 2
        out = np.empty_like(x)
        sel = comp == 0
        out[sel] = truncated_normal(mean[sel], std[sel], self.low, self.high, self.rng)
        if n_prop:
            drawn = np.asarray(proposal(n_prop, self.rng), dtype=np.float64)
            if drawn.shape != (n_prop, self.dim) or np.any(~np.isfinite(drawn)):
                raise ValueError(f"proposal must return finite ({n_prop}, {self.dim}) states")
            out[comp == 1] = np.clip(drawn, self.low, self.high)
        prior_mean, prior_std = self._prior
        if n_prior:
            out[comp == 2] = truncated_normal(np.broadcast_to(prior_mean, (n_prior, self.dim)),
                                              prior_std, self.low, self.high, self.rng)
        self.iapf_corrected = n_prop == 0 or proposal_log_pdf is not None
        if not self.iapf_corrected:
            return out, None
        if np.any(std <= 0) or (n_prior and np.any(prior_std <= 0)) or np.any(
                self.low >= self.high):
            raise InputError("noise_std", "the IAPF importance correction needs every noise "
                             "and prior std > 0 and low < high")
        # Weight p(x | ancestor) / q(x | ancestor, z), q = the mixture actually sampled.
        log_p = truncated_normal_logpdf(out, mean, std, self.low, self.high).sum(axis=1)
        terms = [math.log(n_dyn / n) + log_p] if n_dyn else []
        if n_prop:
            log_g = np.asarray(proposal_log_pdf(out), dtype=np.float64)
            if log_g.shape != (n,) or np.any(np.isnan(log_g)):
                raise ValueError(f"proposal_log_pdf must return ({n},) log-densities")
            terms.append(math.log(n_prop / n) + log_g)
        if n_prior:
            log_prior = truncated_normal_logpdf(out, prior_mean, prior_std, self.low,
                                                self.high).sum(axis=1)
            terms.append(math.log(n_prior / n) + log_prior)
        log_q = logsumexp(np.stack(terms), axis=0)
        with np.errstate(invalid="ignore"):
            offset = np.where(np.isneginf(log_p), -np.inf, log_p - log_q)
        return out, offset

    def step(self, log_likelihood: LogLikelihood, *, proposal: Proposal | None = None,
             proposal_log_pdf=None) -> np.ndarray:
        """Process one frame and return the estimate.

        Parameters
        ----------
        log_likelihood : callable
            ``log_likelihood(x (P, D)) -> (P,)`` for this frame's measurements; ``-inf`` marks
            impossible states, ``NaN`` and ``+inf`` are errors.
        proposal, proposal_log_pdf : callable, optional
            This frame's IAPF proposal and its log-density (override the constructor's).

        Returns
        -------
        estimate : (D,) ndarray
            Weighted mean of the last layer's particles.
        """
        if self.particles is None:
            raise RuntimeError("AnnealedParticleFilter.step: call initialise() first")
        proposal = self.proposal if proposal is None else proposal
        proposal_log_pdf = self.proposal_log_pdf if proposal_log_pdf is None else proposal_log_pdf
        n = self._n
        self.step_evaluations = 0
        self.iapf_corrected = False
        ess = np.empty(self._layers)
        betas = np.empty(self._layers)
        weights = Weights(self.log_weights)
        x = self.particles
        for layer in range(self._layers):
            x = x[self._resample(weights.W, n, self.rng)]
            std = self.dynamics.noise_std(x, self.noise_std, layer_scale=self._scales[layer])
            offset = None
            if layer == 0:
                mean = self.dynamics.drift(x, self._history)
                if self.strategy == "iapf":
                    x, offset = self._iapf_layer(x, mean, std, proposal, proposal_log_pdf)
                else:
                    x = truncated_normal(mean, std, self.low, self.high, self.rng)
            else:
                x = truncated_normal(x, std, self.low, self.high, self.rng)
            ll = self._evaluate(log_likelihood, x)
            if self._betas is not None:
                beta = float(self._betas[layer])
            else:
                beta = find_beta(ll, self.survival, offset=offset, beta_max=self.beta_max)
            weights = Weights(tempered_log_weights(ll, beta, offset))
            ess[layer] = weights.ess
            betas[layer] = beta
        self.particles = x
        self.log_weights = np.array(weights.log_w)
        self.log_likelihoods = ll
        self.layer_ess, self.layer_betas = ess, betas
        self.estimate = weighted_sum(weights.W, x)
        best = int(np.argmax(weights.log_w))
        self.map_particle = x[best].copy()
        self.map_log_likelihood = float(ll[best])
        finite = np.isfinite(ll)
        self.mean_log_likelihood = (weighted_sum(weights.W[finite], ll[finite])
                                    if not weights.degenerate and finite.any() else -np.inf)
        self.n_evaluations += self.step_evaluations
        self.frame += 1
        self._history = np.vstack([self._history, self.estimate])[-_HISTORY:]
        return self.estimate.copy()

    def run(self, log_likelihoods: Iterable[LogLikelihood], *, proposals=None,
            callback: Callable[[AnnealedParticleFilter], None] | None = None) -> np.ndarray:
        """Run :meth:`step` over a sequence of frames.

        Parameters
        ----------
        log_likelihoods : iterable of callable
            One log-likelihood per frame.
        proposals : iterable of callable or of (proposal, proposal_log_pdf) pairs, optional
            Per-frame IAPF proposals, aligned with ``log_likelihoods``.
        callback : callable, optional
            Called as ``callback(filter)`` after every step (e.g. to record attributes).

        Returns
        -------
        estimates : (T, D) ndarray
        """
        out = []
        proposals = iter(proposals) if proposals is not None else None
        for fn in log_likelihoods:
            prop, prop_pdf = None, None
            if proposals is not None:
                item = next(proposals)
                prop, prop_pdf = item if isinstance(item, tuple) else (item, None)
            out.append(self.step(fn, proposal=prop, proposal_log_pdf=prop_pdf))
            if callback is not None:
                callback(self)
        return np.array(out).reshape(len(out), self.dim)

    # ------------------------------------------------------------------ checkpointing
    def get_state(self) -> dict:
        """Complete filter state as plain arrays, numbers and dicts (copies).

        Returns
        -------
        state : dict
            ``particles`` (N, D), ``log_weights`` (N,), ``history`` (H, D), ``prior_mean`` and
            ``prior_std`` (D,), ``rng`` (the bit generator's state dict), ``frame``,
            ``n_evaluations``, ``estimate`` (D,) or None, and ``strategy``, ``n_total``, ``dim``
            to detect a mismatched filter on :meth:`set_state`.
        """
        if self.particles is None:
            raise RuntimeError("AnnealedParticleFilter.get_state: call initialise() first")
        return {
            "strategy": self.strategy,
            "n_total": self._n,
            "dim": self.dim,
            "particles": self.particles.copy(),
            "log_weights": self.log_weights.copy(),
            "history": self._history.copy(),
            "prior_mean": self._prior[0].copy(),
            "prior_std": self._prior[1].copy(),
            "rng": copy.deepcopy(self.rng.bit_generator.state),
            "frame": int(self.frame),
            "n_evaluations": int(self.n_evaluations),
            "estimate": None if self.estimate is None else self.estimate.copy(),
        }

    def set_state(self, state: dict) -> None:
        """Restore a state from :meth:`get_state`; continuing then equals an uninterrupted run.

        Raises
        ------
        InputError
            When the state is incomplete or belongs to a differently configured filter.
        """
        keys = ("strategy", "n_total", "dim", "particles", "log_weights", "history",
                "prior_mean", "prior_std", "rng", "frame", "n_evaluations")
        missing = [k for k in keys if k not in state]
        if missing:
            raise InputError("filter state", f"missing {', '.join(missing)}")
        n, d = self._n, self.dim
        if (state["strategy"] != self.strategy or int(state["n_total"]) != n
                or int(state["dim"]) != d):
            raise InputError("filter state", f"made by a {state['strategy']} filter with "
                             f"{state['n_total']} particles in {state['dim']}-D, this filter is "
                             f"{self.strategy} with {n} in {d}-D")
        particles = np.array(state["particles"], dtype=np.float64)
        log_w = np.array(state["log_weights"], dtype=np.float64)
        history = np.array(state["history"], dtype=np.float64).reshape(-1, d)
        if particles.shape != (n, d) or log_w.shape != (n,) or history.shape[0] > _HISTORY:
            raise InputError("filter state", "particles, log_weights or history have wrong shapes")
        try:
            Weights(log_w)
        except ValueError as exc:
            raise InputError("filter state", str(exc)) from None
        try:
            self.rng.bit_generator.state = copy.deepcopy(state["rng"])
        except (TypeError, ValueError, KeyError) as exc:
            raise InputError("filter state", f"random generator state: {exc}") from None
        self.particles, self.log_weights, self._history = particles, log_w, history
        self._prior = (np.array(state["prior_mean"], dtype=np.float64).reshape(d),
                       np.array(state["prior_std"], dtype=np.float64).reshape(d))
        self.log_likelihoods = None
        self._clear_records()
        self.frame = int(state["frame"])
        self.n_evaluations = int(state["n_evaluations"])
        est = state.get("estimate")
        self.estimate = None if est is None else np.array(est, dtype=np.float64).reshape(d)

    def __repr__(self) -> str:
        return (f"AnnealedParticleFilter(n_particles={self.n_particles}, "
                f"n_layers={self.n_layers}, dim={self.dim}, strategy={self.strategy!r}, "
                f"dynamics={self.dynamics!r})")
