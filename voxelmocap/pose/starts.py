"""Where a track starts: the ground truth, a search over the voxels, or several starts at once.

* :func:`ground_truth_landmarks`: a frame's true landmarks, when the data set has them;
* :func:`initial_state_from_voxels`: a standing pose at the voxels' centre, facing the best of
  a ring of headings (``[init] method = "voxels"``); the extremity fit of
  :mod:`voxelmocap.pose.initialise` is the default;
* :class:`MultiStart`: several starting poses tracked side by side for the first frames; the
  likeliest one goes on (a mirrored pose scores about as well as the right one on one frame).
"""

from __future__ import annotations

import numpy as np

from ..config import TrackConfig
from .records import FrameRecord

__all__ = ["GROUND_TRUTH_START", "MultiStart", "ground_truth_landmarks",
           "initial_state_from_voxels"]

#: How :meth:`BodyTracker.initial_state <voxelmocap.pose.tracker.BodyTracker.initial_state>`
#: names a start from the ground truth.
GROUND_TRUTH_START = "the ground truth"


def ground_truth_landmarks(gt, frame: int) -> np.ndarray | None:
    """A frame's true landmarks ``(15, 3)`` (mm) for :meth:`BodyTracker.initialise`.

    Parameters
    ----------
    gt : voxelmocap.io.body_pose_xml.BodyPoseSequence or None
        The sequence's ground truth.
    frame : int
        Synchronised frame number.

    Returns
    -------
    (15, 3) ndarray or None
        None when there is no ground truth, the frame is not in it, or an endpoint is disabled.
    """
    from ..joints import endpoints_to_landmarks

    if gt is None:
        return None
    row = int(gt.index_of([frame])[0])
    if row < 0 or not bool(gt.enabled[row].all()):
        return None
    return endpoints_to_landmarks(gt.endpoints[row])


def initial_state_from_voxels(measurement, model, variances, *, n_yaw: int = 36,
                              coverage: float = 0.0) -> np.ndarray:
    """A standing pose at the voxel blob's centroid, facing the best of ``n_yaw`` headings.

    Parameters
    ----------
    measurement : voxelmocap.score.likelihood.Measurement
        The first frame.
    model : BodyModel
    variances : (4,) sequence of float
        The likelihood's σ².
    n_yaw : int
        Headings tried, evenly spread over the full turn.
    coverage : float
        Weight of the likelihood's coverage term.

    Returns
    -------
    (27,) ndarray

    Raises
    ------
    InputError
        When the frame has no occupied voxel.
    """
    from ..score.likelihood import log_likelihood

    occ = measurement.occupancy
    idx = np.argwhere(occ)
    if len(idx) == 0:
        from ..measure.observation import no_voxels

        raise no_voxels("first frame", "initialise from the voxels")
    centre = measurement.grid.centre_of(idx).mean(axis=0)
    base = model.default_state()
    base[0], base[1] = centre[0], centre[1]
    yaw_i = list(model.state_names).index("root_yaw")
    candidates = np.repeat(base[None], n_yaw, axis=0)
    candidates[:, yaw_i] = np.linspace(-np.pi, np.pi, n_yaw, endpoint=False)
    scores = log_likelihood(measurement, model, candidates, variances=variances,
                            coverage=coverage)
    return candidates[int(np.argmax(scores))]


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
    """

    def __init__(self, model, config: TrackConfig, seed: int, states, frames: int, *,
                 noise_std=None):
        self.frames = int(frames)
        from .tracker import BodyTracker

        self.trackers: list[BodyTracker] = []
        for k, state in enumerate(np.atleast_2d(np.asarray(states, dtype=float))):
            tracker = BodyTracker(model, config, seed=np.random.default_rng([int(seed), k]),
                                  noise_std=noise_std)
            tracker.start("multi-start", state)
            self.trackers.append(tracker)
        self.records: list[list[FrameRecord]] = [[] for _ in self.trackers]
        #: each start's filter state after each frame, so that the kept start's frames can be
        #: written with their checkpoints (a run killed while writing them resumes exactly)
        self.checkpoints: list[list[dict]] = [[] for _ in self.trackers]
        self.chosen: int | None = None

    def step(self, observation, *, frame: int | None = None) -> list[FrameRecord] | None:
        """Step every start; after ``frames`` frames, the chosen start's records (else None)."""
        for tracker, records, states in zip(self.trackers, self.records, self.checkpoints,
                                            strict=True):
            records.append(tracker.step(observation, frame=frame))
            states.append(tracker.get_state())
        return self.finish() if len(self.records[0]) >= self.frames else None

    @property
    def totals(self) -> list[float]:
        """Each start's summed log-likelihood over the frames tracked so far."""
        return [sum(r.log_likelihood for r in records) for records in self.records]

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
