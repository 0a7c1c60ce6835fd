"""Partitioned (hierarchical) annealing: search the state one group of dimensions at a time.

Deutscher & Reid (2005) partition the state of an articulated body so that each annealing layer
searches a few dimensions whose effect the likelihood can see on its own; Canton-Ferrer et al.
(2011) do the same on voxels, torso first, then each limb. :class:`PartitionedParticleFilter`
runs, per frame, the partitions in order. Partition 0 keeps each particle's own values in the
other dimensions (its likelihood is evaluated in full). Every later partition ``k`` holds all
dimensions outside its own at the estimate reached so far (the *reference*), so that the caller
can score its particles by re-scoring only what its dimensions move
(:class:`voxelmocap.score.partial.PartialScorer` for a limb): the caller supplies
``log_likelihood_for(k, reference) -> callable``.

Within a partition: resample (to the partition's particle count), propagate its dimensions (layer
1: the dynamics' drift and noise; later layers: the noise scaled by
:func:`.annealing.layer_noise_scales`), evaluate, weight by ``exp(β ll)`` with β for an ESS of
``survival · N``. Its estimate is the weighted mean of its dimensions in its last layer; an
optional deterministic pattern search (:func:`.refine.pattern_search`) then improves it with a
few evaluations. Like the joint filter, it sees no body: only dimension indices and callables.

>>> import numpy as np
>>> target = np.array([1.0, -2.0, 0.5])
>>> def ll_for(k, ref):
...     return lambda x: -0.5 * np.sum((x - target) ** 2, axis=1) / 0.1**2
>>> f = PartitionedParticleFilter([Partition((0,), 3, 100), Partition((1, 2), 3, 100)],
...                               -5 * np.ones(3), 5 * np.ones(3), 0.5, rng=0)
>>> f.initialise(np.zeros(3), 1.0)
>>> bool(np.all(np.abs(f.step_partitioned(ll_for) - target) < 0.3))
True
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import NamedTuple

import numpy as np

from ..errors import InputError
from ..portable import weighted_sum
from .annealing import find_beta, layer_noise_scales, tempered_log_weights
from .apf import _HISTORY, AnnealedParticleFilter
from .refine import pattern_search
from .resampling import Weights
from .truncated import truncated_normal

__all__ = ["SEARCHES", "Partition", "PartitionedParticleFilter"]

#: Names of the search of ``FilterConfig.search``: every dimension at once, or partition by partition.
SEARCHES = ("joint", "hierarchical")


class Partition(NamedTuple):
    """One group of the hierarchical search: its dimensions, layers and particles per layer."""

    dims: tuple[int, ...]
    layers: int
    particles: int


LikelihoodFactory = Callable[[int, np.ndarray], Callable[[np.ndarray], np.ndarray]]


class PartitionedParticleFilter(AnnealedParticleFilter):
    """Annealed particle filter searching one partition of the state after another.

    Parameters
    ----------
    partitions : sequence of Partition
        Disjoint groups covering every dimension, searched in this order.
    low, high, noise_std, rng, survival, noise_decay, dynamics, resampling, beta_max
        As for :class:`~.apf.AnnealedParticleFilter`.
    refine_evaluations : int
        Likelihood evaluations of the pattern search after each partition (0: no refinement).
    explore : float
        Share of the first layer's particles of every partition after the first drawn uniformly
        over the partition's legal box (0: none).

    Notes
    -----
    The particle set kept between frames has ``max(p.particles)`` particles (the last
    partition's, resampled); ``layer_ess`` / ``layer_betas`` list every layer of every partition
    in order. :meth:`step` (the joint search of the parent class) is not available.
    """

    def __init__(self, partitions: Sequence[Partition], low, high, noise_std, *, rng=None,
                 survival: float = 0.5, noise_decay: float = 0.5, dynamics=None,
                 resampling: str = "systematic", beta_max: float = np.inf,
                 refine_evaluations: int = 0, explore: float = 0.0):
        parts = [Partition(tuple(int(d) for d in p.dims), int(p.layers), int(p.particles))
                 for p in partitions]
        if not parts:
            raise InputError("partitions", "need at least one partition")
        n_keep = max(p.particles for p in parts)
        super().__init__(n_keep, sum(p.layers for p in parts), low, high, noise_std,
                         strategy="apf", rng=rng, survival=survival, noise_decay=noise_decay,
                         dynamics=dynamics, resampling=resampling, beta_max=beta_max)
        dims = [d for p in parts for d in p.dims]
        if sorted(dims) != list(range(self.dim)):
            raise InputError("partitions", f"must cover dimensions 0…{self.dim - 1} exactly once")
        for p in parts:
            if p.layers < 1 or p.particles < 2:
                raise InputError("partitions", f"{p}: need layers >= 1 and particles >= 2")
        if int(refine_evaluations) < 0:
            raise InputError("refine_evaluations", "must be >= 0")
        self.partitions = parts
        self.noise_decay = float(noise_decay)
        self.refine_evaluations = int(refine_evaluations)
        if not 0.0 <= float(explore) < 1.0 or (explore > 0 and not (
                np.all(np.isfinite(self.low)) and np.all(np.isfinite(self.high)))):
            raise InputError("explore", "must be in [0, 1), with finite bounds when > 0")
        self.explore = float(explore)
        self._proposal, self._proposal_share = None, 0.0
        self.refine_gains = np.zeros(len(parts))

    @property
    def searched(self) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """Each partition's last layer in the last step: ``[(dims, particles (P_k, K), W)]``.

        A partition's particles differ only in its own dimensions (the others are shared), so
        the last layer of the whole step (:attr:`particles`) says nothing of how sure the earlier
        partitions were; these do, one partition each.
        """
        return list(self._searched)

    def _clear_records(self):
        super()._clear_records()
        self._searched = []

    def move_estimate(self, state, *, keep_motion: bool = True) -> None:
        """As :meth:`.apf.AnnealedParticleFilter.move_estimate`; each partition's last layer
        (:attr:`searched`) moves by the same offset, so the spread is measured where the limb
        now is."""
        delta = None if self.estimate is None else np.asarray(state, dtype=float) - self.estimate
        super().move_estimate(state, keep_motion=keep_motion)
        self._searched = [(dims, np.clip(own + delta[dims], self.low[dims], self.high[dims]), w)
                          for dims, own, w in self._searched]

    def step(self, log_likelihood, **kwargs):
        raise RuntimeError("PartitionedParticleFilter: call step_partitioned(log_likelihood_for)")

    def step_partitioned(self, log_likelihood_for: LikelihoodFactory, *, proposal=None,
                         proposal_share: float = 0.0) -> np.ndarray:
        """Process one frame; returns the estimate ``(D,)``.

        Parameters
        ----------
        log_likelihood_for : callable
            ``log_likelihood_for(k, reference (D,)) -> ll``, where ``ll((P, D)) -> (P,)`` scores
            partition ``k``'s particles. For ``k = 0`` the particles differ in every dimension;
            for ``k > 0`` they equal ``reference`` outside partition ``k``.
        proposal : callable, optional
            ``proposal(n, rng) -> (n, D)``: an importance function of this frame (e.g. a
            detector's, :class:`voxelmocap.pose.proposal.MixtureProposal`). ``proposal_share`` of the
            first layer's particles of every partition after the first take their partition's
            dimensions from it (the IAPF's mixing, Fontmarty et al. Table I, without the
            importance correction), so that a limb the dynamics lost can jump back.
        proposal_share : float
            In [0, 1); 0 uses no proposal.
        """
        if not 0.0 <= float(proposal_share) < 1.0:
            raise InputError("proposal_share", "must be in [0, 1)")
        self._proposal = proposal if proposal_share > 0 else None
        self._proposal_share = float(proposal_share)
        if self.particles is None:
            raise RuntimeError("PartitionedParticleFilter.step_partitioned: initialise() first")
        self.step_evaluations = 0
        n_layers = sum(p.layers for p in self.partitions)
        ess, betas = np.empty(n_layers), np.empty(n_layers)
        w = Weights(self.log_weights)
        x = self.particles
        reference = weighted_sum(w.W, x) if self.estimate is None else self.estimate.copy()
        map_state = reference.copy()
        pos = 0
        self.refine_gains = np.zeros(len(self.partitions))
        searched = []
        for k, part in enumerate(self.partitions):
            dims = np.asarray(part.dims)
            ll = log_likelihood_for(k, reference.copy())
            # Partition k > 0 starts from the previous frame's values of its own dimensions,
            # each particle's (resampled with the weights reached so far), the rest shared.
            if k > 0:
                own = x[:, dims].copy()
                x = np.repeat(reference[None], x.shape[0], axis=0)
                x[:, dims] = own
            x, w, lls = self._anneal_partition(k, part, x, w, ll, ess, betas, pos)
            searched.append((dims, x[:, dims], w.W))
            pos += part.layers
            reference[dims] = weighted_sum(w.W, x[:, dims])
            best = int(np.argmax(w.log_w))
            map_state[dims] = x[best, dims]
            if self.refine_evaluations:
                reference[dims] = self._refine(ll, reference, map_state, dims, k)
        n = self._n
        if x.shape[0] != n:
            idx = self._resample(w.W, n, self.rng)
            x, lls = x[idx], lls[idx]
            w = Weights(np.zeros(n))
        self.particles = x
        self.log_weights = np.array(w.log_w)
        self.log_likelihoods = lls
        self.layer_ess, self.layer_betas = ess, betas
        self._searched = searched
        self.estimate = reference
        self.map_particle = map_state
        best = int(np.argmax(w.log_w))
        self.map_log_likelihood = float(lls[best])
        finite = np.isfinite(lls)
        self.mean_log_likelihood = (weighted_sum(w.W[finite], lls[finite])
                                    if not w.degenerate and finite.any() else -np.inf)
        self.n_evaluations += self.step_evaluations
        self.frame += 1
        self._history = np.vstack([self._history, self.estimate])[-_HISTORY:]
        return self.estimate.copy()

    def _refine(self, ll, reference, map_state, dims, k):
        """Compass search on ``dims`` from the better of the mean and the MAP (both composed
        with ``reference``); returns the refined values of ``dims``."""
        starts = np.repeat(reference[None], 2, axis=0)
        starts[1, dims] = map_state[dims]
        f = self._evaluate(ll, starts)
        i = int(np.argmax(f))
        budget = max(self.refine_evaluations - 2, 0)
        refined, f1, used = pattern_search(ll, starts[i], dims, 0.5 * self.noise_std[dims],
                                           low=self.low, high=self.high,
                                           max_evaluations=budget, f0=float(f[i]))
        self.step_evaluations += used
        self.refine_gains[k] = f1 - float(f[0])
        return refined[dims]

    def _anneal_partition(self, k, part, x, w, ll, ess, betas, pos):
        """The layers of partition ``k`` (see the module docstring)."""
        dims = np.asarray(part.dims)
        scales = layer_noise_scales(part.layers, noise_decay=self.noise_decay)
        lo, hi = self.low[dims], self.high[dims]
        lls = None
        for layer in range(part.layers):
            x = x[self._resample(w.W, part.particles, self.rng)]
            std = self.dynamics.noise_std(x, self.noise_std, layer_scale=scales[layer])[:, dims]
            centre = (self.dynamics.drift(x, self._history) if layer == 0 else x)[:, dims]
            x = x.copy()
            x[:, dims] = truncated_normal(centre, std, lo, hi, self.rng)
            if layer == 0 and k > 0:
                # a share drawn over the whole legal box of this partition: a few dimensions
                # are small enough to search globally, so a limb stuck in a local optimum can
                # jump to a better one; and a share from the frame's proposal
                self._substitute(x, dims, self.explore,
                                 lambda n: self.rng.uniform(lo, hi, (n, dims.size)))
                if self._proposal is not None:
                    self._substitute(x, dims, self._proposal_share, lambda n: np.clip(
                        self._proposal(n, self.rng)[:, dims], lo, hi))
            lls = self._evaluate(ll, x)
            beta = find_beta(lls, self.survival, beta_max=self.beta_max)
            w = Weights(tempered_log_weights(lls, beta))
            ess[pos + layer], betas[pos + layer] = w.ess, beta
        return x, w, lls

    def _substitute(self, x, dims, share, draw) -> None:
        """Replace ``dims`` of ``round(share · P)`` random particles of ``x`` (P, D) in place
        by ``draw(n)`` (n, len(dims))."""
        n = round(share * x.shape[0])
        if n:
            idx = self.rng.choice(x.shape[0], n, replace=False)
            x[np.ix_(idx, dims)] = draw(n)

    def __repr__(self) -> str:
        groups = ", ".join(f"{len(p.dims)}d×{p.layers}×{p.particles}" for p in self.partitions)
        return (f"PartitionedParticleFilter([{groups}], refine={self.refine_evaluations}, "
                f"dynamics={self.dynamics!r})")
