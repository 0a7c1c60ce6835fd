"""Numba forward kinematics: the same frames and joints as ``kinematics.forward_kinematics_numpy``.

Rotations are applied in place on the right of 3×3 frames (``M ← M·Rx(a)`` etc.), following the
composition documented in :mod:`voxelmocap.body.kinematics`. ``dims`` is the (20,) float64 vector
of :func:`dims_vector`; outputs are C-contiguous float64 arrays ``base, axis, u1, u2 (P, 10, 3)``
and ``joints (P, 15, 3)``. The numpy version is the readable reference; tests hold the two
together to 1e-9 mm.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

# index of each length in the dims vector
TORSO, HEAD = 0, 1
SH_OFF, SH_DROP, HIP_OFF, HIP_DROP = 2, 4, 6, 8          # (left, right) pairs
UPPER_ARM, FOREARM, THIGH, SHIN = 10, 12, 14, 16


def dims_vector(d) -> np.ndarray:
    """(20,) float64 lengths of a :class:`~voxelmocap.body.shapes.BodyDimensions`."""
    v = [d.torso, d.head, *d.shoulder_offset, *d.shoulder_drop, *d.hip_offset, *d.hip_drop,
         *d.upper_arm, *d.forearm, *d.thigh, *d.shin, 0.0, 0.0]
    return np.array(v, dtype=np.float64)


@njit(cache=True, inline="always")
def _rx(m, a):
    c = math.cos(a)
    s = math.sin(a)
    for r in range(3):
        y = m[r, 1]
        z = m[r, 2]
        m[r, 1] = y * c + z * s
        m[r, 2] = z * c - y * s


@njit(cache=True, inline="always")
def _ry(m, a):
    c = math.cos(a)
    s = math.sin(a)
    for r in range(3):
        x = m[r, 0]
        z = m[r, 2]
        m[r, 0] = x * c - z * s
        m[r, 2] = x * s + z * c


@njit(cache=True, inline="always")
def _rz(m, a):
    c = math.cos(a)
    s = math.sin(a)
    for r in range(3):
        x = m[r, 0]
        y = m[r, 1]
        m[r, 0] = x * c + y * s
        m[r, 1] = y * c - x * s


@njit(cache=True, inline="always")
def _set_part(m, q, p, joint, sign, base, axis, u1, u2, joints):
    for e in range(3):
        base[p, q, e] = joints[p, joint, e]
        axis[p, q, e] = sign * m[e, 2]
        u1[p, q, e] = m[e, 0]
        u2[p, q, e] = m[e, 1]


@njit(cache=True)
def forward(states, dims, base, axis, u1, u2, joints):
    """Fill the part frames and joints of every state (see the module docstring).

    Serial: at well under a microsecond per state it is not worth waking threads for.
    """
    fr = np.empty((11, 3, 3))  # root torso head l_ua l_fa r_ua r_fa l_th l_sh r_th r_sh
    for p in range(states.shape[0]):
        x = states[p]
        fr[:] = 0.0
        root = fr[0]
        for e in range(3):
            root[e, e] = 1.0
        _rz(root, x[3])
        _rx(root, -x[4])
        _ry(root, x[5])
        torso = fr[1]
        torso[:] = root
        _rx(torso, -x[6])
        _ry(torso, x[7])
        _rz(torso, x[8])
        head = fr[2]
        head[:] = torso
        _rx(head, -x[9])
        _ry(head, x[10])
        for side in range(2):
            sign = 1.0 - 2.0 * side               # +1 left, −1 right
            ua = fr[3 + 2 * side]
            fa = fr[4 + 2 * side]
            ua[:] = torso
            _rx(ua, x[11 + 3 * side])
            _ry(ua, sign * x[12 + 3 * side])
            _rz(ua, -sign * x[13 + 3 * side])
            fa[:] = ua
            _rx(fa, x[17 + side])
            th = fr[7 + 2 * side]
            sh = fr[8 + 2 * side]
            th[:] = root
            _rx(th, x[19 + 3 * side])
            _ry(th, sign * x[20 + 3 * side])
            _rz(th, -sign * x[21 + 3 * side])
            sh[:] = th
            _rx(sh, -x[25 + side])
        # joints, in LANDMARK_NAMES order
        for e in range(3):
            joints[p, 1, e] = x[e]
            joints[p, 0, e] = x[e] + dims[TORSO] * torso[e, 2]
            joints[p, 14, e] = joints[p, 0, e] + dims[HEAD] * head[e, 2]
        for side in range(2):
            lat = 2.0 * side - 1.0                # left at −x, right at +x
            ua = fr[3 + 2 * side]
            fa = fr[4 + 2 * side]
            th = fr[7 + 2 * side]
            sh = fr[8 + 2 * side]
            js = 2 + 3 * side                     # shoulder, elbow, wrist
            jh = 8 + 3 * side                     # hip, knee, ankle
            for e in range(3):
                joints[p, js, e] = joints[p, 0, e] + (lat * dims[SH_OFF + side] * torso[e, 0]
                                                      - dims[SH_DROP + side] * torso[e, 2])
                joints[p, js + 1, e] = joints[p, js, e] - dims[UPPER_ARM + side] * ua[e, 2]
                joints[p, js + 2, e] = joints[p, js + 1, e] - dims[FOREARM + side] * fa[e, 2]
                joints[p, jh, e] = x[e] + (lat * dims[HIP_OFF + side] * root[e, 0]
                                           - dims[HIP_DROP + side] * root[e, 2])
                joints[p, jh + 1, e] = joints[p, jh, e] - dims[THIGH + side] * th[e, 2]
                joints[p, jh + 2, e] = joints[p, jh + 1, e] - dims[SHIN + side] * sh[e, 2]
        _set_part(torso, 0, p, 1, 1.0, base, axis, u1, u2, joints)
        _set_part(head, 1, p, 0, 1.0, base, axis, u1, u2, joints)
        _set_part(fr[3], 2, p, 2, -1.0, base, axis, u1, u2, joints)
        _set_part(fr[4], 3, p, 3, -1.0, base, axis, u1, u2, joints)
        _set_part(fr[5], 4, p, 5, -1.0, base, axis, u1, u2, joints)
        _set_part(fr[6], 5, p, 6, -1.0, base, axis, u1, u2, joints)
        _set_part(fr[7], 6, p, 8, -1.0, base, axis, u1, u2, joints)
        _set_part(fr[8], 7, p, 9, -1.0, base, axis, u1, u2, joints)
        _set_part(fr[9], 8, p, 11, -1.0, base, axis, u1, u2, joints)
        _set_part(fr[10], 9, p, 12, -1.0, base, axis, u1, u2, joints)
