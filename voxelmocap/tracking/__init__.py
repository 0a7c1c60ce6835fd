"""Particle filtering core: annealed particle filter, truncated Gaussians, resampling, dynamics.

Knows nothing about bodies, voxels or files: the filter sees an opaque ``D``-dimensional state with
bounds, a dynamics model and a per-frame log-likelihood callable ``(P, D) -> (P,)``.

Modules: :mod:`.truncated` (exact truncated-Gaussian sampling), :mod:`.resampling` (log-weights,
resampling schemes by name), :mod:`.annealing` (β by bisection, fixed schedules, layer noise),
:mod:`.dynamics` (random walk, Azad's velocity and two-state elbow models), :mod:`.apf`
(:class:`AnnealedParticleFilter` with strategies ``sir``, ``apf``, ``iapf``), :mod:`.partitioned`
(the hierarchical search, :class:`PartitionedParticleFilter`) and :mod:`.refine` (compass search).

>>> import numpy as np
>>> from voxelmocap.tracking import AnnealedParticleFilter
>>> f = AnnealedParticleFilter(100, 3, [-5.0], [5.0], 0.5, rng=1)
>>> f.initialise([0.0], 1.0)
>>> f.step(lambda x: -0.5 * (x[:, 0] - 2.0) ** 2 / 0.2**2).shape
(1,)
"""

from .annealing import (
    FONTMARTY_ALPHAS,
    FONTMARTY_BETAS,
    ess_fraction,
    find_beta,
    layer_noise_scales,
    tempered_log_weights,
)
from .apf import STRATEGIES, AnnealedParticleFilter, check_options
from .dynamics import DYNAMICS, Dynamics, RandomWalk, TwoStateElbow, VelocityModel
from .partitioned import SEARCHES, Partition, PartitionedParticleFilter
from .resampling import SCHEMES, Weights, get_scheme, systematic
from .truncated import truncated_normal, truncated_normal_logpdf

__all__ = [
    "DYNAMICS",
    "FONTMARTY_ALPHAS",
    "FONTMARTY_BETAS",
    "SCHEMES",
    "SEARCHES",
    "STRATEGIES",
    "AnnealedParticleFilter",
    "Dynamics",
    "Partition",
    "PartitionedParticleFilter",
    "RandomWalk",
    "TwoStateElbow",
    "VelocityModel",
    "Weights",
    "check_options",
    "ess_fraction",
    "find_beta",
    "get_scheme",
    "layer_noise_scales",
    "systematic",
    "tempered_log_weights",
    "truncated_normal",
    "truncated_normal_logpdf",
]
