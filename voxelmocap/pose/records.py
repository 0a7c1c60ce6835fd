"""What the body tracker says about a frame: :class:`FrameRecord`, and observers of records.

A :class:`FrameRecord` is everything one tracked frame produced (estimate, MAP particle,
landmarks, endpoints, part scores, ESS and β per layer, timing, confidence, presence); the runner
writes it, studies collect it. Observers, in the spirit of the ``particles`` library's
collectors, are callables ``observer(record, tracker)`` called after every step
(:class:`Collector` stacks chosen record fields). :func:`absent_record` is the record of a frame
without a person, where nothing was tracked.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

__all__ = ["Collector", "FrameRecord", "Observer", "absent_record"]


@dataclass(frozen=True)
class FrameRecord:
    """What one tracked frame produced (the estimate is clipped into the model's legal ranges).

    Attributes
    ----------
    frame : int
        Synchronised 1-based frame number.
    state : (27,) ndarray
        The estimate: weighted mean of the last annealing layer (mm, rad).
    map_state : (27,) ndarray
        The particle of largest last-layer weight (not clipped; it is a particle).
    landmarks : (15, 3) ndarray
        Landmarks of ``state`` (mm) in ``voxelmocap.joints.LANDMARK_NAMES`` order.
    endpoints : (20, 3) ndarray
        ``body_pose`` endpoints of ``state`` (mm) in ``ENDPOINT_NAMES`` order.
    part_scores : (n_parts, 4) ndarray
        Out, DO, Empty, Surf of every part of ``state``.
    ess, betas : (L,) ndarray
        Effective sample size and likelihood exponent of each annealing layer.
    seconds : float
        Wall time of :meth:`BodyTracker.step` (the runner stores the whole frame's instead,
        measurement included).
    log_likelihood : float
        Log-likelihood of ``state`` under the selected cues (voxel only: from ``part_scores``).
    likelihood_seconds : float
        The part of ``seconds`` spent in the filter's likelihood evaluations.
    landmark_spread : (15,) ndarray
        Weighted RMS distance (mm) of each landmark over the particles of every partition's
        last layer (:func:`voxelmocap.pose.confidence.searched_spread`); NaN when unknown.
    confidence : (15,) ndarray
        Each landmark's confidence in [0, 1] (:func:`voxelmocap.pose.confidence.landmark_confidence`
        of the spread and ``part_scores``); NaN when unknown.
    observed : bool
        False for a frame without a person (``voxelmocap.pose.recovery``): the filter did not step
        and the estimate repeats the last one; evaluations skip such frames.
    note : str
        What happened besides tracking, e.g. a re-initialisation (empty when nothing did).
    """

    frame: int
    state: np.ndarray
    map_state: np.ndarray
    landmarks: np.ndarray
    endpoints: np.ndarray
    part_scores: np.ndarray
    ess: np.ndarray
    betas: np.ndarray
    seconds: float
    log_likelihood: float
    likelihood_seconds: float = 0.0
    landmark_spread: np.ndarray = field(default_factory=lambda: np.full(15, np.nan))
    confidence: np.ndarray = field(default_factory=lambda: np.full(15, np.nan))
    observed: bool = True
    note: str = ""


Observer = Callable[[FrameRecord, object], None]


class Collector:
    """An observer that keeps chosen fields of every record, e.g. ``Collector("state")``.

    >>> c = Collector("frame", "log_likelihood")
    >>> c.stacked()["frame"].shape
    (0,)
    """

    def __init__(self, *fields: str):
        unknown = [f for f in fields if f not in FrameRecord.__dataclass_fields__]
        if unknown:
            raise ValueError(f"Collector: FrameRecord has no field {unknown[0]!r}")
        self.fields = fields or tuple(FrameRecord.__dataclass_fields__)
        self.values: dict[str, list] = {f: [] for f in self.fields}

    def __call__(self, record: FrameRecord, tracker) -> None:
        for f in self.fields:
            self.values[f].append(getattr(record, f))

    def stacked(self) -> dict[str, np.ndarray]:
        """Each field's values stacked along a new first axis (frames)."""
        return {f: np.array(v) for f, v in self.values.items()}


def absent_record(model, observation, state, *, frame: int, n_layers: int, variances,
                  seconds: float = 0.0) -> FrameRecord:
    """The record of a frame without a person (``voxelmocap.pose.recovery``): nothing was tracked.

    It repeats ``state`` (the last estimate, or wherever the track will start) so that every
    export stays a valid pose, with ``observed = False``; ESS and β are NaN (no filter step).
    """
    from ..body import joints_to_endpoints
    from ..score.likelihood import log_likelihood_from_scores, part_scores

    state = np.asarray(state, dtype=float)
    joints = model.forward(state[None]).joints
    scores = part_scores(observation, model, state[None])[0]
    return FrameRecord(
        frame=int(frame), state=state.copy(), map_state=state.copy(), landmarks=joints[0],
        endpoints=joints_to_endpoints(joints)[0], part_scores=scores,
        ess=np.full(n_layers, np.nan), betas=np.full(n_layers, np.nan), seconds=seconds,
        log_likelihood=float(log_likelihood_from_scores(scores, variances=variances)),
        observed=False, note="no person in view")
