"""Which way the body faces: the turned-round hypothesis and the evidence that breaks the tie.

The truncated-cone body has no feet and a round head: the voxels of a person facing +y and of
one facing −y with left and right exchanged differ only where a joint's limits forbid the other
reading (a knee or an elbow bent the wrong way). A track can therefore start, or drift into,
facing backwards with every limb on the other side's voxels (docs/benchmarks.md). This module
supplies

* :func:`turned_round`: the estimate turned 180° in place — the trunk's geometry kept exactly
  (``yaw + π``; pitch, roll, waist and neck flexion and side bends negated; twists kept), so that
  the left hip and shoulder stand where the right ones stood — and each limb refitted onto the
  other side's joints (knee and ankle, elbow and wrist) within its legal range; where the limits
  allow it the geometry is the same body, facing the other way;
* :func:`foot_evidence`: the voxels at floor level in front of each ankle against those behind
  it (a foot points forward: toes ≈ 150–200 mm ahead of the ankle, the heel ≈ 50 mm behind);
* :func:`travel_evidence`: the heading against the direction of travel (people walk forwards).

Each evidence is a number in [−1, 1] per state; :class:`voxelmocap.pose.tracker.BodyTracker`
weighs them with the likelihood when it compares a state with its turned-round twin.
"""

from __future__ import annotations

import numpy as np

from ..body.state import STATE_INDEX
from ..portable import matmul

__all__ = ["FOOT_BOX_MM", "facing_direction", "facing_evidence", "foot_evidence", "travel_evidence",
           "turned_round"]

#: The floor-level boxes of :func:`foot_evidence` (mm): along the facing, from ``near`` to ``far``
#: ahead of (and behind) the ankle's floor point, ``half_width`` to each side, up to ``height``
#: above the floor. A shoe reaches ≈ 0.15 × the height ahead of the ankle and ≈ 0.04 behind it.
FOOT_BOX_MM = {"near": 60.0, "far": 220.0, "half_width": 70.0, "height": 120.0}

#: State dimensions negated by the half turn (the trunk's frame turned about its own z axis).
_NEGATED = ("root_pitch", "root_roll", "waist_flex", "waist_side", "neck_flex", "neck_side")
#: Each limb's angles, left then right, and how the half turn maps one side onto the other:
#: flexion and internal rotation change sign (the limb frame is turned about z), abduction keeps.
_LIMB_ANGLES = (("shoulder_flex", -1.0), ("shoulder_abd", 1.0), ("shoulder_rot", -1.0),
                ("elbow", -1.0), ("hip_flex", -1.0), ("hip_abd", 1.0), ("hip_rot", -1.0),
                ("knee", -1.0))
#: landmarks a limb's angles place, per limb pair (refit targets)
_LIMB_JOINTS = {"arm": ("elbow", "wrist"), "leg": ("knee", "ankle")}
_LIMB_DIMS = {"arm": ("shoulder_flex", "shoulder_abd", "shoulder_rot", "elbow"),
              "leg": ("hip_flex", "hip_abd", "hip_rot", "knee")}


def facing_direction(states) -> np.ndarray:
    """``(P, 2)`` unit vectors in the floor plane: where each state's root faces (its +y)."""
    yaw = np.atleast_2d(np.asarray(states, float))[:, STATE_INDEX["root_yaw"]]
    # the root frame is Rz(yaw)·…; the body faces its frame's +y
    return np.stack([-np.sin(yaw), np.cos(yaw)], axis=1)


def turned_round(model, state, *, refit: bool = True) -> np.ndarray:
    """The body turned 180° in place, left and right exchanged: ``(27,)``.

    Parameters
    ----------
    model : BodyModel
    state : (27,) array_like
        A legal pose.
    refit : bool
        Refit each limb whose mapped angles left its legal range (least squares, within the
        range) so that its joints land as near as they can to the other side's; without it the
        mapped angles are only clipped.

    Returns
    -------
    (27,) ndarray
        Legal. The pelvis, thorax and head top are where they were; the left hip, shoulder,
        knee, … stand where the right ones stood and the other way round, wherever the joint
        limits allow the mapped angles (a knee bent backwards for one facing is bent forwards
        for the other: there the limb is refitted, and the geometry differs).

    Notes
    -----
    The root frame is ``Rz(yaw) Rx(−pitch) Ry(roll)`` and the torso ``root · Rx(−flex) Ry(side)
    Rz(twist)``; turning a frame about its own z axis by π conjugates ``Rx(a)`` to ``Rx(−a)``,
    ``Ry(b)`` to ``Ry(−b)`` and keeps ``Rz``. A limb frame ``Rx(flex) Ry(±abd) Rz(∓rot)`` on one
    side maps to the other side's with flexion and rotation negated, abduction kept; the elbow
    ``Rx(e)`` and knee ``Rx(−k)`` are negated.
    """
    x = model.clip(np.asarray(state, dtype=float)[None])[0]
    y = x.copy()
    y[STATE_INDEX["root_yaw"]] = x[STATE_INDEX["root_yaw"]] + np.pi
    for name in _NEGATED:
        y[STATE_INDEX[name]] = -x[STATE_INDEX[name]]
    for angle, sign in _LIMB_ANGLES:
        left, right = STATE_INDEX[f"l_{angle}"], STATE_INDEX[f"r_{angle}"]
        y[left], y[right] = sign * x[right], sign * x[left]
    # keep the heading in the legal ±4π (it only ever moves by π here)
    yaw = STATE_INDEX["root_yaw"]
    if y[yaw] > model.high[yaw]:
        y[yaw] -= 2 * np.pi
    clipped = model.clip(y[None])[0]
    if not refit:
        return clipped
    before = model.landmarks(x[None])[0]
    for limb, joints in _LIMB_JOINTS.items():
        for side, other in (("l", "r"), ("r", "l")):
            dims = [STATE_INDEX[f"{side}_{d}"] for d in _LIMB_DIMS[limb]]
            if np.array_equal(clipped[dims], y[dims]):
                continue                      # the mapped angles are legal: exact already
            clipped = _refit(model, clipped, dims, [f"{side}_{j}" for j in joints],
                             before, [f"{other}_{j}" for j in joints])
    return clipped


