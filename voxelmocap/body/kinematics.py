"""Batched forward kinematics of the 27-parameter skeleton (numpy, vectorised over particles).

Frames: every segment frame has x = the subject's right, y = forward, z = up when the subject
stands in the zero pose facing world +Y. The root (pelvis) frame is ``Rz(yaw) Rx(−pitch)
Ry(roll)``; the torso frame is ``root · Rx(−waist_flex) Ry(waist_side) Rz(waist_twist)`` and the
head frame ``torso · Rx(−neck_flex) Ry(neck_side)``. A shoulder (hip) frame is ``torso (root) ·
Rx(flex) Ry(±abd) Rz(∓rot)`` with the upper signs on the left side, so that abduction and
internal rotation have the same anatomical meaning on both sides; the forearm is ``upper arm · Rx(elbow)``
and the shin ``thigh · Rx(−knee)``. Limbs hang along −z of their frame, the torso and head point
along +z; ``u1`` (half-axis ``H``) is the frame's x and ``u2`` (``W``) its y.

Joint positions: pelvis = root translation; thorax = pelvis + torso·z_torso; head top = thorax +
head·z_head; shoulders = thorax + torso-frame ``(∓offset, 0, −drop)``; hips = pelvis + root-frame
``(∓offset, 0, −drop)`` (left at −x); elbow, wrist, knee, ankle follow down the limbs.

>>> from voxelmocap.body.shapes import BodyDimensions
>>> kin = forward_kinematics(np.zeros((1, 27)), BodyDimensions.average())
>>> kin.joints.shape, kin.base.shape
((1, 15, 3), (1, 10, 3))
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .shapes import BodyDimensions

__all__ = [
    "Kinematics",
    "forward_kinematics",
    "forward_kinematics_numpy",
    "rotation_x",
    "rotation_y",
    "rotation_z",
]

# Joint rows of Kinematics.joints follow the 15 landmarks (joints.LANDMARK_NAMES).
THORAX, PELVIS, L_SHOULDER, L_ELBOW, L_WRIST, R_SHOULDER, R_ELBOW, R_WRIST = range(8)
L_HIP, L_KNEE, L_ANKLE, R_HIP, R_KNEE, R_ANKLE, HEAD_TOP = range(8, 15)


class Kinematics(NamedTuple):
    """Result of :func:`forward_kinematics` for P particles and the 10 parts.

    Attributes
    ----------
    base : (P, 10, 3) ndarray
        Centre of each part's base ellipse (mm), at its proximal joint.
    axis : (P, 10, 3) ndarray
        Unit vector from the base towards the far end (``n``).
    u1, u2 : (P, 10, 3) ndarray
        Unit cross-section axes of the half-axes ``H`` (lateral) and ``W`` (front-back).
    joints : (P, 15, 3) ndarray
        Joint positions (mm) in ``LANDMARK_NAMES`` order.
    """

    base: np.ndarray
    axis: np.ndarray
    u1: np.ndarray
    u2: np.ndarray
    joints: np.ndarray


def rotation_x(a) -> np.ndarray:
    """(..., 3, 3) rotations by angles ``a`` (rad) about x (right-hand rule)."""
    a = np.asarray(a, dtype=float)
    c, s = np.cos(a), np.sin(a)
    if a.ndim == 0:                       # one angle (the fits' inner loops): no stacking
        return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
    o, z = np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([o, z, z], -1), np.stack([z, c, -s], -1),
                     np.stack([z, s, c], -1)], -2)


def rotation_y(a) -> np.ndarray:
    """(..., 3, 3) rotations by angles ``a`` (rad) about y (right-hand rule)."""
    a = np.asarray(a, dtype=float)
    c, s = np.cos(a), np.sin(a)
    if a.ndim == 0:
        return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
    o, z = np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([c, z, s], -1), np.stack([z, o, z], -1),
                     np.stack([-s, z, c], -1)], -2)


def rotation_z(a) -> np.ndarray:
    """(..., 3, 3) rotations by angles ``a`` (rad) about z (right-hand rule)."""
    a = np.asarray(a, dtype=float)
    c, s = np.cos(a), np.sin(a)
    if a.ndim == 0:
        return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    o, z = np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1),
                     np.stack([z, z, o], -1)], -2)


def _mm(a, b):
    return np.matmul(a, b)


def _apply(rot, vec):
    """(P, 3, 3) @ (3,) or (P, 3) → (P, 3)."""
    return rot @ vec if np.ndim(vec) == 1 else np.einsum("pij,pj->pi", rot, vec)


def forward_kinematics(states, dims: BodyDimensions) -> Kinematics:
    """Joint positions and part frames of a batch of states (numba kernel).

    Same numbers (to rounding) as :func:`forward_kinematics_numpy`, the readable reference.

    Parameters
    ----------
    states : (P, 27) float ndarray
        Pose states (mm, rad), already validated (finite).
    dims : BodyDimensions
        Subject skeleton.

    Returns
    -------
    Kinematics
    """
    from ._kinematics_kernels import dims_vector, forward

    x = np.ascontiguousarray(states, dtype=np.float64)
    P = x.shape[0]
    base, axis, u1, u2 = (np.empty((P, 10, 3)) for _ in range(4))
    joints = np.empty((P, 15, 3))
    forward(x, dims_vector(dims), base, axis, u1, u2, joints)
    return Kinematics(base=base, axis=axis, u1=u1, u2=u2, joints=joints)


def forward_kinematics_numpy(states, dims: BodyDimensions) -> Kinematics:
    """Joint positions and part frames of a batch of states (numpy reference).

    Parameters
    ----------
    states : (P, 27) float ndarray
        Pose states (mm, rad), already validated (finite).
    dims : BodyDimensions
        Subject skeleton.

    Returns
    -------
    Kinematics
    """
    x = np.asarray(states, dtype=float)
    P = x.shape[0]
    root = _mm(_mm(rotation_z(x[:, 3]), rotation_x(-x[:, 4])), rotation_y(x[:, 5]))
    torso = _mm(root, _mm(_mm(rotation_x(-x[:, 6]), rotation_y(x[:, 7])), rotation_z(x[:, 8])))
    head = _mm(torso, _mm(rotation_x(-x[:, 9]), rotation_y(x[:, 10])))

    def limb(parent, i, sign):
        # flex, abd, rot at columns i, i+1, i+2; sign = +1 left, −1 right
        local = _mm(_mm(rotation_x(x[:, i]), rotation_y(sign * x[:, i + 1])),
                    rotation_z(-sign * x[:, i + 2]))
        return _mm(parent, local)

    l_uarm, r_uarm = limb(torso, 11, 1.0), limb(torso, 14, -1.0)
    l_farm = _mm(l_uarm, rotation_x(x[:, 17]))
    r_farm = _mm(r_uarm, rotation_x(x[:, 18]))
    l_thigh, r_thigh = limb(root, 19, 1.0), limb(root, 22, -1.0)
    l_shin = _mm(l_thigh, rotation_x(-x[:, 25]))
    r_shin = _mm(r_thigh, rotation_x(-x[:, 26]))

    up = np.array([0.0, 0.0, 1.0])
    down = -up
    d = dims
    joints = np.empty((P, 15, 3))
    pelvis = x[:, 0:3]
    thorax = pelvis + d.torso * _apply(torso, up)
    joints[:, PELVIS] = pelvis
    joints[:, THORAX] = thorax
    joints[:, HEAD_TOP] = thorax + d.head * _apply(head, up)
    for s, sign, (sh, el, wr), (ua, fa) in (
            (0, -1.0, (L_SHOULDER, L_ELBOW, L_WRIST), (l_uarm, l_farm)),
            (1, 1.0, (R_SHOULDER, R_ELBOW, R_WRIST), (r_uarm, r_farm))):
        joints[:, sh] = thorax + _apply(torso, np.array(
            [sign * d.shoulder_offset[s], 0.0, -d.shoulder_drop[s]]))
        joints[:, el] = joints[:, sh] + d.upper_arm[s] * _apply(ua, down)
        joints[:, wr] = joints[:, el] + d.forearm[s] * _apply(fa, down)
    for s, sign, (hp, kn, an), (th, sn) in (
            (0, -1.0, (L_HIP, L_KNEE, L_ANKLE), (l_thigh, l_shin)),
            (1, 1.0, (R_HIP, R_KNEE, R_ANKLE), (r_thigh, r_shin))):
        joints[:, hp] = pelvis + _apply(root, np.array(
            [sign * d.hip_offset[s], 0.0, -d.hip_drop[s]]))
        joints[:, kn] = joints[:, hp] + d.thigh[s] * _apply(th, down)
        joints[:, an] = joints[:, kn] + d.shin[s] * _apply(sn, down)

    # Parts in PART_NAMES order: (rotation, base joint, axis sign)
    frames = ((torso, PELVIS, 1.0), (head, THORAX, 1.0),
              (l_uarm, L_SHOULDER, -1.0), (l_farm, L_ELBOW, -1.0),
              (r_uarm, R_SHOULDER, -1.0), (r_farm, R_ELBOW, -1.0),
              (l_thigh, L_HIP, -1.0), (l_shin, L_KNEE, -1.0),
              (r_thigh, R_HIP, -1.0), (r_shin, R_KNEE, -1.0))
    rots = np.stack([f[0] for f in frames], axis=1)           # (P, 10, 3, 3)
    signs = np.array([f[2] for f in frames])
    base = joints[:, [f[1] for f in frames]]
    axis = rots[..., :, 2] * signs[None, :, None]
    u1 = np.ascontiguousarray(rots[..., :, 0])
    u2 = np.ascontiguousarray(rots[..., :, 1])
    return Kinematics(base=np.ascontiguousarray(base), axis=np.ascontiguousarray(axis),
                      u1=u1, u2=u2, joints=joints)
