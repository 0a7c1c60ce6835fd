"""Recovery: frames without a person, lost tracks, re-initialisation.

Three pieces, all free of file access, that let a track survive what the annealed particle filter
alone cannot (issue 11; Fontmarty et al., paper 004 §III-A and Table I):

* :func:`voxelmocap.pose.proposal.detector_proposal` — the IAPF's importance function: poses
  fitted by inverse kinematics to this frame's extremities (its own module);
* :func:`person_presence` — a frame *has no person* when the largest 26-connected blob of
  occupied voxels holds less than ``min_share`` of the body model's volume (:func:`body_volume`).
  A visual hull contains the body it is carved from, so a person fully inside the volume gives a
  blob of at least about the body's volume (1.0–1.4 × on the rendered clips at 20 mm, minus
  segmentation holes); specks of noise, a shadow or a person half out of the volume give much
  less. 0.3 leaves room for a crouch seen by few cameras and rejects a stray arm or leg.
* :class:`LostTrack` — a track is *lost* after ``patience`` consecutive bad frames; a frame is bad
  when its log-likelihood falls more than ``drop`` below the median of the last ``window`` good
  frames (the scores collapse when the model leaves the voxels: every part fully off them costs
  ``½ · (1/0.1 + 1/0.1) = 10`` log-units for its Empty and Surf terms), or when the mean Empty
  score of the parts exceeds ``empty_max`` (more than that share of the model is on empty space:
  this catches a track that was never right, which has no good reference to fall from). On the
  rendered walk a good track's log-likelihood varies between −11 and −26 (median −14), so a drop
  of 20 for 3 frames is not noise.

:class:`Recovery` ties them to a :class:`~voxelmocap.pose.tracker.BodyTracker`
(``BodyTracker.observe``): absent frames are flagged and not tracked (the record repeats the last
estimate with ``observed = False``), and the track is re-initialised from the voxels when the
person comes back or the track is lost.

>>> import numpy as np
>>> from voxelmocap.body import BodyModel
>>> from voxelmocap.grid import VoxelGrid
>>> grid = VoxelGrid((-1000.0, -1000.0, 0.0), 40.0, (50, 50, 50))
>>> person_presence(np.zeros(grid.shape, bool), grid, BodyModel()).present
False
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage

from .proposal import MixtureProposal, extremities_of

__all__ = ["LostTrack", "Presence", "Recovery", "body_volume", "person_presence"]


# ---------------------------------------------------------------------------- absence
def body_volume(model) -> float:
    """Analytic volume of the body model's parts (mm³), overlaps counted twice."""
    return float(sum(p.volume for p in model.dimensions.parts()))


@dataclass(frozen=True)
class Presence:
    """Whether a frame has a person (:func:`person_presence`).

    Attributes
    ----------
    present : bool
    voxels : int
        Occupied voxels of the largest 26-connected blob.
    needed : float
        The threshold: ``min_share`` × the body's volume in voxels.
    """

    present: bool
    voxels: int
    needed: float


def person_presence(occupancy, grid, model, *, min_share: float = 0.3) -> Presence:
    """Is there a body-sized blob of occupied voxels? (module docstring)

    Parameters
    ----------
    occupancy : (nx, ny, nz) bool array_like
        ``V^R``.
    grid : VoxelGrid
    model : BodyModel
        The body whose volume sets the threshold.
    min_share : float
        Share of the body's volume the largest blob must reach.
    """
    occ = np.asarray(occupancy, dtype=bool)
    needed = min_share * body_volume(model) / float(grid.voxel_size) ** 3
    idx = np.argwhere(occ)
    if len(idx) == 0:
        return Presence(False, 0, needed)
    lo, hi = idx.min(axis=0), idx.max(axis=0) + 1
    box = occ[lo[0]:hi[0], lo[1]:hi[1], lo[2]:hi[2]]
    labels, n = ndimage.label(box, structure=np.ones((3, 3, 3), dtype=bool))
    biggest = int(np.bincount(labels.ravel())[1:].max()) if n else 0
    return Presence(biggest >= needed, biggest, needed)


