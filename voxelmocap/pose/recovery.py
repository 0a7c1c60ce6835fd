"""Recovery: detector proposals for the IAPF, frames without a person, lost tracks.

Three pieces, all free of file access, that let a track survive what the annealed particle filter
alone cannot (issue 11; Fontmarty et al., paper 004 §III-A and Table I):

* :func:`detector_proposal` — the IAPF's importance function ``q(x_k | x_{k-1}, z_k)``: a Gaussian
  mixture (truncated to the legal ranges) around poses fitted by inverse kinematics to *this*
  frame's extremities (:func:`voxelmocap.measure.detect.find_extremities`). While tracking it is cheap:
  the previous estimate is the warm start, each tip is labelled with the body end (head, wrists,
  ankles) it is nearest to, and only the chains that end there move (a damped Gauss–Newton fit
  with a batched finite-difference Jacobian, a few milliseconds). Optionally a second component
  labels the hands and feet the other way round (left ↔ right); off by default, it let a wrong
  side win on a jog (``docs/benchmarks.md``). Without a
  previous estimate the mixture is built around the best hypotheses of
  :func:`voxelmocap.pose.initialise.initial_pose` (seconds: only when a track starts again).
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
import weakref
from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage
from scipy.optimize import linear_sum_assignment
from scipy.special import logsumexp

from ..body.kinematics import (
    HEAD_TOP,
    L_ANKLE,
    L_ELBOW,
    L_WRIST,
    R_ANKLE,
    R_ELBOW,
    R_WRIST,
    forward_kinematics,
)
from ..tracking.truncated import truncated_normal, truncated_normal_logpdf
from .initialise import ANKLE_SHARE, FOOT_SHARE, HAND_SHARE, PRIOR_MM_PER_RAD

__all__ = [
    "LostTrack",
    "MixtureProposal",
    "Presence",
    "Recovery",
    "body_volume",
    "detector_proposal",
    "person_presence",
]

#: The body ends a tip can be labelled with, and the state values that move each one.
_ENDS = (HEAD_TOP, L_WRIST, R_WRIST, L_ANKLE, R_ANKLE)
_CHAIN_NAMES = {
    HEAD_TOP: ("neck_flex", "neck_side"),
    L_WRIST: ("l_shoulder_flex", "l_shoulder_abd", "l_shoulder_rot", "l_elbow"),
    R_WRIST: ("r_shoulder_flex", "r_shoulder_abd", "r_shoulder_rot", "r_elbow"),
    L_ANKLE: ("l_hip_flex", "l_hip_abd", "l_hip_rot", "l_knee"),
    R_ANKLE: ("r_hip_flex", "r_hip_abd", "r_hip_rot", "r_knee"),
}
_ELBOW = {L_WRIST: L_ELBOW, R_WRIST: R_ELBOW}
_MIRROR = {HEAD_TOP: HEAD_TOP, L_WRIST: R_WRIST, R_WRIST: L_WRIST, L_ANKLE: R_ANKLE,
           R_ANKLE: L_ANKLE}


# ---------------------------------------------------------------------------- the proposal
#: Extremities of the observations seen lately: the detector is most of a proposal's cost
#: (≈ 90 %), and the starts of a ``MultiStart`` and a re-initialisation share one observation.
_EXTREMITIES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def extremities_of(observation):
    """:func:`voxelmocap.measure.detect.find_extremities` of an observation, computed once per object."""
    from ..measure.detect import find_extremities

    try:
        return _EXTREMITIES[observation]
    except (KeyError, TypeError):
        pass
    ex = find_extremities(observation.occupancy, observation.grid)
    try:
        _EXTREMITIES[observation] = ex
    except TypeError:  # not weak-referenceable: no cache
        pass
    return ex


class MixtureProposal:
    """Equal-weight mixture of Gaussians truncated to ``[low, high]``, diagonal, one shared std.

    Unpacks as the filter's pair: ``proposal, proposal_log_pdf = MixtureProposal(...)``.

    Parameters
    ----------
    means : (K, D) array_like
        Component centres (clipped into the bounds).
    std : (D,) array_like
        Standard deviation of every component (> 0).
    low, high : (D,) array_like
        Bounds, ``low < high``.

    Attributes
    ----------
    means : (K, D) ndarray
    std, low, high : (D,) ndarray
    labels : list of str
        What each component is (set by :func:`detector_proposal`).
    seconds : float
        Time spent building it (detection and fits).
    """

    def __init__(self, means, std, low, high):
        self.low = np.asarray(low, dtype=float).ravel()
        self.high = np.asarray(high, dtype=float).ravel()
        self.means = np.clip(np.atleast_2d(np.asarray(means, dtype=float)), self.low, self.high)
        self.std = np.broadcast_to(np.asarray(std, dtype=float), self.low.shape).copy()
        if self.means.shape[1] != self.low.size or len(self.means) == 0:
            raise ValueError(f"means must be (K, {self.low.size}) with K >= 1")
        if np.any(~(self.std > 0)) or np.any(~np.isfinite(self.std)):
            raise ValueError("std must be finite and > 0")
        self.labels: list[str] = [f"component {k}" for k in range(len(self.means))]
        self.seconds = 0.0

    def __iter__(self):
        return iter((self.sample, self.log_pdf))

    def __len__(self) -> int:
        return len(self.means)

    def sample(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """``(n, D)`` draws: a uniformly chosen component, then its truncated Gaussian."""
        comp = rng.integers(len(self.means), size=int(n))
        return truncated_normal(self.means[comp], self.std, self.low, self.high, rng)

    def log_pdf(self, x) -> np.ndarray:
        """``(n,)`` log-density of ``x`` (n, D) under the mixture (``-inf`` outside the bounds)."""
        x = np.atleast_2d(np.asarray(x, dtype=float))
        per = np.stack([truncated_normal_logpdf(x, m, self.std, self.low, self.high).sum(axis=1)
                        for m in self.means])
        return logsumexp(per, axis=0) - np.log(len(self.means))


def _to_segment(points, a, b):
    """``(..., 3)`` vectors from the closest points of segments [a, b] to ``points``."""
    ab = b - a
    t = np.clip(np.sum((points - a) * ab, axis=-1) / np.maximum(np.sum(ab * ab, axis=-1), 1e-12),
                0.0, 1.0)
    return points - (a + t[..., None] * ab)


def _reach(model, joints, rows, tips, yaw):
    """``(P, E, 3)``: each tip from the reachable extension of its end (see ``initialise._fit``).

    ``joints`` (P, 15, 3), ``rows`` E joint rows, ``tips`` (E, 3), ``yaw`` (P,). The head top must
    be on its tip; a wrist within a hand's length before it along the forearm; an ankle on the
    foot (forward along the heading, down to the floor).
    """
    height = float(model.dimensions.height)
    out = np.empty((joints.shape[0], len(rows), 3))
    facing = np.stack([-np.sin(yaw), np.cos(yaw), np.zeros_like(yaw)], axis=1)
    for e, (row, tip) in enumerate(zip(rows, tips, strict=True)):
        j = joints[:, row]
        if row == HEAD_TOP:
            out[:, e] = tip - j
        elif row in _ELBOW:
            d = j - joints[:, _ELBOW[row]]
            d = d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-9)
            out[:, e] = _to_segment(tip, j, j + HAND_SHARE * height * d)
        else:
            foot = j + FOOT_SHARE * height * facing - np.array([0.0, 0.0, ANKLE_SHARE * height])
            out[:, e] = _to_segment(tip, j, foot)
    return out


def _fit_ends(model, x0, rows, tips, *, iterations: int = 8) -> np.ndarray:
    """Move only the chains of ``rows`` so that their ends reach ``tips``; the rest stays ``x0``.

    Damped Gauss–Newton (Levenberg–Marquardt) with a forward-difference Jacobian evaluated in one
    batched forward-kinematics call per iteration, bounds by projection, and a pull towards ``x0``
    (:data:`voxelmocap.pose.initialise.PRIOR_MM_PER_RAD`) that settles what the tips leave free.
    """
    names = list(model.state_names)
    free = np.array([names.index(n) for r in rows for n in _CHAIN_NAMES[r]], dtype=int)
    if len(free) == 0:
        return x0.copy()
    low, high = model.low[free], model.high[free]
    dims = model.dimensions
    tips = np.asarray(tips, dtype=float)

    def residuals(X):
        joints = forward_kinematics(X, dims).joints
        r = _reach(model, joints, rows, tips, X[:, 3]).reshape(len(X), -1)
        return np.concatenate([r, PRIOR_MM_PER_RAD * (X[:, free] - x0[free])], axis=1)

    x = x0.copy()
    h = 1e-5
    damping = 1e-3
    r = residuals(x[None])[0]
    cost = float(r @ r)
    for _ in range(iterations):
        X = np.repeat(x[None], len(free) + 1, axis=0)
        X[np.arange(1, len(free) + 1), free] += h
        R = residuals(X)
        J = (R[1:] - R[0]).T / h  # (m, n_free)
        A = J.T @ J
        g = J.T @ R[0]
        step = np.linalg.solve(A + damping * (np.diag(np.diag(A)) + 1e-9 * np.eye(len(free))), -g)
        cand = x.copy()
        cand[free] = np.clip(x[free] + step, low, high)
        rc = residuals(cand[None])[0]
        cc = float(rc @ rc)
        if cc < cost:
            x, cost, damping = cand, cc, damping * 0.3
        else:
            damping *= 10.0
        if np.abs(step).max() < 1e-4:
            break
    return x


def _label(model, state, tips, gate_mm: float):
    """Tip → end assignment minimising the summed reach distance (Hungarian), gated."""
    joints = forward_kinematics(state[None], model.dimensions).joints
    cost = np.stack([np.linalg.norm(_reach(model, joints, [row] * len(tips), tips,
                                           state[None, 3])[0], axis=1) for row in _ENDS], axis=1)
    ti, ei = linear_sum_assignment(cost)
    keep = cost[ti, ei] <= gate_mm
    return [_ENDS[e] for e in ei[keep]], tips[ti[keep]]


def detector_proposal(observation, model, *, std, previous=None, log_likelihood=None,
                      extremities=None, gate_mm: float = 400.0, mirror: bool = False,
                      n_best: int = 4, iterations: int = 8) -> MixtureProposal:
    """The IAPF importance function of one frame, built from its detected extremities.

    Parameters
    ----------
    observation : voxelmocap.measure.observation.VoxelObservation
        This frame.
    model : BodyModel
    std : float or (27,) array_like
        Spread of every mixture component (mm, rad; e.g. the propagation noise).
    previous : (27,) array_like, optional
        The previous estimate: warm start and labels of the tips (see the module docstring).
    log_likelihood : callable, optional
        ``(P, 27) → (P,)`` of this frame; needed without ``previous`` (ranks the hypotheses of
        :func:`voxelmocap.pose.initialise.initial_pose`).
    extremities : Extremities, optional
        This frame's extremities if already found (else :func:`extremities_of`).
    gate_mm : float
        A tip farther than this from every end's reach is not used (a ghost or a bump).
    mirror : bool
        Add the left ↔ right relabelled fit as a second component.
    n_best : int
        Components without ``previous`` (the best distinct hypotheses).
    iterations : int
        Gauss–Newton iterations of a warm-started fit.

    Returns
    -------
    MixtureProposal
        Centred on ``previous`` alone when nothing is detected.
    """
    t0 = time.perf_counter()
    ex = extremities if extremities is not None else extremities_of(observation)
    if previous is None:
        if ex is None or log_likelihood is None:
            raise ValueError("detector_proposal: without a previous estimate it needs a person "
                             "in view and the frame's log_likelihood")
        from .initialise import initial_pose

        states, how = initial_pose(ex, model, log_likelihood, n_best=max(int(n_best), 2))
        mix = MixtureProposal(np.atleast_2d(states), std, model.low, model.high)
        mix.labels = [how] + [f"hypothesis {k + 2}" for k in range(len(mix) - 1)]
        mix.seconds = time.perf_counter() - t0
        return mix
    prev = model.clip(np.asarray(previous, dtype=float)[None])[0]
    means, labels = [prev], ["previous estimate"]
    if ex is not None and len(ex.points):
        # The trunk stays where the filter put it: the deepest voxel (the extremities' centre)
        # is off the model's trunk axis by ~100 mm on a walk, and moving the trunk there made
        # the fits worse (mean landmark error 78 → 113 mm before the limbs moved).
        warm = prev
        rows, tips = _label(model, warm, np.asarray(ex.points, float), gate_mm)
        if rows:
            means = [_fit_ends(model, warm, rows, tips, iterations=iterations)]
            labels = [f"fit of {len(rows)} tips"]
            swapped = [_MIRROR[r] for r in rows]
            if mirror and swapped != rows and len(set(swapped)) == len(swapped):
                means.append(_fit_ends(model, warm, swapped, tips, iterations=iterations))
                labels.append("left/right swapped fit")
    mix = MixtureProposal(np.array(means), std, model.low, model.high)
    mix.labels = labels
    mix.seconds = time.perf_counter() - t0
    return mix


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
