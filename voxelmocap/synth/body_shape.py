"""The rendered body: capsules and ellipsoids dressed in clothing colours, and the subject file.

The body drawn into the synthetic images is deliberately *not* the tracker's truncated-cone
model: limbs are capsules with ellipsoidal muscle and clothing bulges (thigh and calf bulges,
T-shirt sleeves, a loose shirt hem), the trunk is three blended ellipsoids (pelvis, abdomen,
chest) plus a shirt-hem bulge, the head is an ellipsoid with a hair cap, hands and shoes are
flattened ellipsoids. Proportions come from the motion's canonical points (bone lengths of the
clip's skeleton); widths come from the subject's :class:`BodyShape` (scaled by stature, varied
per subject by a seed). Clothing colours per part: shirt, trousers, skin, hair, shoes.

:func:`body_primitives` turns canonical points ``(20, 3)`` into flat arrays for the numba ray
caster (:mod:`voxelmocap.synth._render_kernels`); :func:`subject_body` measures the subject's
dimensions from the truth, which the writer stores as ``<Subject>_body.toml``
(:mod:`voxelmocap.io.body_file`, see ``docs/synth.md``).
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass, field

import numpy as np

from ..body.shapes import BodyDimensions
from .skeletons import CANONICAL_NAMES

__all__ = ["BodyShape", "Primitives", "body_primitives", "subject_body"]

_C = {name: i for i, name in enumerate(CANONICAL_NAMES)}

# Clothing palettes (BGR, 0..1): picked per subject.
_SHIRTS = [(0.20, 0.25, 0.70), (0.65, 0.35, 0.15), (0.25, 0.55, 0.25), (0.75, 0.75, 0.72),
           (0.15, 0.60, 0.80), (0.45, 0.20, 0.45)]
_TROUSERS = [(0.35, 0.22, 0.12), (0.15, 0.15, 0.17), (0.45, 0.45, 0.42), (0.30, 0.40, 0.55)]
_SKINS = [(0.55, 0.66, 0.85), (0.42, 0.52, 0.72), (0.30, 0.38, 0.52), (0.62, 0.72, 0.90)]
_HAIR = [(0.08, 0.08, 0.10), (0.10, 0.20, 0.35), (0.30, 0.45, 0.60), (0.15, 0.12, 0.10)]
_SHOES = [(0.10, 0.10, 0.10), (0.85, 0.85, 0.85), (0.15, 0.20, 0.35)]


def _subject_rng(subject: str) -> np.random.Generator:
    # A stable per-subject stream (crc32 is stable across runs, unlike hash()).
    return np.random.default_rng(zlib.crc32(subject.encode("utf-8")))


@dataclass(frozen=True)
class BodyShape:
    """Flesh half-widths (mm) and clothing colours of a rendered subject.

    Build it with :meth:`for_subject`; all widths scale with the stature.
    """

    height: float
    torso: tuple[float, float]          # lateral, front-back half-widths at the pelvis
    chest: tuple[float, float]          # lateral, front-back at the chest
    head: tuple[float, float, float]    # lateral, front-back, vertical semi-axes
    neck: float
    upper_arm: float
    forearm: float
    thigh: float
    shin: float
    colours: dict[str, tuple[float, float, float]] = field(default_factory=dict)

    @classmethod
    def for_subject(cls, subject: str, height: float) -> BodyShape:
        """The shape of subject ``subject`` at stature ``height`` (mm), varied ±8 % per subject."""
        rng = _subject_rng(subject)
        k = height / 1750.0
        v = lambda: rng.uniform(0.92, 1.08)  # noqa: E731
        girth = v()
        colours = {
            "shirt": _SHIRTS[rng.integers(len(_SHIRTS))],
            "trousers": _TROUSERS[rng.integers(len(_TROUSERS))],
            "skin": _SKINS[rng.integers(len(_SKINS))],
            "hair": _HAIR[rng.integers(len(_HAIR))],
            "shoes": _SHOES[rng.integers(len(_SHOES))],
        }
        return cls(
            height=height,
            torso=(155 * k * girth, 105 * k * girth * v()),
            chest=(165 * k * girth, 110 * k * girth * v()),
            head=(78 * k * v(), 98 * k, 118 * k),
            neck=52 * k,
            upper_arm=47 * k * girth,
            forearm=38 * k * girth,
            thigh=78 * k * girth * v(),
            shin=52 * k * girth,
            colours=colours,
        )


@dataclass
class Primitives:
    """Flat arrays of one frame's body for the ray caster.

    Attributes
    ----------
    capsules : (Nc, 7) float64
        ``ax ay az bx by bz r``: segment ends (mm) and radius (mm).
    capsule_colours : (Nc, 3) float64
        BGR reflectance in [0, 1].
    ellipsoids : (Ne, 12) float64
        ``cx cy cz`` centre (mm), then the row-major 3×3 matrix ``A`` mapping world offsets from
        the centre onto the unit sphere (``A = diag(1/semi-axes) · Rᵀ``).
    ellipsoid_colours : (Ne, 3) float64
        BGR reflectance.
    """

    capsules: np.ndarray
    capsule_colours: np.ndarray
    ellipsoids: np.ndarray
    ellipsoid_colours: np.ndarray

    def bounding_points(self) -> np.ndarray:
        """(M, 3) points whose convex hull, grown by :meth:`max_radius`, holds the body (mm)."""
        pts = [self.capsules[:, 0:3], self.capsules[:, 3:6], self.ellipsoids[:, 0:3]]
        return np.concatenate(pts, axis=0)

    def radii(self) -> np.ndarray:
        """(M,) bounding radius of each point of :meth:`bounding_points`."""
        r_c = self.capsules[:, 6]
        # Largest semi-axis of each ellipsoid = 1 / smallest singular value of A.
        A = self.ellipsoids[:, 3:12].reshape(-1, 3, 3)
        r_e = 1.0 / np.linalg.svd(A, compute_uv=False)[:, -1]
        return np.concatenate([r_c, r_c, r_e])


def _unit(v):
    n = np.linalg.norm(v)
    return v / n if n > 1e-9 else v


def _ortho(v, ref):
    """``ref`` made perpendicular to the unit vector ``v`` and normalised (fallbacks if parallel)."""
    w = ref - (ref @ v) * v
    if np.linalg.norm(w) < 1e-6:
        w = np.array([1.0, 0.0, 0.0]) - v[0] * v
    return _unit(w)


def _ellipsoid(centre, axes, semi):
    """Row of :attr:`Primitives.ellipsoids`: ``axes`` (3, 3) columns = unit axes, ``semi`` (3,)."""
    A = np.diag(1.0 / np.asarray(semi, dtype=float)) @ np.asarray(axes).T
    return np.concatenate([centre, A.reshape(-1)])


def _frame_along(main, ref):
    """Orthonormal columns (main, side, third) with ``main`` first."""
    a = _unit(main)
    b = _ortho(a, ref)
    return np.stack([a, b, np.cross(a, b)], axis=1)


def body_primitives(points, shape: BodyShape) -> Primitives:
    """Capsules and ellipsoids of the body in one frame.

    Parameters
    ----------
    points : (20, 3) array_like
        Canonical points (mm).
    shape : BodyShape
        Widths and colours.
    """
    p = {name: np.asarray(points[i], dtype=float) for name, i in _C.items()}
    col = shape.colours
    caps, cap_col, ells, ell_col = [], [], [], []

    def capsule(a, b, r, c):
        caps.append(np.concatenate([a, b, [r]]))
        cap_col.append(col[c])

    def ellipsoid(centre, axes, semi, c):
        ells.append(_ellipsoid(centre, axes, semi))
        ell_col.append(col[c])

    up_t = _unit(p["thorax"] - p["pelvis"])
    left_p = _ortho(up_t, p["l_hip"] - p["r_hip"])
    left_c = _ortho(up_t, p["l_shoulder"] - p["r_shoulder"])
    fwd_p = np.cross(left_p, up_t)
    fwd_c = np.cross(left_c, up_t)
    torso_len = np.linalg.norm(p["thorax"] - p["pelvis"])
    # Trunk: pelvis, abdomen and chest ellipsoids overlap into one smooth, non-conical trunk.
    ellipsoid(p["pelvis"] + up_t * 0.05 * torso_len, np.stack([left_p, fwd_p, up_t], 1),
              (shape.torso[0], shape.torso[1], 0.30 * torso_len), "trousers")
    ellipsoid(p["pelvis"] + up_t * 0.45 * torso_len, np.stack([left_c, fwd_c, up_t], 1),
              (0.93 * shape.chest[0], 0.95 * shape.chest[1], 0.33 * torso_len), "shirt")
    ellipsoid(p["pelvis"] + up_t * 0.24 * torso_len + fwd_p * 0.08 * shape.torso[1],
              np.stack([left_p, fwd_p, up_t], 1),
              (1.01 * shape.torso[0], 1.04 * shape.torso[1], 0.09 * torso_len), "shirt")  # hem
    ellipsoid(p["thorax"] - up_t * 0.30 * torso_len, np.stack([left_c, fwd_c, up_t], 1),
              (shape.chest[0], shape.chest[1], 0.36 * torso_len), "shirt")
    # Neck and head (skin face, hair cap shifted up and back).
    up_h = _unit(p["head_top"] - p["head"]) if np.linalg.norm(p["head_top"] - p["head"]) > 1 \
        else up_t
    fwd_h = _ortho(up_h, fwd_c)
    left_h = np.cross(up_h, fwd_h)
    # The head-top landmark sits just under the scalp (6 mm) and the hair (≈ 15 mm), as a marker
    # on a cap would, so it projects inside the silhouette from every side.
    head_c = p["head_top"] - up_h * (shape.head[2] - 6.0)
    capsule(p["thorax"] - up_t * 0.02 * torso_len, head_c - up_h * 0.5 * shape.head[2],
            shape.neck, "skin")
    hax = np.stack([left_h, fwd_h, up_h], 1)
    ellipsoid(head_c, hax, shape.head, "skin")
    ellipsoid(head_c + up_h * 0.10 * shape.head[2] - fwd_h * 0.14 * shape.head[1], hax,
              (1.06 * shape.head[0], 0.97 * shape.head[1], 0.96 * shape.head[2]), "hair")
    for side in "lr":
        s, e, w, h = (p[f"{side}_shoulder"], p[f"{side}_elbow"], p[f"{side}_wrist"],
                      p[f"{side}_hand"])
        # deltoid / shoulder cap and a T-shirt sleeve over the upper 55 % of the upper arm
        ua = _frame_along(e - s, fwd_c)
        ua_len = np.linalg.norm(e - s)
        inward = p["thorax"] - up_t * 0.1 * torso_len - s
        ellipsoid(s + 0.25 * inward, ua,
                  (1.25 * shape.upper_arm, 1.12 * shape.upper_arm, 1.12 * shape.upper_arm), "shirt")
        ellipsoid(s + (e - s) * 0.28, ua, (0.32 * ua_len, 1.14 * shape.upper_arm,
                                            1.12 * shape.upper_arm), "shirt")
        # the sleeve covers the top of the arm; bare skin from just above the elbow
        capsule(s, s + (e - s) * 0.45, 1.06 * shape.upper_arm, "shirt")
        capsule(s + (e - s) * 0.45, e, shape.upper_arm, "skin")
        mid = e + (w - e) * 0.45
        capsule(e, mid, shape.forearm, "skin")
        capsule(mid, w, 0.78 * shape.forearm, "skin")
        hd = _frame_along(h - w, fwd_c)
        hl = max(np.linalg.norm(h - w), 40.0)
        ellipsoid(w + (h - w) * 0.75, hd, (0.75 * hl + 25.0, 0.95 * shape.forearm,
                                           0.5 * shape.forearm), "skin")
        hip, k, a, t = p[f"{side}_hip"], p[f"{side}_knee"], p[f"{side}_ankle"], p[f"{side}_toe"]
        th = _frame_along(k - hip, fwd_p)
        th_len = np.linalg.norm(k - hip)
        capsule(hip, k, 0.72 * shape.thigh, "trousers")
        ellipsoid(hip + (k - hip) * 0.38, th, (0.45 * th_len, 1.05 * shape.thigh, shape.thigh),
                  "trousers")
        sh = _frame_along(a - k, fwd_p)
        sh_len = np.linalg.norm(a - k)
        capsule(k, a, 0.82 * shape.shin, "trousers")
        ellipsoid(k + (a - k) * 0.33, sh, (0.36 * sh_len, 1.12 * shape.shin, 1.18 * shape.shin),
                  "trousers")
        ellipsoid(a - (a - k) * 0.04, sh, (0.10 * sh_len, 1.15 * shape.shin, 1.15 * shape.shin),
                  "trousers")  # loose trouser cuff
        # Shoe: from behind the heel to beyond the toe joint, flat on its sole.
        fd = _unit(t - a)
        fd_h = _unit(np.array([fd[0], fd[1], 0.0])) if np.hypot(fd[0], fd[1]) > 1e-6 else fd
        heel = a - fd_h * 0.03 * shape.height - np.array([0, 0, 0.025 * shape.height])
        tip = t + fd * 0.035 * shape.height
        length = np.linalg.norm(tip - heel)
        ft = _frame_along(tip - heel, np.array([0.0, 0.0, 1.0]))
        ellipsoid(0.5 * (heel + tip) + ft[:, 1] * 0.012 * shape.height, ft,
                  (0.5 * length + 10.0, 0.028 * shape.height, 0.026 * shape.height), "shoes")
    return Primitives(np.array(caps), np.array(cap_col), np.array(ells), np.array(ell_col))


def subject_body(points, shape: BodyShape, *, height: float | None = None) -> BodyDimensions:
    """The subject's body-file dimensions measured from canonical points, rounded to 0.1 mm.

    Lengths are the means over frames of the ground-truth geometry, as a motion-capture lab would
    measure them from the skeleton; widths are the rendered flesh half-widths.

    Parameters
    ----------
    points : (F, 20, 3) array_like
        Canonical points of the sequence (mm), grounded (floor at Z = 0).
    shape : BodyShape
        The rendered body's widths.
    height : float, optional
        Standing stature (mm); default the highest head top in ``points``.

    Returns
    -------
    BodyDimensions
        Lengths and half-widths (mm) for :func:`voxelmocap.io.body_file.write_body_file`.
    """
    P = np.asarray(points, dtype=float)

    def seg(a, b):
        return float(np.mean(np.linalg.norm(P[:, _C[b]] - P[:, _C[a]], axis=-1)))

    up = P[:, _C["thorax"]] - P[:, _C["pelvis"]]
    up /= np.linalg.norm(up, axis=-1, keepdims=True)

    def offset_drop(base, name):
        d = P[:, _C[name]] - P[:, _C[base]]
        along = np.sum(d * up, axis=-1)
        lateral = np.linalg.norm(d - along[:, None] * up, axis=-1)
        return float(np.mean(lateral)), float(max(0.0, -np.mean(along)))

    sh = [offset_drop("thorax", f"{s}_shoulder") for s in "lr"]
    hp = [offset_drop("pelvis", f"{s}_hip") for s in "lr"]
    r = lambda x: round(float(x), 1)  # noqa: E731
    pair = lambda a, b: (r(a), r(b))  # noqa: E731
    return BodyDimensions(
        height=r(height if height is not None else np.max(P[:, _C["head_top"], 2])),
        torso=r(seg("pelvis", "thorax")),
        head=r(seg("thorax", "head_top")),
        shoulder_offset=pair(sh[0][0], sh[1][0]),
        shoulder_drop=pair(sh[0][1], sh[1][1]),
        hip_offset=pair(hp[0][0], hp[1][0]),
        hip_drop=pair(hp[0][1], hp[1][1]),
        upper_arm=pair(seg("l_shoulder", "l_elbow"), seg("r_shoulder", "r_elbow")),
        forearm=pair(seg("l_elbow", "l_wrist"), seg("r_elbow", "r_wrist")),
        thigh=pair(seg("l_hip", "l_knee"), seg("r_hip", "r_knee")),
        shin=pair(seg("l_knee", "l_ankle"), seg("r_knee", "r_ankle")),
        w_torso=pair(*shape.torso),
        w_chest=pair(*shape.chest),
        w_head=pair(shape.head[0], shape.head[1]),
        w_upper_arm=pair(shape.upper_arm, shape.upper_arm),
        w_forearm=pair(shape.forearm, shape.forearm),
        w_thigh=pair(shape.thigh, shape.thigh),
        w_shin=pair(shape.shin, shape.shin),
    )