# ---------------------------------------------------------------------------- lost track
@dataclass
class LostTrack:
    """The lost-track rule over a record history (module docstring), fed one frame at a time.

    Parameters
    ----------
    window : int
        Good frames whose median log-likelihood is the reference.
    drop : float
        A frame is bad when its log-likelihood is more than this below the reference.
    empty_max : float
        ... or when the mean Empty score of its parts is above this.
    patience : int
        Consecutive bad frames that make the track lost.
    min_reference : int
        Good frames needed before the drop criterion applies.
    """

    window: int = 30
    drop: float = 20.0
    empty_max: float = 0.5
    patience: int = 3
    min_reference: int = 5
    good: list = field(default_factory=list)
    bad_run: int = 0

    def bad(self, log_likelihood: float, part_scores) -> bool:
        """Whether one frame is bad against the current reference (no update)."""
        empty = float(np.mean(np.asarray(part_scores, dtype=float)[:, 2]))
        if empty > self.empty_max:
            return True
        if len(self.good) >= self.min_reference:
            return log_likelihood < float(np.median(self.good[-self.window:])) - self.drop
        return False

    def update(self, log_likelihood: float, part_scores) -> bool:
        """Add a frame; True when the track is lost (``patience`` bad frames in a row)."""
        if self.bad(log_likelihood, part_scores):
            self.bad_run += 1
        else:
            self.bad_run = 0
            self.good.append(float(log_likelihood))
            del self.good[:-self.window]
        return self.bad_run >= self.patience

    def reset(self) -> None:
        """Forget the history (after a re-initialisation or an absence)."""
        self.good.clear()
        self.bad_run = 0

    def get_state(self) -> dict:
        return {"good": np.asarray(self.good, dtype=float), "bad_run": int(self.bad_run)}

    def set_state(self, state: dict) -> None:
        self.good = [float(v) for v in np.asarray(state["good"], dtype=float).ravel()]
        self.bad_run = int(state["bad_run"])


