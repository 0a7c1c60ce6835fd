"""Port of the HumanEva toolkit's ``@mocap_stream/cur_frame``: marker frames → 20 body_pose endpoints.

This is the arithmetic of the official HumanEva support code (v1.1 beta): ``cur_frame``,
``MarkerCoord2Xform`` and the ``@quaternion`` class, re-implemented with numpy over many stream
positions at once. It reproduces the toolkit's numbers, *quirks included*; every reproduced quirk
is marked ``QUIRK`` below and listed in ``docs/humaneva_mocap.md``. Reading the files and the
label lookup live in :mod:`voxelmocap.io.humaneva_mocap`; this module only computes.

Conventions (as in the toolkit): marker frames and stream positions are 1-based, units are mm,
``markers`` is ``(N, M, 3)`` (frame × marker × xyz) and a missing marker sample is ``(0, 0, 0)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = [
    "FRAMES",
    "HEAD_LENGTH",
    "LENGTH_PAIRS",
    "SEGMENT_NAMES",
    "VALIDITY_MARKERS",
    "MarkerIndex",
    "ToolkitPoses",
    "quat_from_matrix",
    "quat_slerp",
    "quat_to_matrix",
    "toolkit_cur_frames",
    "y_rotation",
]

#: The toolkit's hard-coded head length L18 (mm).
HEAD_LENGTH = 316.103

#: Segments of ``cur_frame(…, 'body_pose_xforms')``, in its order.
SEGMENT_NAMES = ("torso", "upperLArm", "lowerLArm", "upperRArm", "lowerRArm", "upperLLeg",
                 "lowerLLeg", "upperRLeg", "lowerRLeg", "head")

#: The 15 marker frames ``cur_frame`` builds, as (name, origin label of the axis set, label of
#: the joint centre that translates it, post-multiplied by yRotation(π)). The pelvis is built three
#: times with the same markers; one copy stands for all (they raise and fall back identically).
FRAMES = (
    ("pelvis", "PELO", "PELO", False),
    ("thorax", "TRXO", "TRXO", False),  # computed and discarded, but it can raise
    ("head", "HEDO", "TRXO", False),
    ("lclavicle", "LCLO", "LCLO", False),  # discarded too
    ("lshoulder", "LHUO", "LCLO", False),
    ("lelbow", "LRAO", "LHUO", False),
    ("rclavicle", "RCLO", "RCLO", False),  # discarded too
    ("rshoulder", "RHUO", "RCLO", False),
    ("relbow", "RRAO", "RHUO", False),
    ("lthigh", "LFEO", "LFEP", True),
    ("ltibia", "LTIO", "LFEO", True),
    ("rthigh", "RFEO", "RFEP", True),
    ("rtibia", "RTIO", "RFEO", True),
)

#: The 18 limb lengths as (from, to) joint-centre labels; None is a constant (0, or L18).
LENGTH_PAIRS = (
    ("TRXO", "PELO"), ("PELO", "LFEP"), ("LFEP", "LFEO"), ("LFEO", "LTIO"), None,
    ("PELO", "RFEP"), ("RFEP", "RFEO"), ("RFEO", "RTIO"), None,
    ("TRXO", "LCLO"), ("LCLO", "LHUO"), ("LHUO", "LRAO"), None,
    ("TRXO", "RCLO"), ("RCLO", "RHUO"), ("RHUO", "RRAO"), None,
    None,
)

#: The 39 physical markers of the validity test, in the toolkit's order; a tuple means "the
#: smallest index matching any of these spellings".
VALIDITY_MARKERS = (
    "RASI", "LASI", "LPSI", "RELB", "STRN", "LTHI", "LWRA", "LELB", "T10", "RWRA", "RUPA", "RKNE",
    "RBAK", "LKNE", "CLAV", "RSHO", "LSHO", "C7", "RTIB", "LTIB", "LBHD", "RBHD", "RFHD", "LFHD",
    "LANK", "LHEE", "RANK", "LTOE", "RTOE", "RHEE", "LFIN", ("RFRM", "RFRA"), ("LFRM", "LFRA"),
    "RWRB", "RFIN", "LWRB", "RTHI", "LUPA", "RPSI",
)

_DOT_LIMIT = 1e-4  # MarkerCoord2Xform's orthogonality threshold
_SMALL_SINE = 1e-6  # mpower's small-angle switch
_UNIT_TOLERANCE = 1e-5  # from_matrix stops (MATLAB `keyboard`) beyond this


@dataclass(frozen=True)
class MarkerIndex:
    """0-based marker columns that ``cur_frame`` reads, resolved from the labels.

    Attributes
    ----------
    label : dict of str to int
        Column of every axis-set origin and joint-centre label used.
    validity : (39,) int ndarray
        Columns of the 39 physical markers of the validity test.
    """

    label: dict
    validity: np.ndarray


@dataclass
class ToolkitPoses:
    """What ``cur_frame`` returns at a batch of stream positions.

    Attributes
    ----------
    positions : (F,) float ndarray
        1-based fractional mocap positions p.
    status : (F,) str ndarray
        ``"ok"``; ``"empty"`` (ceil(p) past the end: the toolkit returns ``[]`` and valid 0); or
        ``"error"`` (the toolkit raises: row 0 or N+1 read, or ``Bad marker data.``).
    message : list of str
        Why a row is an error ("" otherwise).
    valid : (F,) bool ndarray
        The toolkit's validity flag (False for empty and error rows).
    endpoints : (F, 20, 3) float ndarray
        The 20 endpoints in body_pose order, mm; NaN on empty and error rows (and where the
        toolkit itself yields NaN).
    lengths : (F, 18) float ndarray
        ``cur_frame(…, 'body_lengths')``; NaN on empty and error rows.
    xforms : (F, 10, 4, 4) float ndarray
        Global transforms in :data:`SEGMENT_NAMES` order; NaN on empty and error rows.
    bad_marker_warning : (F,) bool ndarray
        Whether a frame fell back to identity axes (the toolkit's ``Bad marker data.`` warning).
    """

    positions: np.ndarray
    status: np.ndarray
    message: list
    valid: np.ndarray
    endpoints: np.ndarray
    lengths: np.ndarray
    xforms: np.ndarray
    bad_marker_warning: np.ndarray


# ---------------------------------------------------------------------- rotation helpers
def y_rotation(theta) -> np.ndarray:
    """The toolkit's ``yRotation(θ)``: ``(..., 4, 4)``, the *transpose* of the usual R_y(θ).

    QUIRK: +sin θ sits at row 3, column 1; and sin(π) = 1.2246e-16 is kept, not rounded to 0.
    """
    theta = np.asarray(theta, float)
    c, s = np.cos(theta), np.sin(theta)
    out = np.zeros(theta.shape + (4, 4))
    out[..., 0, 0] = c
    out[..., 0, 2] = -s
    out[..., 1, 1] = 1.0
    out[..., 2, 0] = s
    out[..., 2, 2] = c
    out[..., 3, 3] = 1.0
    return out


def _translate(v) -> np.ndarray:
    v = np.asarray(v, float)
    out = np.broadcast_to(np.eye(4), v.shape[:-1] + (4, 4)).copy()
    out[..., :3, 3] = v
    return out


def _norm3(v: np.ndarray) -> np.ndarray:
    return np.sqrt((v[..., 0] * v[..., 0] + v[..., 1] * v[..., 1]) + v[..., 2] * v[..., 2])


def _dot3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return (a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1]) + a[..., 2] * b[..., 2]


def _quat_norm(q: np.ndarray) -> np.ndarray:
    # sqrt(sum(value.^2)), summed left to right as MATLAB does for four terms
    return np.sqrt(((q[..., 0] ** 2 + q[..., 1] ** 2) + q[..., 2] ** 2) + q[..., 3] ** 2)


def quat_from_matrix(m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The toolkit's ``@quaternion/from_matrix`` (a port of VXL's), batched.

    Parameters
    ----------
    m : (..., 3, 3) float ndarray
        Rotation matrices (not necessarily orthonormal: the toolkit does not orthogonalise).

    Returns
    -------
    q : (..., 4) float ndarray
        ``(w, x, y, z)``.
    non_unit : (...,) bool ndarray
        Where ``|1 − ‖q‖| > 1e-5``: the toolkit stops in the debugger there.
    """
    d0, d1, d2 = m[..., 0, 0], m[..., 1, 1], m[..., 2, 2]
    # QUIRK: the four diagonal terms, evaluated left to right, and the *first* maximum in the
    # order xx, yy, zz, rr decide the branch; this changes the result at ~1e-4 mm on real data.
    terms = np.stack([((1.0 + d0) - d1) - d2, ((1.0 - d0) + d1) - d2,
                      ((1.0 - d0) - d1) + d2, ((1.0 + d0) + d1) + d2], axis=-1)
    # MATLAB's max ignores NaN and answers index 1 when everything is NaN.
    branch = np.argmax(np.where(np.isnan(terms), -np.inf, terms), axis=-1)
    best = np.take_along_axis(terms, branch[..., None], axis=-1)[..., 0]
    with np.errstate(invalid="ignore", divide="ignore"):
        a = 0.5 * np.sqrt(best)
        a4 = 4 * a
        m32_23 = (m[..., 2, 1] - m[..., 1, 2]) / a4
        m13_31 = (m[..., 0, 2] - m[..., 2, 0]) / a4
        m21_12 = (m[..., 1, 0] - m[..., 0, 1]) / a4
        p12_21 = (m[..., 0, 1] + m[..., 1, 0]) / a4
        p13_31 = (m[..., 0, 2] + m[..., 2, 0]) / a4
        p23_32 = (m[..., 1, 2] + m[..., 2, 1]) / a4
    choices = np.stack([
        np.stack([m32_23, a, p12_21, p13_31], axis=-1),  # xx
        np.stack([m13_31, p12_21, a, p23_32], axis=-1),  # yy
        np.stack([m21_12, p13_31, p23_32, a], axis=-1),  # zz
        np.stack([a, m32_23, m13_31, m21_12], axis=-1),  # rr
    ], axis=-2)
    q = np.take_along_axis(choices, branch[..., None, None], axis=-2)[..., 0, :]
    # abs(1 − NaN) > 1e-5 is false in MATLAB too: a NaN quaternion passes on.
    non_unit = np.abs(1 - _quat_norm(q)) > _UNIT_TOLERANCE
    return q, non_unit


def _quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    a1, a2, a3, a4 = (a[..., i] for i in range(4))
    b1, b2, b3, b4 = (b[..., i] for i in range(4))
    return np.stack([((a1 * b1 - a2 * b2) - a3 * b3) - a4 * b4,
                     ((a1 * b2 + a2 * b1) + a3 * b4) - a4 * b3,
                     ((a1 * b3 - a2 * b4) + a3 * b1) + a4 * b2,
                     ((a1 * b4 + a2 * b3) - a3 * b2) + a4 * b1], axis=-1)


def _quat_conj(q: np.ndarray) -> np.ndarray:
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def _quat_power(q: np.ndarray, t: np.ndarray) -> np.ndarray:
    """``@quaternion/mpower``: ``q^t`` with the toolkit's small-angle branch."""
    n = _quat_norm(q)
    with np.errstate(invalid="ignore", divide="ignore"):
        tmp = q / n[..., None]
        # w/‖q‖ can exceed 1 by an ulp; MATLAB's acos then goes complex with an imaginary part
        # ~1e-8 that the small-angle branch below carries along and the final output drops.
        # Clipping gives that real part.
        theta = np.arccos(np.clip(tmp[..., 0], -1.0, 1.0))
        stheta = np.sin(theta)
        large = np.abs(stheta) > _SMALL_SINE
        scale = n ** t
        vec_large = np.sin(t * theta)[..., None] * (tmp[..., 1:] / stheta[..., None])
        vec_small = t[..., None] * tmp[..., 1:]
    vec = np.where(large[..., None], vec_large, vec_small)
    return scale[..., None] * np.concatenate([np.cos(t * theta)[..., None], vec], axis=-1)


def quat_slerp(qf: np.ndarray, qc: np.ndarray, t) -> np.ndarray:
    """``@quaternion/slerp``: ``qf ⊗ (qf* ⊗ qc′)^t`` (batched).

    QUIRK: ``qc′ = −qc`` iff the dot product of the two *vector parts* is negative (w is ignored),
    so two quaternions near the identity with vector parts of opposite signs are interpolated the
    long way round, through a 180° rotation. Reproduced, not fixed.
    """
    t = np.asarray(t, float)
    flip = _dot3(qf[..., 1:], qc[..., 1:]) < 0
    qc = np.where(flip[..., None], -qc, qc)
    return _quat_mul(qf, _quat_power(_quat_mul(_quat_conj(qf), qc), t))


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """``@quaternion/to_matrix``: normalise, then the euclideanspace.com formula. ``(..., 3, 3)``."""
    q = q / _quat_norm(q)[..., None]
    w, x, y, z = (q[..., i] for i in range(4))
    m = np.empty(q.shape[:-1] + (3, 3))
    m[..., 0, 0] = 1 + 2 * (-y ** 2 - z ** 2)
    m[..., 0, 1] = 2 * (x * y - w * z)
    m[..., 0, 2] = 2 * (x * z + w * y)
    m[..., 1, 0] = 2 * (x * y + w * z)
    m[..., 1, 1] = 1 + 2 * (-x ** 2 - z ** 2)
    m[..., 1, 2] = 2 * (y * z - w * x)
    m[..., 2, 0] = 2 * (x * z - w * y)
    m[..., 2, 1] = 2 * (y * z + w * x)
    m[..., 2, 2] = 1 + 2 * (-x ** 2 - y ** 2)
    return m


# ---------------------------------------------------------------------- one marker frame
def _marker_frame(markers, coord: int, joint: int, f0: np.ndarray, f1: np.ndarray,
                  alpha: np.ndarray, post_pi: bool):
    """``MarkerCoord2Xform`` for a batch: ``(T (F, 4, 4), fallback (F,), bad (F,), non_unit (F,))``.

    ``f0``/``f1`` are the 0-based rows floor(p) − 1 and floor(p) (i.e. frames floor(p) and
    floor(p) + 1), already clipped into range by the caller.
    """
    pts = {}
    # QUIRK: the axis points are taken *by position* after the origin label: +1 is the z axis,
    # +2 the x axis and +3 the y axis, whatever they are called.
    for key, offset in (("o", 0), ("z", 1), ("x", 2), ("y", 3)):
        pts[key] = (markers[f0, coord + offset], markers[f1, coord + offset])
    fallback = np.zeros(len(f0), bool)
    for pair in pts.values():
        for p in pair:
            fallback |= np.all(p == 0, axis=-1)
    # QUIRK: one missing axis point in either frame resets *both* frames to identity axes; the
    # joint-centre translation below is still interpolated (zeros included).
    identity = {"o": (0.0, 0.0, 0.0), "x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0),
                "z": (0.0, 0.0, 1.0)}
    for key in pts:
        pts[key] = tuple(np.where(fallback[:, None], identity[key], p) for p in pts[key])
    rotations, bad = [], np.zeros(len(f0), bool)
    with np.errstate(invalid="ignore", divide="ignore"):
        for side in (0, 1):
            axes = {}
            for key in ("x", "y", "z"):
                v = pts[key][side] - pts["o"][side]
                axes[key] = v / _norm3(v)[:, None]
            # QUIRK: one-sided test, only dot products > 1e-4 raise; NaN never does.
            bad |= (_dot3(axes["x"], axes["y"]) > _DOT_LIMIT) \
                | (_dot3(axes["x"], axes["z"]) > _DOT_LIMIT) \
                | (_dot3(axes["y"], axes["z"]) > _DOT_LIMIT)
            rotations.append(np.stack([axes["x"], axes["y"], axes["z"]], axis=-2))
    qf, non_unit_f = quat_from_matrix(rotations[0])
    qc, non_unit_c = quat_from_matrix(rotations[1])
    local_rot_global = np.zeros((len(f0), 4, 4))
    local_rot_global[:, :3, :3] = quat_to_matrix(quat_slerp(qf, qc, alpha))
    local_rot_global[:, 3, 3] = 1.0
    origin = (1 - alpha)[:, None] * markers[f0, joint] + alpha[:, None] * markers[f1, joint]
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        # globalTRANSlocal * inv(localROTglobal) * rot_offset, the offset being eye(4) when
        # none is given: multiplying by it is kept, as 0·NaN spreads a NaN as in MATLAB.
        xform = _translate(origin) @ _safe_inv(local_rot_global) \
            @ (y_rotation(np.pi) if post_pi else np.eye(4))
    return xform, fallback, bad, non_unit_f | non_unit_c


def _safe_inv(m: np.ndarray) -> np.ndarray:
    # inv() of [R 0; 0 1] as MATLAB does it (LU); a NaN matrix gives NaN rather than an exception.
    finite = np.all(np.isfinite(m), axis=(-2, -1))
    out = np.full_like(m, np.nan)
    if finite.any():
        try:
            out[finite] = np.linalg.inv(m[finite])
        except np.linalg.LinAlgError:  # singular: only from NaN-free garbage rotations
            for i in np.flatnonzero(finite):
                try:
                    out[i] = np.linalg.inv(m[i])
                except np.linalg.LinAlgError:
                    out[i] = np.inf
    return out


def _limb_length(markers, a: int, b: int, r0: np.ndarray, r1: np.ndarray) -> np.ndarray:
    """``LimbLength`` over the two rows: mean |a − b|, dropping all-zero samples; NaN if none."""
    total = np.zeros(len(r0))
    count = np.zeros(len(r0))
    for rows in (r0, r1):
        pa, pb = markers[rows, a], markers[rows, b]
        keep = ~(np.all(pa == 0, axis=-1) | np.all(pb == 0, axis=-1))
        d = pa - pb
        dist = np.sqrt((d[:, 0] ** 2 + d[:, 1] ** 2) + d[:, 2] ** 2)
        total = np.where(keep, total + dist, total)
        count += keep
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, total / count, np.nan)


