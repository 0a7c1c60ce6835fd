"""The detector proposal: the IAPF's importance function from this frame's extremities.

:func:`detector_proposal` is ``q(x_k | x_{k-1}, z_k)`` of Fontmarty et al.'s IAPF (paper 004
§III-A): a Gaussian mixture (truncated to the legal ranges) around poses fitted by inverse
kinematics to *this* frame's extremities (:func:`voxelmocap.measure.detect.find_extremities`).
While tracking it is cheap: the previous estimate is the warm start, each tip is labelled with
the body end (head, wrists, ankles) it is nearest to, and only the chains that end there move (a
damped Gauss–Newton fit with a batched finite-difference Jacobian, a few milliseconds).
Optionally a second component labels the hands and feet the other way round (left ↔ right); off
by default, it let a wrong side win on a jog (``docs/benchmarks.md``). Without a previous
estimate the mixture is built around the best hypotheses of
:func:`voxelmocap.pose.initialise.initial_pose` (seconds: only when a track starts again).
:mod:`.recovery` uses it when a track starts again; the tracker every frame with
``strategy = "iapf"``.
"""

from __future__ import annotations

import math
import time
import weakref

import numpy as np
from scipy.optimize import linear_sum_assignment

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
from ..portable import dot, logsumexp, matmul
from ..tracking.truncated import truncated_normal, truncated_normal_logpdf
from .initialise import ANKLE_SHARE, FOOT_SHARE, HAND_SHARE, PRIOR_MM_PER_RAD

__all__ = ["MixtureProposal", "detector_proposal", "extremities_of"]

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
        return logsumexp(per, axis=0) - math.log(len(self.means))


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
    cost = dot(r, r)
    for _ in range(iterations):
        X = np.repeat(x[None], len(free) + 1, axis=0)
        X[np.arange(1, len(free) + 1), free] += h
        R = residuals(X)
        J = (R[1:] - R[0]).T / h  # (m, n_free)
        A = matmul(J.T, J)
        g = matmul(J.T, R[0])
        step = np.linalg.solve(A + damping * (np.diag(np.diag(A)) + 1e-9 * np.eye(len(free))), -g)
        cand = x.copy()
        cand[free] = np.clip(x[free] + step, low, high)
        rc = residuals(cand[None])[0]
        cc = dot(rc, rc)
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
