"""The body's partitions for the hierarchical search, and their likelihoods.

The state splits into four groups whose effect on the voxels can be scored apart (Deutscher &
Reid 2005; Canton-Ferrer et al. 2011): the root, trunk and head (11 dimensions; they move every
part, so this partition is scored in full), then both legs together (hip 3 + knee each), then
each arm (shoulder 3 + elbow), which moves only its two cones. The legs are searched as a pair:
searched one after the other, the first leg was scored against the second one's estimate of the
previous frame, and in a walk the legs pass each other, so that stale leg's double occupancy
pushed the first one away (the built-in demo's walk: 108–110 mm with the legs apart, 40–44 mm
together; docs/benchmarks.md). The legs go first: they hold more voxels than the arms and pin
the pelvis height and heading the arms hang from.
A limb's particles are scored by :class:`~voxelmocap.score.partial.PartialScorer`, equal to
the full likelihood, at the cost of their own cones (two for an arm, four for the legs) instead
of ten.

>>> [len(d) for d, _ in BODY_PARTITIONS]
[11, 8, 4, 4]
"""

from __future__ import annotations

import numpy as np

from ..body.shapes import PART_NAMES
from ..body.state import STATE_INDEX
from ..tracking.partitioned import Partition

__all__ = ["BODY_PARTITIONS", "LIMBS", "body_partitions", "log_likelihood_for", "pitch_prior"]


def _dims(*names):
    return tuple(STATE_INDEX[n] for n in names)


def _parts(*names):
    return tuple(PART_NAMES.index(n) for n in names)


def _limb(prefix: str, joint: str, bend: str, upper: str, lower: str):
    return (_dims(*(f"{prefix}_{joint}_{a}" for a in ("flex", "abd", "rot")), f"{prefix}_{bend}"),
            _parts(f"{prefix}_{upper}", f"{prefix}_{lower}"))


#: name → (its four state dimensions, its two parts): the limbs of the hierarchical search and
#: of the global limb search (:mod:`voxelmocap.pose.limb_search`), legs first.
LIMBS: dict[str, tuple[tuple[int, ...], tuple[int, ...]]] = {
    "l_leg": _limb("l", "hip", "knee", "thigh", "shin"),
    "r_leg": _limb("r", "hip", "knee", "thigh", "shin"),
    "l_arm": _limb("l", "shoulder", "elbow", "upper_arm", "forearm"),
    "r_arm": _limb("r", "shoulder", "elbow", "upper_arm", "forearm"),
}

#: (dimensions, parts they move) of each partition, in search order; parts ``()`` = all.
BODY_PARTITIONS: tuple[tuple[tuple[int, ...], tuple[int, ...]], ...] = (
    (_dims("root_x", "root_y", "root_z", "root_yaw", "root_pitch", "root_roll", "waist_flex",
           "waist_side", "waist_twist", "neck_flex", "neck_side"), ()),
    (LIMBS["l_leg"][0] + LIMBS["r_leg"][0], LIMBS["l_leg"][1] + LIMBS["r_leg"][1]),
    LIMBS["l_arm"],
    LIMBS["r_arm"],
)


def body_partitions(fc) -> list[Partition]:
    """The filter's partitions from a ``FilterConfig``.

    Sizes left None spend the joint search's budget (``FilterConfig.trunk_layers``): the trunk
    ``layers // 2`` layers of ``particles``, each arm ``layers // 3`` layers of ``3/8`` of them,
    the leg pair as many layers of twice as many particles (``limb_particles`` is per limb).

    >>> from voxelmocap.config import FilterConfig
    >>> [(len(p.dims), p.layers, p.particles) for p in body_partitions(FilterConfig())][:2]
    [(11, 3, 600), (8, 2, 450)]
    """
    def size(value, default):
        return int(default) if value is None else int(value)

    trunk = Partition(BODY_PARTITIONS[0][0], size(fc.trunk_layers, max(1, fc.layers // 2)),
                      size(fc.trunk_particles, fc.particles))
    limb_layers = size(fc.limb_layers, max(1, fc.layers // 3))
    limb_particles = size(fc.limb_particles, max(2, round(3 * fc.particles / 8)))
    return [trunk] + [Partition(dims, limb_layers, limb_particles * (len(dims) // 4))
                      for dims, _ in BODY_PARTITIONS[1:]]


def pitch_prior(states, std_deg: float | None) -> np.ndarray | float:
    """Log-density (up to a constant) of a zero-mean Gaussian prior on the root pitch."""
    if std_deg is None:
        return 0.0
    pitch = np.asarray(states)[:, STATE_INDEX["root_pitch"]]
    return -0.5 * (pitch / np.deg2rad(std_deg)) ** 2


def log_likelihood_for(observation, model, variances, prior_deg, k: int, reference, *,
                       coverage: float = 0.0):
    """Partition ``k``'s log-likelihood callable ``(P, 27) -> (P,)`` around ``reference``.

    Partition 0 is scored in full; the legs and each arm with :class:`PartialScorer` built on
    ``reference`` (the same values at the cost of their own cones).
    The root-pitch prior (:func:`pitch_prior`) is added to both; ``coverage`` weighs the
    likelihood's coverage term (:func:`voxelmocap.score.likelihood.coverage_log_likelihood`).
    """
    from ..score.likelihood import log_likelihood
    from ..score.partial import PartialScorer

    dims, parts = BODY_PARTITIONS[k]
    if not parts:
        def ll(states):
            return log_likelihood(observation, model, states, variances=variances,
                                  coverage=coverage) + pitch_prior(states, prior_deg)
        return ll
    scorer = PartialScorer(observation, model, reference, parts, dims)

    def ll_partial(states):
        return scorer.log_likelihood(states, variances=variances, coverage=coverage) + \
            pitch_prior(states, prior_deg)
    return ll_partial
