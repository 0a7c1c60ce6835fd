"""Motion models for the particle filter's prediction step.

Overview
--------
A dynamics model describes ``p(x_k | x_{k-1})`` as a Gaussian per particle, truncated by the filter
to the state bounds: it returns the deterministic part (:meth:`drift`, a ``(P, D)`` array of means)
and the per-particle noise (:meth:`noise_std`, ``(P, D)`` standard deviations) given the particles
of the previous frame, the history of the filter's estimates, and the base noise ``(D,)``. The
filter applies the drift once per frame (first annealing layer) and the noise in every layer, scaled
down layer by layer. Models know nothing about bodies: the state dimensions they act on are given
as indices.

* :class:`RandomWalk`: ``x_k = x_{k-1} + ω`` (paper 002 eq. 10, paper 004 Table II).
* :class:`VelocityModel`: Azad et al.'s ``s_k = s_{k-1} + A (s̄_{k-1} - s̄_{k-2}) + B ω`` with
  ``A = 0.7 I`` (paper 000 eqs 14-15), ``s̄`` being the filter's last two estimates.
* :class:`TwoStateElbow`: Azad et al.'s two-state model (paper 000 §4.4, eq. 16): the velocity
  model, but while a particle's elbow angle is within ``threshold`` of straight (0.2 rad), the noise
  on the matching shoulder twist is ``singular_std`` (0.4 rad) instead of the base noise.

Models are looked up by name in :data:`DYNAMICS` (the configuration's ``filter.dynamics``; the
body tracker builds them with ``voxelmocap.pose.filter_setup.build_dynamics``).

>>> import numpy as np
>>> m = VelocityModel(0.7)
>>> m.drift(np.zeros((1, 2)), np.array([[0.0, 0.0], [1.0, -2.0]]))
array([[ 0.7, -1.4]])
"""

from __future__ import annotations

import numpy as np

__all__ = ["DYNAMICS", "Dynamics", "RandomWalk", "TwoStateElbow", "VelocityModel"]


class Dynamics:
    """Base class: a Gaussian motion model ``N(drift(x), diag(noise_std(x)²))`` per particle."""

    def drift(self, particles: np.ndarray, history: np.ndarray) -> np.ndarray:
        """Means of the predicted states.

        Parameters
        ----------
        particles : (P, D) ndarray
            States at frame ``k-1``.
        history : (H, D) ndarray
            The filter's previous estimates, oldest first (``H`` may be 0).

        Returns
        -------
        mean : (P, D) ndarray
        """
        return np.array(particles, dtype=np.float64)

    def noise_std(
        self, particles: np.ndarray, base_std: np.ndarray, *, layer_scale: float = 1.0
    ) -> np.ndarray:
        """Standard deviations of the prediction noise.

        Parameters
        ----------
        particles : (P, D) ndarray
            States the noise is added to (the model may depend on them).
        base_std : (D,) ndarray
            The filter's base noise, in state units.
        layer_scale : float
            Multiplier of every standard deviation for the current annealing layer.

        Returns
        -------
        std : (P, D) ndarray
        """
        std = np.asarray(base_std, dtype=np.float64) * float(layer_scale)
        return np.broadcast_to(std, np.shape(particles)).copy()

    def __repr__(self) -> str:
        fields = ", ".join(f"{k}={v!r}" for k, v in vars(self).items())
        return f"{type(self).__name__}({fields})"


class RandomWalk(Dynamics):
    """Gaussian random walk ``x_k = x_{k-1} + ω``, ``ω ~ N(0, diag(base_std²))``."""