def _refit(model, x, dims, moved, before, targets) -> np.ndarray:
    """``x`` with the angles ``dims`` fitted (least squares within their range) so that the
    landmarks ``moved`` land on ``before``'s ``targets``."""
    from scipy.optimize import least_squares

    from ..joints import LANDMARK_NAMES

    rows = [LANDMARK_NAMES.index(n) for n in moved]
    goal = before[[LANDMARK_NAMES.index(n) for n in targets]].ravel()
    dims = np.asarray(dims)
    low, high = model.low[dims], model.high[dims]
    high_ls = np.where(high > low, high, low + 1e-12)

    def residual(v):
        y = x.copy()
        y[dims] = v
        return model.landmarks(y[None])[0, rows].ravel() - goal

    sol = least_squares(residual, np.clip(x[dims], low, high), bounds=(low, high_ls),
                        x_scale=np.maximum(high - low, 1e-3), max_nfev=200)
    out = x.copy()
    out[dims] = np.clip(sol.x, low, high)
    return out


def foot_evidence(observation, model, states, *, box=None) -> np.ndarray:
    """Whether the floor-level voxels say each state faces the right way: ``(P,)`` in [−1, 1].

    For each ankle of each state, the occupied voxels in a box at floor level ahead of the
    ankle's floor point (along the state's facing) are counted against those in the same box
    behind it; the evidence is ``(ahead − behind) / (ahead + behind)`` over both feet (0 when
    neither box holds a voxel: no evidence). A person's shoes reach forward from the ankles, so
    the state facing the person's way scores > 0 and its turned-round twin < 0.

    Parameters
    ----------
    observation : VoxelObservation
    model : BodyModel
    states : (P, 27) array_like
    box : dict, optional
        :data:`FOOT_BOX_MM` by default.

    Returns
    -------
    (P,) float ndarray
    """
    from ..joints import LANDMARK_NAMES

    b = dict(FOOT_BOX_MM if box is None else box)
    states = np.atleast_2d(np.asarray(states, float))
    grid = observation.grid
    occupied = np.argwhere(observation.occupancy)
    if len(occupied) == 0:
        return np.zeros(len(states))
    centres = grid.centre_of(occupied)
    low = centres[centres[:, 2] <= b["height"]]
    if len(low) == 0:
        return np.zeros(len(states))
    joints = model.landmarks(states)
    feet = [LANDMARK_NAMES.index("l_ankle"), LANDMARK_NAMES.index("r_ankle")]
    facing = facing_direction(states)
    side = np.stack([facing[:, 1], -facing[:, 0]], axis=1)
    out = np.zeros(len(states))
    for p in range(len(states)):
        ahead = behind = 0
        for f in feet:
            d = low[:, :2] - joints[p, f, :2]
            along = matmul(d, facing[p])
            across = np.abs(matmul(d, side[p]))
            inside = across <= b["half_width"]
            ahead += int(np.count_nonzero(inside & (along >= b["near"]) & (along <= b["far"])))
            behind += int(np.count_nonzero(inside & (-along >= b["near"])
                                           & (-along <= b["far"])))
        if ahead + behind:
            out[p] = (ahead - behind) / (ahead + behind)
    return out


def travel_evidence(positions, states, *, frame_rate: float, min_speed_mm_s: float = 400.0
                    ) -> np.ndarray:
    """Whether the direction of travel says each state faces the right way: ``(P,)`` in [−1, 1].

    Parameters
    ----------
    positions : (T, 2 or 3) array_like
        The pelvis (or the voxels' centre) over the last frames, oldest first (mm).
    states : (P, 27) array_like
        The states to judge (their heading).
    frame_rate : float
        Frames per second of ``positions``.
    min_speed_mm_s : float
        Below this mean horizontal speed the person is not going anywhere: no evidence (0).

    Returns
    -------
    (P,) float ndarray
        The cosine between each state's facing and the horizontal displacement from the first
        to the last position, when the speed reaches ``min_speed_mm_s``; else 0.
    """
    pos = np.asarray(positions, float)
    states = np.atleast_2d(np.asarray(states, float))
    if len(pos) < 2:
        return np.zeros(len(states))
    move = pos[-1, :2] - pos[0, :2]
    seconds = (len(pos) - 1) / float(frame_rate)
    distance = float(np.hypot(*move))
    if distance / seconds < min_speed_mm_s:
        return np.zeros(len(states))
    return matmul(facing_direction(states), move / distance)


def facing_evidence(observation, model, states) -> np.ndarray:
    """The frame's evidence of which way each state faces, ``(P,)`` in [−1, 1]: the feet
    (:func:`foot_evidence`)."""
    return foot_evidence(observation, model, states)
