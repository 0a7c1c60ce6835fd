"""Several starting poses tracked side by side for the first frames; the likeliest goes on.

On one frame a mirrored pose (facing the other way) scores about as well as the right one; a few
frames of motion tell them apart. :class:`MultiStart` runs one
:class:`~voxelmocap.pose.tracker.BodyTracker` per start and keeps the likeliest after
``[init] multistart_frames``.
"""

from __future__ import annotations

import numpy as np

from ..config import TrackConfig
from .filter_setup import REFERENCE_RATE
from .records import FrameRecord
from .tracker import BodyTracker

__all__ = ["MultiStart"]


class MultiStart:
    """Several starting poses tracked side by side for the first frames; the likeliest goes on.

    Within one frame the annealing collapses a mixture of starting poses onto whichever scores
    best on that frame, and far from the truth a mirrored pose (facing the other way) scores
    about as well as the right one. Tracking each start separately for a few frames lets the
    motion tell them apart: the start whose summed log-likelihood over those frames is highest
    is kept, with the records of its first frames.

    Parameters
    ----------
    model : BodyModel
    config : TrackConfig
    seed : int
        Start ``k`` uses ``numpy.random.default_rng([seed, k])``.
    states : (K, 27) array_like
        The starting poses.
    frames : int
        Frames to track before choosing.
    noise_std : (27,) array_like, optional
        As for :class:`BodyTracker`.
    frame_rate : float
        As for :class:`BodyTracker` (Hz, default 60).
    """

    def __init__(self, model, config: TrackConfig, seed: int, states, frames: int, *,
                 noise_std=None, frame_rate: float = REFERENCE_RATE):
        self.frames = int(frames)
        self.trackers: list[BodyTracker] = []
        for k, state in enumerate(np.atleast_2d(np.asarray(states, dtype=float))):
            tracker = BodyTracker(model, config, seed=np.random.default_rng([int(seed), k]),
                                  noise_std=noise_std, frame_rate=frame_rate)
            tracker.start("multi-start", state)
            self.trackers.append(tracker)
        self.records: list[list[FrameRecord]] = [[] for _ in self.trackers]
        #: each start's filter state after each frame, so that the kept start's frames can be
        #: written with their checkpoints (a run killed while writing them resumes exactly)
        self.checkpoints: list[list[dict]] = [[] for _ in self.trackers]
        #: each start's summed facing evidence (``[filter] facing_weight`` > 0 only)
        self.evidence = np.zeros(len(self.trackers))
        self.weight = float(config.filter.facing_weight)
        self.model = model
        self.chosen: int | None = None

    def step(self, observation, *, frame: int | None = None) -> list[FrameRecord] | None:
        """Step every start; after ``frames`` frames, the chosen start's records (else None)."""
        for tracker, records, states in zip(self.trackers, self.records, self.checkpoints,
                                            strict=True):
            records.append(tracker.step(observation, frame=frame))
            states.append(tracker.get_state())
        if self.weight:
            from .facing import facing_evidence

            now = np.stack([records[-1].state for records in self.records])
            self.evidence += facing_evidence(observation, self.model, now)
        return self.finish() if len(self.records[0]) >= self.frames else None

    @property
    def totals(self) -> list[float]:
        """Each start's summed log-likelihood over the frames tracked so far, plus
        ``facing_weight`` × its summed facing evidence."""
        totals = [sum(r.log_likelihood for r in records) for records in self.records]
        if self.weight:
            totals = [t + self.weight * float(e) for t, e in zip(totals, self.evidence,
                                                                 strict=True)]
        return totals

    def finish(self) -> list[FrameRecord]:
        """Choose now (e.g. the sequence ended early): the records of the likeliest start."""
        self.chosen = int(np.argmax(self.totals))
        return self.records[self.chosen]

    @property
    def tracker(self):
        """The chosen start's :class:`~voxelmocap.pose.tracker.BodyTracker` (after
        :meth:`finish`)."""
        if self.chosen is None:
            raise RuntimeError("MultiStart.tracker: no start chosen yet")
        return self.trackers[self.chosen]
