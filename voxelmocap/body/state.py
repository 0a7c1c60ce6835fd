"""The 27-dimensional pose state: layout, names, units and legal ranges.

A state is a float vector of 27 numbers (paper 002 §2.2, Fig. 2a):

====  =======================  ==================================================================
idx   name                     meaning (angles in radians, translations in mm)
====  =======================  ==================================================================
0-2   root_x, root_y, root_z   pelvis position in the world (Z up, floor at 0)
3     root_yaw                 heading about the world Z axis (0 = facing +Y, its right = +X)
4     root_pitch               forward tilt of the whole body about its lateral axis
5     root_roll                sideways tilt about its forward axis (+ = lean to its right)
6-8   waist_flex/side/twist    torso relative to the pelvis: flexion (+ forward), lateral bend
                               (+ to its right), axial rotation (+ turning left)
9-10  neck_flex, neck_side     head relative to the torso: flexion (+ chin down), lateral bend
11-13 l_shoulder_flex/abd/rot  upper arm: flexion (+ forward), abduction (+ away from the body),
                               internal rotation (+ inward)
14-16 r_shoulder_…             same for the right arm (same anatomical signs)
17    l_elbow                  elbow flexion (0 = straight)
18    r_elbow
19-21 l_hip_flex/abd/rot       thigh: flexion (+ forward), abduction (+ outward), internal rotation
22-24 r_hip_…
25    l_knee                   knee flexion (0 = straight, + = shin backwards)
26    r_knee
====  =======================  ==================================================================

Joint ranges are the normal active ranges of motion of adults published by the American Academy of
Orthopaedic Surgeons (AAOS, *Joint Motion: Method of Measuring and Recording*, 1965), as tabulated
in Norkin & White, *Measurement of Joint Motion: A Guide to Goniometry* (F.A. Davis, 3rd ed. 2003,
Appendix A): shoulder flexion 180°, extension 60°, abduction 180°, internal rotation 70°, external
rotation 90°; elbow flexion 150°; hip flexion 120°, extension 30°, abduction 45°, adduction 30°,
internal and external rotation 45°; knee flexion 135°; cervical spine flexion 45°, extension 45°,
lateral flexion 45°; thoracolumbar spine flexion 80°, extension 25°, lateral flexion 35°, rotation
45°. Two departures, both documented where they are set: shoulder adduction (negative abduction)
is allowed to 45° so that an arm can cross in front of the body (AAOS measures horizontal adduction
of 135° from the abducted position, not adduction from neutral), and the root has no anatomical
range: yaw spans ±4π so that a subject walking in circles never meets a bound (yaw is equivalent
modulo 2π; see :func:`wrap_heading`), pitch and roll span ±90°, the translation spans a ±3 m
capture area and a pelvis height of 0.2–1.6 m.

>>> len(STATE_NAMES), STATE_NAMES[25]
(27, 'l_knee')
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError

__all__ = [
    "N_DIMS",
    "STATE_HIGH",
    "STATE_INDEX",
    "STATE_LOW",
    "STATE_NAMES",
    "check_states",
    "wrap_heading",
]

_D = np.pi / 180.0

# (name, low, high) in mm or radians; the AAOS numbers are quoted in degrees.
_LAYOUT: tuple[tuple[str, float, float], ...] = (
    ("root_x", -3000.0, 3000.0),
    ("root_y", -3000.0, 3000.0),
    ("root_z", 200.0, 1600.0),
    ("root_yaw", -4 * np.pi, 4 * np.pi),
    ("root_pitch", -90 * _D, 90 * _D),
    ("root_roll", -90 * _D, 90 * _D),
    ("waist_flex", -25 * _D, 80 * _D),     # thoracolumbar extension 25, flexion 80
    ("waist_side", -35 * _D, 35 * _D),     # lateral flexion 35 each way
    ("waist_twist", -45 * _D, 45 * _D),    # rotation 45 each way
    ("neck_flex", -45 * _D, 45 * _D),      # cervical extension 45, flexion 45
    ("neck_side", -45 * _D, 45 * _D),      # cervical lateral flexion 45
    ("l_shoulder_flex", -60 * _D, 180 * _D),  # extension 60, flexion 180
    ("l_shoulder_abd", -45 * _D, 180 * _D),   # abduction 180; adduction 45 (see module notes)
    ("l_shoulder_rot", -90 * _D, 70 * _D),    # external 90, internal 70
    ("r_shoulder_flex", -60 * _D, 180 * _D),
    ("r_shoulder_abd", -45 * _D, 180 * _D),
    ("r_shoulder_rot", -90 * _D, 70 * _D),
    ("l_elbow", 0.0, 150 * _D),            # elbow flexion 150
    ("r_elbow", 0.0, 150 * _D),
    ("l_hip_flex", -30 * _D, 120 * _D),    # hip extension 30, flexion 120
    ("l_hip_abd", -30 * _D, 45 * _D),      # adduction 30, abduction 45
    ("l_hip_rot", -45 * _D, 45 * _D),      # external 45, internal 45
    ("r_hip_flex", -30 * _D, 120 * _D),
    ("r_hip_abd", -30 * _D, 45 * _D),
    ("r_hip_rot", -45 * _D, 45 * _D),
    ("l_knee", 0.0, 135 * _D),             # knee flexion 135
    ("r_knee", 0.0, 135 * _D),
)

#: Names of the 27 state dimensions, in state-vector order.
STATE_NAMES: tuple[str, ...] = tuple(row[0] for row in _LAYOUT)
#: Index of each state name.
STATE_INDEX: dict[str, int] = {name: i for i, name in enumerate(STATE_NAMES)}
#: (27,) lower legal bound of each dimension (mm or rad).
STATE_LOW: np.ndarray = np.array([row[1] for row in _LAYOUT])
#: (27,) upper legal bound of each dimension (mm or rad).
STATE_HIGH: np.ndarray = np.array([row[2] for row in _LAYOUT])
N_DIMS: int = len(STATE_NAMES)
STATE_LOW.setflags(write=False)
STATE_HIGH.setflags(write=False)

#: Tolerance (a share of each range) within which a state just outside its range is still legal;
#: it absorbs round-off from callers that clip and then add tiny offsets.
RANGE_TOLERANCE = 1e-9


def check_states(states, *, low=STATE_LOW, high=STATE_HIGH, legal: bool = True,
                 clip: bool = False, source: str = "states") -> np.ndarray:
    """Validate a batch of states and return it as a C-contiguous ``(P, 27)`` float64 array.

    Parameters
    ----------
    states : (P, 27) or (27,) array_like
        Pose states (mm, rad).
    low, high : (27,) array_like
        Legal bounds.
    legal : bool
        When true, states outside ``[low, high]`` (beyond a relative tolerance of 1e-9 of the
        range) are rejected, or clipped if ``clip`` is true. Non-finite values are always rejected.
    clip : bool
        Clip out-of-range values into ``[low, high]`` instead of raising.
    source : str
        Name used in error messages.

    Returns
    -------
    (P, 27) float64 ndarray
        A new array when clipping or converting, otherwise possibly the input itself.

    Raises
    ------
    InputError
        Wrong shape, a NaN or infinite value, or (``legal`` and not ``clip``) a value out of range.
    """
    arr = np.asarray(states, dtype=float)
    if arr.ndim == 1:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != N_DIMS:
        raise InputError(source, f"expected shape (P, {N_DIMS}), got {np.shape(states)}")
    bad = ~np.isfinite(arr)
    if bad.any():
        p, d = np.argwhere(bad)[0]
        raise InputError(source, f"particle {p}: {STATE_NAMES[d]} is {arr[p, d]} (not finite)")
    if legal:
        low = np.asarray(low, dtype=float)
        high = np.asarray(high, dtype=float)
        tol = RANGE_TOLERANCE * (high - low)
        outside = (arr < low - tol) | (arr > high + tol)
        if clip:
            arr = np.clip(arr, low, high)
        elif outside.any():
            p, d = np.argwhere(outside)[0]
            raise InputError(source, f"particle {p}: {STATE_NAMES[d]} = {arr[p, d]:.6g} is "
                                     f"outside its legal range [{low[d]:.6g}, {high[d]:.6g}]")
    return np.ascontiguousarray(arr)


def wrap_heading(states) -> np.ndarray:
    """Copy of ``states`` with ``root_yaw`` wrapped into ``[-π, π)``; the pose is unchanged.

    Parameters
    ----------
    states : (..., 27) array_like

    Returns
    -------
    (..., 27) float64 ndarray
    """
    out = np.array(states, dtype=float, copy=True)
    yaw = out[..., STATE_INDEX["root_yaw"]]
    out[..., STATE_INDEX["root_yaw"]] = (yaw + np.pi) % (2 * np.pi) - np.pi
    return out