class VelocityModel(Dynamics):
    """Azad et al.'s constant-velocity drift (paper 000 eq. 14).

    Parameters
    ----------
    factor : float
        The diagonal of ``A`` (0.7 in paper 000 eq. 15), in ``[0, 1]``.
    indices : sequence of int, optional
        State dimensions that receive the drift; all when None (e.g. leave out angles that wrap).

    Notes
    -----
    ``drift = x + factor · (s̄_{k-1} - s̄_{k-2})`` where ``s̄`` are the last two estimates; with fewer
    than two estimates the velocity is taken as zero.
    """

    def __init__(self, factor: float = 0.7, indices=None):
        if not 0.0 <= factor <= 1.0:  # > 1 would amplify the velocity frame after frame
            raise ValueError(f"{type(self).__name__}: factor must be in [0, 1], got {factor}")
        self.factor = float(factor)
        self.indices = None if indices is None else np.asarray(indices, dtype=np.intp)

    def velocity(self, history: np.ndarray, dim: int) -> np.ndarray:
        """``factor · (s̄_{k-1} - s̄_{k-2})`` restricted to :attr:`indices`, shape ``(D,)``."""
        v = np.zeros(dim)
        history = np.asarray(history, dtype=np.float64)
        if history.ndim == 2 and history.shape[0] >= 2:
            step = history[-1] - history[-2]
            sel = slice(None) if self.indices is None else self.indices
            v[sel] = self.factor * step[sel]
        return v

    def drift(self, particles, history):
        particles = np.asarray(particles, dtype=np.float64)
        return particles + self.velocity(history, particles.shape[1])


class TwoStateElbow(VelocityModel):
    """Azad et al.'s two-state elbow model (paper 000 §4.4, eq. 16) on top of the velocity model.

    Parameters
    ----------
    twist_indices : sequence of int
        State index of each shoulder's rotation about the upper-arm axis (θ_s).
    elbow_indices : sequence of int
        State index of the matching elbow flexion angle (θ_e), same length, radians.
    threshold : float
        φ: the elbow counts as "nearly straight" while ``|θ_e| < threshold`` (0.2 rad).
    singular_std : float
        β̂: noise standard deviation on θ_s in that state (0.4 rad), replacing the base noise.
    factor : float
        Velocity factor (``A = factor · I``); 0 gives a random walk with the two-state noise.
    indices : sequence of int, optional
        Dimensions receiving the velocity drift (all when None).

    Notes
    -----
    The state is decided per particle from its elbow angle at frame ``k-1`` (the particle being
    propagated). In later annealing layers the same rule applies to the layer's (smaller) noise:
    the singular noise is scaled like the base noise.
    """

    def __init__(self, twist_indices, elbow_indices, *, threshold: float = 0.2,
                 singular_std: float = 0.4, factor: float = 0.7, indices=None):
        super().__init__(factor, indices)
        self.twist_indices = np.atleast_1d(np.asarray(twist_indices, dtype=np.intp))
        self.elbow_indices = np.atleast_1d(np.asarray(elbow_indices, dtype=np.intp))
        if self.twist_indices.shape != self.elbow_indices.shape:
            raise ValueError("TwoStateElbow: twist_indices and elbow_indices differ in length")
        if not threshold >= 0 or not singular_std >= 0:
            raise ValueError("TwoStateElbow: threshold and singular_std must be >= 0")
        self.threshold = float(threshold)
        self.singular_std = float(singular_std)

    def noise_std(self, particles, base_std, *, layer_scale: float = 1.0):
        """Base noise, ``singular_std`` on θ_s where the elbow is straight; all × layer_scale."""
        particles = np.asarray(particles, dtype=np.float64)
        std = super().noise_std(particles, base_std, layer_scale=layer_scale)
        straight = np.abs(particles[:, self.elbow_indices]) < self.threshold  # (P, n_arms)
        std[:, self.twist_indices] = np.where(
            straight, self.singular_std * layer_scale, std[:, self.twist_indices]
        )
        return std


DYNAMICS: dict[str, type[Dynamics]] = {
    "random_walk": RandomWalk,
    "velocity": VelocityModel,
    "elbow": TwoStateElbow,
}
"""Dynamics models by configuration name."""