# ---------------------------------------------------------------------------- tracker glue
class Recovery:
    """Absence flags, lost-track detection and re-initialisation around a body tracker.

    :meth:`voxelmocap.pose.tracker.BodyTracker.observe` delegates here (``config.recovery``). Per frame:

    1. :func:`person_presence`; without a person the filter is *not* stepped and
       ``BodyTracker.absent_record`` is returned (the last estimate, ``observed = False``);
    2. with a person after an absence, or after the lost-track rule fired, the filter starts
       again from the voxels (:meth:`reinitialise`) and the record's ``note`` says so;
    3. the filter steps (with the detector proposal when the strategy is ``iapf``), and the
       record feeds :class:`LostTrack`; when it fires, the next frame re-initialises.

    Parameters
    ----------
    tracker : voxelmocap.pose.tracker.BodyTracker

    Attributes
    ----------
    events : list of (int, str)
        Frames where the track was re-initialised, and why.
    """

    def __init__(self, tracker):
        rc = tracker.config.recovery
        self.tracker = tracker
        self.config = rc
        self.lost = LostTrack(window=rc.lost_window, drop=rc.lost_drop, empty_max=rc.lost_empty,
                              patience=rc.lost_patience)
        self.absent = False
        self.pending: str | None = None
        self.last_state: np.ndarray | None = None
        self.events: list[tuple[int, str]] = []

    def presence(self, observation) -> Presence:
        return person_presence(observation.occupancy, observation.grid, self.tracker.model,
                               min_share=self.config.min_volume_share)

    def step(self, observation, *, frame: int):
        """One frame with recovery: a :class:`~voxelmocap.pose.records.FrameRecord`."""
        import dataclasses

        t0 = time.perf_counter()
        tracker = self.tracker
        if not self.presence(observation).present:
            self.absent = True
            self.lost.reset()
            state = self.last_state
            if state is None:
                state = (tracker.filter.estimate if tracker.filter.estimate is not None
                         else tracker.model.default_state())
            return tracker.absent_record(observation, tracker.model.clip(state[None])[0],
                                         frame=frame, seconds=time.perf_counter() - t0)
        note = ""
        reason = ("the person is back in view" if self.absent and self.last_state is not None
                  else self.pending)
        if reason is not None or not tracker.initialised:
            phrase = self.reinitialise(observation, frame=frame)
            note = f"re-initialised ({reason or 'first frame with a person'}): {phrase}"
            self.events.append((int(frame), note))
        self.absent, self.pending = False, None
        record = tracker.step(observation, frame=frame)
        if (self.lost.update(tracker.lost_track_value(record), record.part_scores)
                and self.config.reinitialise):
            self.pending = (f"track lost at frame {int(frame)}: {self.lost.patience} frames of "
                            "collapsed scores")
            self.lost.reset()
        self.last_state = record.state
        return dataclasses.replace(record, note=note) if note else record

    def reinitialise(self, observation, *, frame: int) -> str:
        """Start the filter again from this frame's voxels; returns how.

        The candidates are the extremity hypotheses of :func:`voxelmocap.pose.initialise.initial_pose`
        and, when there is one, the last estimate moved horizontally onto the voxels (a person
        who walked out and back in often comes back in much the same pose). With
        ``init.limb_sweep`` their limbs are searched over their ranges
        (:meth:`~voxelmocap.pose.tracker.BodyTracker.searched_starts`), as at the first start. All
        are ranked by the likelihood; the filter starts from a mixture of the
        ``init.hypotheses`` best, and this frame's IAPF proposal is that mixture too.
        """
        from .initialise import initial_pose

        tracker = self.tracker
        model = tracker.model
        ex = extremities_of(observation)
        ll = tracker.log_likelihood(observation)
        n = tracker.config.init.hypotheses
        states, how = initial_pose(ex, model, ll, n_best=max(n, 1))
        states = np.atleast_2d(states)
        from_last = np.zeros(len(states), bool)   # which candidate is the moved last estimate
        if self.last_state is not None:
            last = self.last_state.copy()
            centre = observation.grid.centre_of(np.argwhere(observation.occupancy)).mean(axis=0)
            pelvis = model.forward(last[None]).joints[0, 1]  # row 1 is the pelvis
            last[:2] += centre[:2] - pelvis[:2]
            candidates = np.concatenate([states, model.clip(last[None])])
            from_last = np.append(from_last, True)
            order = np.argsort(-ll(candidates), kind="stable")[:max(n, 1)]
            states, from_last = candidates[order], from_last[order]
        searched = ""
        if tracker.config.init.limb_sweep:
            # as at the first start: an extremity fit leaves a limb it found no tip for
            # hanging, and the annealing does not swing it up again (docs/benchmarks.md)
            states, n_moved = tracker.searched_starts(observation, states)
            order = np.argsort(-ll(states), kind="stable")
            states, from_last = states[order], from_last[order]
            searched = f"; limbs searched over their ranges ({n_moved} moved)"
        if from_last[0]:
            how = "the last estimate moved onto the voxels"
        how += searched
        phrase = f"the voxels of frame {int(frame)}: {how}"
        tracker.start(phrase, states if len(states) > 1 else states[0])
        tracker.pending_proposal = MixtureProposal(
            states, tracker.config.recovery.proposal_spread * tracker.noise_std, model.low,
            model.high)
        return phrase

    def get_state(self) -> dict:
        """What a checkpoint needs to resume the recovery exactly (plain arrays and numbers)."""
        return {"recovery_good": np.asarray(self.lost.good, dtype=float),
                "recovery_bad_run": int(self.lost.bad_run), "recovery_absent": bool(self.absent),
                "recovery_pending": self.pending or "",
                "recovery_last_state": (np.full(0, np.nan) if self.last_state is None
                                        else np.asarray(self.last_state, dtype=float))}

    def set_state(self, state: dict) -> None:
        """Restore :meth:`get_state` (keys absent from older checkpoints keep their defaults)."""
        if "recovery_good" not in state:
            return
        self.lost.set_state({"good": state["recovery_good"],
                             "bad_run": state["recovery_bad_run"]})
        self.absent = bool(state["recovery_absent"])
        self.pending = str(state["recovery_pending"]) or None
        last = np.asarray(state["recovery_last_state"], dtype=float)
        self.last_state = last if last.size else None
