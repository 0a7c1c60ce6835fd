"""How the body tracker's filter is built from a config: noise, dynamics, filter, layers.

:func:`build_filter` assembles the annealed particle filter of :mod:`voxelmocap.tracking` (or the
hierarchical one, partition by partition) over the body model's legal ranges, with the noise
profile of :func:`noise_profile` and the motion model of :func:`build_dynamics`. The filter itself
knows nothing of bodies; this module is where the body's dimensions meet its options.
"""

from __future__ import annotations

import numpy as np

from ..config import FilterConfig, TrackConfig

__all__ = ["REFERENCE_RATE", "TRUNK_ANGLES", "annealing_layers", "build_dynamics", "build_filter",
           "noise_profile", "searches_hierarchically"]

#: The frame rate (Hz) the ``[filter]`` noise settings are stated at.
REFERENCE_RATE = 60.0

#: Trunk angles that get the root rotation's noise, not the limbs' (see :func:`noise_profile`).
TRUNK_ANGLES = ("waist_flex", "waist_side", "waist_twist", "neck_flex", "neck_side")


def noise_profile(model, config: TrackConfig, frame_rate: float = REFERENCE_RATE) -> np.ndarray:
    """(27,) per-frame propagation noise (mm, rad): translation, root rotation and joint groups.

    The settings are per frame at :data:`REFERENCE_RATE`; at another ``frame_rate`` (Hz) they
    scale by ``REFERENCE_RATE / frame_rate``: the noise must reach as far as the body moves
    between two frames, and a smooth motion moves in proportion to the time between them (at
    30 Hz twice as far as at 60), so a recording at another rate is searched alike.

    The root, waist and neck angles get ``rotation_std_rad``; shoulders, elbows, hips and knees
    ``joint_std_rad``. The trunk moves as slowly as the root, and the pelvis orientation is nearly
    unobservable (no part spans the pelvis), so a compensating root pitch + waist flexion + hip
    flexion change costs almost nothing in the likelihood. With the limbs' larger noise on the
    waist the filter random-walked along that direction (root pitch −40°, waist +44° after 6
    frames of a walk) and lost the legs. Measured with ``scripts/study_tracking.py`` (a one-off
    study, removed; in git before 4253368) (synthetic, 7 cameras, 6 × 300 particles,
    ``joint_std_rad`` 0.1): trunk on the limbs' noise → on the root's: walk μ 58 → 59 mm
    (5 seeds, no change), jog 67 → 60 mm, box 68 → 56 mm (3 seeds);
    ``docs/benchmarks.md``, tracking accuracy study.
    """
    fc = config.filter
    std = np.full(model.n_dims, fc.joint_std_rad)
    std[:3] = fc.translation_std_mm
    std[3:6] = fc.rotation_std_rad
    names = list(model.state_names)
    std[[names.index(n) for n in TRUNK_ANGLES]] = fc.rotation_std_rad
    if frame_rate != REFERENCE_RATE:
        if not (np.isfinite(frame_rate) and frame_rate > 0):
            raise ValueError(f"frame_rate must be a finite number > 0, got {frame_rate!r}")
        std *= REFERENCE_RATE / float(frame_rate)
    return std


def build_dynamics(model, fc: FilterConfig):
    """The motion model named by ``fc.dynamics`` (:data:`voxelmocap.tracking.DYNAMICS`).

    The velocity drift applies to every state dimension (heading included: the estimates it is
    taken from never jump across ±π within a frame or two of a walk).
    """
    from ..tracking import DYNAMICS, TwoStateElbow, VelocityModel

    cls = DYNAMICS[fc.dynamics]
    kwargs = {}
    if issubclass(cls, VelocityModel):
        kwargs["factor"] = fc.velocity_factor
    if issubclass(cls, TwoStateElbow):
        names = list(model.state_names)
        kwargs.update(twist_indices=[names.index("l_shoulder_rot"), names.index("r_shoulder_rot")],
                      elbow_indices=[names.index("l_elbow"), names.index("r_elbow")],
                      threshold=fc.elbow_threshold_rad, singular_std=fc.elbow_singular_std_rad)
    return cls(**kwargs)


def build_filter(model, config: TrackConfig, rng, *, noise_std=None):
    """The annealed particle filter of a config, over the body model's legal ranges.

    Parameters
    ----------
    model : BodyModel
    config : TrackConfig
        ``config.filter`` is used.
    rng : numpy.random.Generator or int
        The filter's generator (or its seed).
    noise_std : (27,) array_like, optional
        Propagation noise; default :func:`noise_profile`.
    """
    from ..tracking import AnnealedParticleFilter

    fc = config.filter
    noise = noise_profile(model, config) if noise_std is None else noise_std
    if searches_hierarchically(config):
        from ..tracking.partitioned import PartitionedParticleFilter
        from .hierarchy import body_partitions

        opts = fc.filter_options()
        return PartitionedParticleFilter(
            body_partitions(fc), model.low, model.high, noise, rng=rng,
            survival=opts["survival"], noise_decay=opts["noise_decay"],
            dynamics=build_dynamics(model, fc), resampling=opts["resampling"],
            beta_max=opts["beta_max"], refine_evaluations=fc.refine_evaluations,
            explore=fc.limb_explore)
    return AnnealedParticleFilter(
        fc.particles, fc.layers, model.low, model.high, noise, strategy=fc.strategy, rng=rng,
        dynamics=build_dynamics(model, fc), **fc.filter_options())


def searches_hierarchically(config: TrackConfig) -> bool:
    """Whether the filter searches partition by partition: ``filter.search = "hierarchical"``
    with the ``apf`` strategy and the voxel likelihood at weight 1 (a limb is scored by
    re-scoring its two cones; other cues are added evaluated on the whole state). Without the
    voxel cue, and with the other strategies, the search is over all dimensions at once."""
    fc = config.filter
    return (fc.search == "hierarchical" and fc.strategy == "apf"
            and dict(config.cues.weights).get("voxel") == 1.0)


def annealing_layers(config: TrackConfig) -> int:
    """Layers per frame of the filter a config builds (one ESS and β each in a record)."""
    fc = config.filter
    if fc.strategy == "sir":
        return 1
    if searches_hierarchically(config):
        from .hierarchy import body_partitions

        return sum(p.layers for p in body_partitions(fc))
    return fc.layers