def _apply(xform: np.ndarray, z) -> np.ndarray:
    """``T(1:3,:) * [0; 0; z; 1]`` as a full product, so NaN anywhere in T propagates (0·NaN)."""
    z = np.broadcast_to(np.asarray(z, float), xform.shape[:-2])
    vec = np.stack([np.zeros_like(z), np.zeros_like(z), z, np.ones_like(z)], axis=-1)
    with np.errstate(invalid="ignore", over="ignore"):
        return (xform[..., :3, :] @ vec[..., None])[..., 0]


# ---------------------------------------------------------------------- cur_frame
def toolkit_cur_frames(markers: np.ndarray, index: MarkerIndex, params: np.ndarray,
                       positions) -> ToolkitPoses:
    """``cur_frame(stream, k, mode)`` at many stream positions p = offset + (k − 1)·scaling.

    Parameters
    ----------
    markers : (N, M, 3) float ndarray
        The trial's marker trajectories (mm; missing samples are (0, 0, 0)).
    index : MarkerIndex
        Marker columns resolved from the trial's labels.
    params : (10, 5) float ndarray
        The limb parameters (``ComputeLimbParameters`` of the static trial and the ``.mp``).
    positions : (F,) array_like of float
        1-based fractional stream positions.

    Returns
    -------
    ToolkitPoses
    """
    markers = np.asarray(markers, float)
    p = np.asarray(positions, float).reshape(-1)
    n = markers.shape[0]
    n_pos = len(p)
    floor = np.floor(p)
    ceil = np.ceil(p)
    # QUIRK: the end test looks at ceil(p) only, but the transforms read floor(p) + 1; at integer
    # p = N that is row N + 1, an error. Rows below 1 are an error as well (p < 1).
    empty = ~(ceil <= n)  # NaN positions count as past the end
    out_of_range = ~empty & ((floor < 1) | (floor + 1 > n))
    live = ~(empty | out_of_range)
    rf = np.clip(floor, 1, n).astype(int) - 1  # row floor(p)
    rc = np.clip(ceil, 1, n).astype(int) - 1  # row ceil(p)  (validity and lengths)
    r1 = np.clip(floor + 1, 1, n).astype(int) - 1  # row floor(p) + 1  (transforms)
    alpha = p - floor
    alpha = np.where(np.isfinite(alpha), alpha, 0.0)

    # validity: QUIRK the coordinate *sum* is tested for zero, not "all three are zero"
    valid = np.ones(n_pos, bool)
    for rows in (rf, rc):
        pts = markers[rows][:, index.validity]
        valid &= ~np.any((pts[..., 0] + pts[..., 1]) + pts[..., 2] == 0, axis=-1)

    lab = index.label
    lengths = np.zeros((n_pos, 18))
    for i, pair in enumerate(LENGTH_PAIRS):
        if pair is not None:
            lengths[:, i] = _limb_length(markers, lab[pair[0]], lab[pair[1]], rf, rc)
    lengths[:, 17] = HEAD_LENGTH

    xf, fallback, bad, non_unit = {}, np.zeros(n_pos, bool), np.zeros(n_pos, bool), \
        np.zeros(n_pos, bool)
    for name, coord, joint, post_pi in FRAMES:
        xf[name], fb, b, nu = _marker_frame(markers, lab[coord], lab[joint], rf, r1, alpha,
                                            post_pi)
        fallback |= fb
        bad |= b
        non_unit |= nu

    with np.errstate(invalid="ignore", over="ignore"):
        # the pelvis is first multiplied by [eye(3) 0; 0 1] (kept for its NaN spreading)
        torso = xf["pelvis"] @ np.eye(4) @ _translate(np.array([-50.0, 0.0, 0.0])) \
            @ y_rotation(np.arctan2(params[0, 0] / 2, lengths[:, 0]))
        arms = {}
        for side, upper_len, offset in (("l", 10, params[5, 0]), ("r", 14, params[7, 0])):
            shoulder, elbow = xf[f"{side}shoulder"], xf[f"{side}elbow"].copy()
            length = lengths[:, upper_len]
            angle = np.arctan2(offset / 2, length)
            diff = _apply(elbow, 0.0) - _apply(shoulder, -length)
            shoulder = shoulder @ y_rotation(-angle)
            elbow[:, :3, 3] = _apply(shoulder, -length) + diff
            arms[side] = (shoulder, elbow @ y_rotation(angle))

    xforms = np.stack([torso, arms["l"][0], arms["l"][1], arms["r"][0], arms["r"][1],
                       xf["lthigh"], xf["ltibia"], xf["rthigh"], xf["rtibia"], xf["head"]], axis=1)
    L = lengths
    endpoints = np.stack([
        _apply(torso, L[:, 0]), _apply(torso, 0.0),
        _apply(arms["l"][0], 0.0), _apply(arms["l"][0], -L[:, 10]),
        _apply(arms["l"][1], 0.0), _apply(arms["l"][1], -L[:, 11]),
        _apply(arms["r"][0], 0.0), _apply(arms["r"][0], -L[:, 14]),
        _apply(arms["r"][1], 0.0), _apply(arms["r"][1], -L[:, 15]),
        _apply(xf["lthigh"], 0.0), _apply(xf["lthigh"], L[:, 2]),
        _apply(xf["ltibia"], 0.0), _apply(xf["ltibia"], L[:, 3]),
        _apply(xf["rthigh"], 0.0), _apply(xf["rthigh"], L[:, 6]),
        _apply(xf["rtibia"], 0.0), _apply(xf["rtibia"], L[:, 7]),
        _apply(xf["head"], 0.0), _apply(xf["head"], L[:, 17]),
    ], axis=1)

    status = np.full(n_pos, "ok", dtype=object)
    message = [""] * n_pos
    for i in range(n_pos):
        if empty[i]:
            status[i] = "empty"
        elif out_of_range[i]:
            status[i] = "error"
            message[i] = (f"position {p[i]:.17g} reads mocap frame "
                          f"{int(floor[i]) if floor[i] < 1 else int(floor[i]) + 1} of 1..{n}")
        elif bad[i]:
            status[i] = "error"
            message[i] = "Bad marker data. (axis markers not orthogonal)"
        elif non_unit[i]:
            status[i] = "error"
            message[i] = "rotation gives a non-unit quaternion (the toolkit stops in the debugger)"
    failed = status != "ok"
    valid &= ~failed
    for arr in (endpoints, lengths, xforms):
        arr[failed] = np.nan
    return ToolkitPoses(positions=p, status=status.astype(str), message=message, valid=valid,
                        endpoints=endpoints, lengths=lengths, xforms=xforms,
                        bad_marker_warning=fallback & live)
