"""Inverse kinematics: the legal state whose landmarks best match given landmarks.

:func:`fit_to_landmarks` starts from a closed-form guess (segment directions turned into the
Euler angles of :mod:`voxelmocap.body.kinematics`, see :func:`analytic_state`) and refines it by
bounded least squares (:func:`scipy.optimize.least_squares`, trust-region reflective) on the 45
landmark coordinates. It is used to start tracking from the ground truth of the first frame, as
the papers do.

>>> from voxelmocap.body import BodyModel
>>> model = BodyModel()
>>> x = model.default_state(); x[17] = 1.0           # bend the left elbow
>>> target = model.landmarks(x[None])[0]
>>> fit = fit_to_landmarks(model, target)
>>> bool(np.abs(model.landmarks(fit[None])[0] - target).max() < 1e-6)
True

A straight elbow or knee leaves the twist of its limb undetermined (any value fits); the fit
then keeps the closed-form guess's value (0).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import least_squares

from ..errors import InputError
from ..portable import atan2, dot, matmul, norm
from .kinematics import (
    HEAD_TOP,
    L_ANKLE,
    L_ELBOW,
    L_HIP,
    L_KNEE,
    L_SHOULDER,
    L_WRIST,
    PELVIS,
    R_ANKLE,
    R_ELBOW,
    R_HIP,
    R_KNEE,
    R_SHOULDER,
    R_WRIST,
    THORAX,
    forward_kinematics,
    rotation_x,
    rotation_y,
    rotation_z,
)

__all__ = ["analytic_state", "fit_to_landmarks", "retarget"]


def _unit(v):
    n = norm(v)
    return v / n if n > 1e-12 else v * 0.0


def _frame(x_dir, z_dir):
    """Rotation with columns (x, y, z): z along ``z_dir``, x as close to ``x_dir`` as possible."""
    z = _unit(z_dir)
    x = _unit(x_dir - dot(x_dir, z) * z)
    if not np.any(x):  # degenerate: pick any perpendicular
        x = _unit(np.cross(z, [0.0, 1.0, 0.0]) if abs(z[1]) < 0.9 else np.cross(z, [1.0, 0, 0]))
    y = np.cross(z, x)
    return np.stack([x, y, z], axis=1)


def _xyz_euler(m):
    """Angles (a, b, c) with m = Rx(a) Ry(b) Rz(c)."""
    b = math.asin(min(max(float(m[0, 2]), -1.0), 1.0))
    a = atan2(-m[1, 2], m[2, 2])
    c = atan2(-m[0, 1], m[0, 0])
    return a, b, c


def _limb_angles(parent, top, mid, end, sign, hinge_sign, low, high):
    """flex, abd, rot, hinge of a 3-DoF + 1-DoF limb from three joint positions.

    ``low``/``high`` are the (4,) ranges of (flex, abd, rot, hinge); of the two Euler solutions
    for the limb direction, the one closest to legal is taken.
    """
    v = matmul(parent.T, _unit(mid - top))                   # (−sin b, sin f cos b, −cos f cos b)
    b0 = math.asin(min(max(float(-v[0]), -1.0), 1.0))
    f0 = atan2(v[1], -v[2])
    best, best_bad = None, np.inf
    for f, b in ((f0, b0), (f0 + np.pi, np.pi - b0), (f0 - np.pi, np.pi - b0),
                 (f0 + np.pi, -np.pi - b0), (f0 - np.pi, -np.pi - b0)):
        q = matmul(matmul(rotation_x(f), rotation_y(b)).T, matmul(parent.T, _unit(end - mid)))
        hinge = math.acos(min(max(float(-q[2]), -1.0), 1.0))
        # elbow: q = (−sin r sin e, cos r sin e, ·); knee: q = (sin r sin k, −cos r sin k, ·)
        r = atan2(-hinge_sign * q[0], hinge_sign * q[1]) if np.sin(hinge) > 1e-6 else 0.0
        cand = np.array([f, sign * b, -sign * r, hinge])
        bad = np.sum(np.maximum(low - cand, 0.0) + np.maximum(cand - high, 0.0))
        if bad < best_bad - 1e-12:
            best, best_bad = cand, bad
    return best


#: (state columns of flex, abd, rot, hinge; top, mid, end joints; side sign; hinge sign; parent)
_LIMBS = (((11, 12, 13, 17), (L_SHOULDER, L_ELBOW, L_WRIST), 1.0, 1.0, "torso"),
          ((14, 15, 16, 18), (R_SHOULDER, R_ELBOW, R_WRIST), -1.0, 1.0, "torso"),
          ((19, 20, 21, 25), (L_HIP, L_KNEE, L_ANKLE), 1.0, -1.0, "root"),
          ((22, 23, 24, 26), (R_HIP, R_KNEE, R_ANKLE), -1.0, -1.0, "root"))


def analytic_state(model, landmarks) -> np.ndarray:
    """Closed-form state (27,) from landmarks (15, 3), clipped into the legal ranges.

    Exact for landmarks of the model's own skeleton when the hips have a drop below the pelvis;
    otherwise a starting point for :func:`fit_to_landmarks`.
    """
    lm = np.asarray(landmarks, dtype=float)
    d = model.dimensions
    x = np.zeros(27)
    pelvis, thorax = lm[PELVIS], lm[THORAX]
    x[0:3] = pelvis
    lateral = lm[R_HIP] - lm[L_HIP]
    hip_mid = 0.5 * (lm[R_HIP] + lm[L_HIP])
    drop = 0.5 * (d.hip_drop[0] + d.hip_drop[1])
    up = pelvis - hip_mid if drop > 5.0 else thorax - pelvis
    root = _frame(lateral, up)
    # root = Rz(yaw) Rx(−pitch) Ry(roll): row 2 = (−cos a sin r, sin a, cos a cos r), a = −pitch
    a = math.asin(min(max(float(root[2, 1]), -1.0), 1.0))
    x[3] = atan2(-root[0, 1], root[1, 1])
    x[4] = -a
    x[5] = atan2(-root[2, 0], root[2, 2])
    torso = _frame(lm[R_SHOULDER] - lm[L_SHOULDER], thorax - pelvis)
    wa, wb, wc = _xyz_euler(matmul(root.T, torso))
    x[6:9] = (-wa, wb, wc)
    v = matmul(torso.T, _unit(lm[HEAD_TOP] - thorax))       # (sin b, −sin a cos b, cos a cos b)
    x[9] = -atan2(-v[1], v[2])
    x[10] = math.asin(min(max(float(v[0]), -1.0), 1.0))
    lo, hi = model.low, model.high
    parents = {"torso": torso, "root": root}
    for idx, (a, b, c), sign, hinge_sign, parent in _LIMBS:
        idx = list(idx)
        x[idx] = _limb_angles(parents[parent], lm[a], lm[b], lm[c], sign, hinge_sign, lo[idx],
                              hi[idx])
    return np.clip(x, model.low, model.high)


def fit_to_landmarks(model, landmarks, *, initial=None, max_nfev: int = 2000) -> np.ndarray:
    """Legal state whose landmarks are closest (least squares) to ``landmarks``.

    Parameters
    ----------
    model : BodyModel
    landmarks : (15, 3) array_like
        Target landmarks (mm) in ``LANDMARK_NAMES`` order, all finite.
    initial : (27,) array_like, optional
        Extra starting state (e.g. the previous frame's); the closed-form guess of
        :func:`analytic_state` is always tried too and the better fit is returned.
    max_nfev : int
        Function-evaluation budget per start.

    Returns
    -------
    (27,) float64 ndarray
        A state inside ``[model.low, model.high]``.
    """
    lm = np.asarray(landmarks, dtype=float)
    if lm.shape != (15, 3):
        raise InputError("landmarks", f"expected shape (15, 3), got {lm.shape}")
    if not np.all(np.isfinite(lm)):
        raise InputError("landmarks", "landmarks must be finite")
    starts = [analytic_state(model, lm)]
    if initial is not None:
        starts.append(np.clip(model.check(initial, legal=False)[0], model.low, model.high))
    low, high = model.low, model.high
    # least_squares needs low < high strictly; pin degenerate ranges by a hair.
    high_ls = np.where(high > low, high, low + 1e-12)
    target = lm.ravel()

    def residual(x):
        return forward_kinematics(x[None], model.dimensions).joints.ravel() - target

    best, best_cost = None, np.inf
    for x0 in starts:
        sol = least_squares(residual, x0, bounds=(low, high_ls), method="trf", x_scale="jac",
                            xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=max_nfev)
        if sol.cost < best_cost:
            best, best_cost = sol.x, sol.cost
    return np.clip(best, low, high)



def retarget(model_from, model_to, states) -> np.ndarray:
    """The same poses on another skeleton, each limb re-aimed at the elbows / knees and wrists /
    ankles it reached on the first.

    Root, trunk and head angles are kept; a limb whose shoulder (hip) moved with the new
    skeleton's offsets or torso length points its upper segment from the new joint at the old
    elbow (knee), its lower segment along the old one. Changing a joint offset with the angles
    held would swing the whole limb sideways instead (what a body fit with the poses held
    compares against).

    Parameters
    ----------
    model_from, model_to : BodyModel
        The skeleton the states were estimated with, and the new one.
    states : (P, 27) array_like
        Legal states of ``model_from``.

    Returns
    -------
    (P, 27) float64 ndarray
        Legal states of ``model_to`` (clipped into its ranges).
    """
    x = np.array(model_from.check(states, legal=False), dtype=float)
    old = forward_kinematics(x, model_from.dimensions).joints
    new = forward_kinematics(x, model_to.dimensions).joints
    lo, hi = model_to.low, model_to.high
    out = x.copy()
    for p in range(len(x)):
        root = matmul(matmul(rotation_z(x[p, 3]), rotation_x(-x[p, 4])), rotation_y(x[p, 5]))
        parents = {"root": root,
                   "torso": matmul(matmul(matmul(root, rotation_x(-x[p, 6])), rotation_y(x[p, 7])),
                                   rotation_z(x[p, 8]))}
        for idx, (top, mid, end), sign, hinge_sign, parent in _LIMBS:
            idx = list(idx)
            angles = _limb_angles(parents[parent], new[p, top], old[p, mid], old[p, end], sign,
                                  hinge_sign, lo[idx], hi[idx])
            if np.sin(angles[3]) <= 1e-6:   # a straight limb: its twist is free, keep it
                angles[2] = x[p, idx[2]]
            out[p, idx] = angles
    return np.clip(out, lo, hi)
