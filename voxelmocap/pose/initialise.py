"""Starting a track without being handed the answer: body size and pose from the voxels.

Every real recording starts without ground truth and without a body file. This module turns the
first frames' voxels into a body model and a starting pose, with nothing but the voxels and the
likelihood:

* :func:`estimate_height` — the standing height from the vertical extent of the person's voxels
  over the first frames (median, so a raised arm or a crouch in one frame does not decide it);
  :meth:`BodyModel.scaled <voxelmocap.body.BodyModel.scaled>` then scales the average adult's
  proportions to it.
* :func:`pose_hypotheses` — from the geodesic extremities (:mod:`voxelmocap.measure.detect`): the two
  lowest tips are the feet, one of the tips above the trunk is the head, the others are hands;
  which side is left follows from the facing, and facings come from the line between the feet,
  the line between the hands and a coarse ring of headings. Each labelling is fitted by bounded
  least squares (ends on the tips, a weak pull of every angle towards the neutral pose for the
  angles the tips leave free).
* :func:`initial_pose` — the hypotheses (plus the standing pose at the voxels' centre facing each
  of 36 headings, the old initialisation, so the new one can only win on likelihood) scored with
  the likelihood; the best is the start.

The body model's ends are joints (wrists, ankles), the voxels' are finger and toe tips: a wrist
reaches its tip when the tip lies within a hand's length beyond it along the forearm, an ankle
when the tip lies on the foot (forward and down from it); a cone body's tips, at the joints,
fit as well. The filter's first frame does the rest.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from ..body.kinematics import (
    HEAD_TOP,
    L_ANKLE,
    L_WRIST,
    PELVIS,
    R_ANKLE,
    R_WRIST,
    forward_kinematics,
)
from ..measure.detect import Extremities
from ..portable import atan2, dot, matmul, norm

__all__ = ["Hypothesis", "estimate_height", "initial_pose", "pose_hypotheses"]

#: Hand length (wrist → finger tip) and floor → ankle height as shares of the standing height
#: (anthropometric averages; Drillis & Contini 1966: hand 0.108, ankle 0.039).
HAND_SHARE = 0.10
ANKLE_SHARE = 0.04
#: Heel-less foot length (ankle → toe tip, horizontally) as a share of the height (≈ 0.11).
FOOT_SHARE = 0.11
#: Weight of the pull of the joint angles towards 0 (per radian, against millimetres).
PRIOR_MM_PER_RAD = 40.0


@dataclass(frozen=True)
class Hypothesis:
    """One labelled, fitted starting pose.

    Attributes
    ----------
    state : (27,) float ndarray
        Legal state (mm, rad).
    label : str
        What was assumed (which tip is the head, the facing).
    cost : float
        Least-squares cost of the fit (mm²).
    """

    state: np.ndarray
    label: str
    cost: float


def estimate_height(extremities: list[Extremities | None]) -> float | None:
    """Standing height (mm): the median vertical extent of the person's voxels over frames.

    Parameters
    ----------
    extremities : list of Extremities or None
        :func:`voxelmocap.measure.detect.find_extremities` of the first frames (None: nothing occupied).

    Returns
    -------
    float or None
        None when no frame had a person.
    """
    extents = [e.height_mm for e in extremities if e is not None]
    return float(np.median(extents)) if extents else None


def _yaw_of_facing(facing: np.ndarray) -> float:
    # Facing at yaw ψ is Rz(ψ)·(0, 1, 0) = (−sin ψ, cos ψ, 0).
    return atan2(-facing[0], facing[1])


def _right_of(yaw: float) -> np.ndarray:
    return np.array([np.cos(yaw), np.sin(yaw), 0.0])


def _candidate_yaws(feet: np.ndarray, hands: np.ndarray, n_ring: int) -> list[float]:
    # The line between the feet (hands) is across the body: facing is one of its two normals.
    # The last stage of the fit frees the heading, so a ring of headings is only the fallback.
    yaws: list[float] = []
    for pair in (feet, hands):
        if len(pair) == 2:
            lateral = (pair[1] - pair[0]) * np.array([1.0, 1.0, 0.0])
            if norm(lateral) > 1e-6:
                facing = np.cross([0.0, 0.0, 1.0], lateral)
                yaws += [_yaw_of_facing(facing), _yaw_of_facing(-facing)]
    return yaws or list(np.linspace(-np.pi, np.pi, n_ring, endpoint=False))


def _to_segment(point, a, b):
    """Vector from the closest point of segment [a, b] to ``point`` (3,)."""
    ab = b - a
    t = min(max(dot(point - a, ab) / max(dot(ab, ab), 1e-12), 0.0), 1.0)
    return point - (a + t * ab)


#: State indices of the trunk (root translation, pitch, roll, waist, neck; the heading is given
#: by the hypothesis) and of each limb chain, with the joint row of the limb's end.
_TRUNK = np.array([0, 1, 2, 4, 5, 6, 7, 8, 9, 10])
_LIMBS = {L_WRIST: np.array([11, 12, 13, 17]), R_WRIST: np.array([14, 15, 16, 18]),
          L_ANKLE: np.array([19, 20, 21, 25]), R_ANKLE: np.array([22, 23, 24, 26])}
_PARENT = {L_WRIST: L_WRIST - 1, R_WRIST: R_WRIST - 1}  # the elbows: the forearm's direction


def _end_residual(model, joints, row, tip, yaw) -> np.ndarray:
    """(3,) from the reachable extension of joint ``row`` to its tip (see :func:`_fit`)."""
    height = float(model.dimensions.height)
    j = joints[row]
    if row == HEAD_TOP:
        return tip - j
    if row in (L_WRIST, R_WRIST):
        d = j - joints[_PARENT[row]]
        return _to_segment(tip, j, j + HAND_SHARE * height * d / max(norm(d), 1e-9))
    facing = np.array([-np.sin(yaw), np.cos(yaw), 0.0])
    foot = j + FOOT_SHARE * height * facing - np.array([0.0, 0.0, ANKLE_SHARE * height])
    return _to_segment(tip, j, foot)


def _solve(model, x, free, residual, max_nfev) -> tuple[np.ndarray, float]:
    low, high = model.low[free], model.high[free]
    high_ls = np.where(high > low, high, low + 1e-12)
    x = x.copy()

    def full(v):
        x[free] = v
        return residual(x)

    sol = least_squares(full, np.clip(x[free], low, high_ls), bounds=(low, high_ls),
                        method="trf", x_scale="jac", max_nfev=max_nfev)
    x[free] = np.clip(sol.x, model.low[free], model.high[free])
    return x, float(sol.cost)


def _fit(model, x0, ends: list[tuple[int, np.ndarray]], centre: np.ndarray) -> tuple[np.ndarray,
                                                                                   float]:
    """Least-squares state whose ends reach the tips, in three stages.

    ``ends`` pairs a joint row (head top, a wrist, an ankle) with the tip it should reach. A
    joint reaches its tip when the tip lies on the joint's *extension*: the head top itself; the
    wrist plus up to a hand's length along the forearm; the ankle plus up to a foot (forward of
    the heading, down to the floor). So a cone body (tips at the joints) and a real one (tips at
    fingers and toes) fit alike. The trunk axis (pelvis → thorax) passes through ``centre``.

    Fitting all 26 free values at once from a standing start falls into poor minima (a tilted
    trunk instead of a raised leg); so the trunk is fitted first (axis and head), then each limb
    alone (4 values, its tip only), then everything together from there. Every stage pulls the
    angles towards the neutral pose (:data:`PRIOR_MM_PER_RAD`), which settles what the tips
    leave free (a limb's twist, a straight elbow's plane).
    """
    yaw = float(x0[3])

    def prior(x):
        return PRIOR_MM_PER_RAD * x[4:]  # pitch and roll too: people mostly stand upright

    def fk(x):
        return forward_kinematics(x[None], model.dimensions).joints[0]

    def trunk_residual(x):
        joints = fk(x)
        parts = [_to_segment(centre, joints[PELVIS], joints[PELVIS - 1])]  # row 0 is the thorax
        parts += [_end_residual(model, joints, row, tip, yaw) for row, tip in ends
                  if row == HEAD_TOP]
        return np.concatenate([*parts, prior(x)])

    x, _ = _solve(model, np.asarray(x0, float), _TRUNK, trunk_residual, 60)
    for row, tip in ends:
        if row in _LIMBS:
            free = _LIMBS[row]

            def limb_residual(x, row=row, tip=tip, free=free):
                return np.concatenate([_end_residual(model, fk(x), row, tip, yaw),
                                       PRIOR_MM_PER_RAD * x[free]])

            x, _ = _solve(model, x, free, limb_residual, 40)

    def all_residual(x):
        joints = fk(x)
        parts = [_to_segment(centre, joints[PELVIS], joints[PELVIS - 1])]
        parts += [_end_residual(model, joints, row, tip, x[3]) for row, tip in ends]
        return np.concatenate([*parts, prior(x)])

    return _solve(model, x, np.arange(model.n_dims), all_residual, 60)


def pose_hypotheses(ex: Extremities, model, *, n_ring: int = 4) -> list[Hypothesis]:
    """Fitted poses for the plausible labellings of the extremities (see the module docstring).

    Parameters
    ----------
    ex : Extremities
        The frame's extremities.
    model : BodyModel
        The body (its size decides the hand and ankle offsets and the pelvis height).
    n_ring : int
        Headings tried besides those the feet and hands suggest.

    Returns
    -------
    list of Hypothesis
        Possibly empty (no tips).
    """
    height = float(model.dimensions.height)
    tips = np.asarray(ex.points, dtype=float).reshape(-1, 3)
    by_height = np.argsort(tips[:, 2], kind="stable")
    below = [int(i) for i in by_height if tips[i, 2] < ex.centre[2] - 0.25 * height]
    # Feet: pairs among the three lowest tips (a visual hull often grows a ghost tip between
    # the legs, where no camera sees the gap).
    feet_choices = [list(c) for c in itertools.combinations(below[:3], 2)] or [below[:1]]
    standing = model.default_state()
    out: list[Hypothesis] = []
    labellings = []
    for feet_idx in feet_choices:
        others = [i for i in range(len(tips)) if i not in below[:3]]
        # Head candidates: tips above the trunk, the one closest to the vertical through it
        # first (a raised hand is usually off to the side).
        above = [i for i in others if tips[i, 2] > ex.centre[2]]
        heads = sorted(above, key=lambda i: np.hypot(*(tips[i, :2] - ex.centre[:2]))) or [None]
        for head in heads[:2]:
            rest = [i for i in others if i != head]
            labellings.append((feet_idx, head, rest[:2]))
            if rest:
                # Arms that hang along the body leave no tips of their own: what is left may
                # be bumps (an elbow, a hip), so try the arms neutral as well.
                labellings.append((feet_idx, head, []))
    for feet_idx, head, hands_idx in labellings:
        feet, hands = tips[feet_idx], tips[hands_idx]
        for yaw in _candidate_yaws(feet, hands, n_ring):
            right = _right_of(yaw)
            ends: list[tuple[int, np.ndarray]] = []
            if head is not None:
                ends.append((HEAD_TOP, tips[head]))
            # The tip farther to the subject's right is the right hand (foot).
            for idx, (left_row, right_row) in ((hands_idx, (L_WRIST, R_WRIST)),
                                               (feet_idx, (L_ANKLE, R_ANKLE))):
                pts = tips[idx]
                if len(pts) == 2:
                    order = np.argsort(matmul(pts, right))  # leftmost first
                    ends += [(left_row, pts[order[0]]), (right_row, pts[order[1]])]
                elif len(pts) == 1:
                    side = right_row if dot(pts[0], right) > dot(ex.centre, right) else left_row
                    ends.append((side, pts[0]))
            x0 = standing.copy()
            x0[0], x0[1] = ex.centre[0], ex.centre[1]  # the standing pelvis height stays
            x0[3] = yaw
            state, cost = _fit(model, x0, ends, ex.centre)
            label = (f"{'no head' if head is None else 'head = tip ' + str(head)}, "
                     f"{'hands = tips ' + str(hands_idx) if hands_idx else 'arms neutral'}, "
                     f"facing {np.degrees(yaw):.0f}°")
            out.append(Hypothesis(state, label, cost))
    return out


def _distinct(model, states, scores, n: int, min_apart_mm: float) -> list[int]:
    """Indices of up to ``n`` best-scoring states at least ``min_apart_mm`` apart (landmarks)."""
    landmarks = model.landmarks(states)
    chosen: list[int] = []
    for i in np.argsort(-scores, kind="stable"):
        if len(chosen) == n:
            break
        if not chosen or np.linalg.norm(landmarks[chosen] - landmarks[i],
                                        axis=2).mean(axis=1).min() >= min_apart_mm:
            chosen.append(int(i))
    return chosen


def initial_pose(ex: Extremities, model, log_likelihood, *, n_yaw: int = 36,
                 n_best: int = 1, min_apart_mm: float = 150.0):
    """The most likely starting pose(s) among the fitted hypotheses and the standing poses.

    Parameters
    ----------
    ex : Extremities
        The first frame's extremities.
    model : BodyModel
    log_likelihood : callable
        ``(P, 27) states → (P,)`` log-likelihoods of the frame.
    n_yaw : int
        Headings of the standing poses at the voxels' centre (the fallback).
    n_best : int
        How many poses to return. More than one lets a filter start from a mixture: far from
        the truth the likelihood ranks a mirrored pose (facing the other way, left for right)
        about as high as the right one, and a few frames of motion tell them apart.
    min_apart_mm : float
        Returned poses differ by at least this mean landmark distance (mm).

    Returns
    -------
    states : (27,) float ndarray, or (n_best', 27) when ``n_best > 1`` (best first, n_best' ≤ n_best)
    description : str
        Which hypothesis won.
    """
    hyps = pose_hypotheses(ex, model)
    standing = np.repeat(model.default_state()[None], n_yaw, axis=0)
    standing[:, 0], standing[:, 1] = ex.centre[0], ex.centre[1]
    standing[:, 3] = np.linspace(-np.pi, np.pi, n_yaw, endpoint=False)
    states = np.concatenate([np.array([h.state for h in hyps]).reshape(-1, model.n_dims),
                             standing])
    labels = [f"extremities fit ({h.label})" for h in hyps] + \
        ["standing pose at the voxels' centre (yaw search)"] * n_yaw
    scores = np.asarray(log_likelihood(states), dtype=float)
    # Improving the 12 best candidates on the likelihood before choosing (3 rounds of 64
    # perturbations) was measured and left out: no better on the five clips (141.7 vs 142.7 mm
    # mean μ, 3 seeds; docs/benchmarks.md) — far from the truth the likelihood cannot rank them.
    chosen = _distinct(model, states, scores, max(n_best, 1), min_apart_mm)
    how = labels[chosen[0]]
    if n_best <= 1:
        return states[chosen[0]], how
    return states[chosen], how + f" and {len(chosen) - 1} other hypotheses"
