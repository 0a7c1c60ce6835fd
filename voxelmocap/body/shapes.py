"""Subject dimensions and the truncated elliptic cones (H, W, L, R) built from them.

Every body part is a section of an elliptic cone (paper 000 §3.1.1): base half-axes ``H`` (along
the part's lateral axis ``u1``) and ``W`` (front-back axis ``u2``), length ``L`` along the axis
``n``, and ratio ``R`` so that the far end has half-axes ``R·H`` and ``R·W``. A point ``p`` belongs
to a part with base centre ``c`` when ``t = (p − c)·n ∈ [0, L]`` and
``((p − c)·u1 / H)² + ((p − c)·u2 / W)² ≤ (1 + (R − 1) t / L)²``; its volume is
``π L H W (1 + R + R²) / 3``.

:class:`BodyDimensions` holds a subject's skeleton (lengths, the contract of the
``<Subject>_body.toml`` file, see ``docs/body_model.md``) and flesh (half-widths); it comes from a
body file (:func:`voxelmocap.io.body_file.read_body_file`), from ground-truth landmarks
(:meth:`BodyDimensions.from_landmarks`) or from the average adult scaled to a height
(:meth:`BodyDimensions.average`). :meth:`BodyDimensions.parts` turns it into the ten cones.

>>> dims = BodyDimensions.average(1780.0)
>>> [p.name for p in dims.parts()][:3]
['torso', 'head', 'l_upper_arm']
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace
from typing import NamedTuple

import numpy as np

from ..errors import InputError

__all__ = ["LENGTH_KEYS", "MAY_BE_ZERO", "PART_NAMES", "WIDTH_KEYS", "BodyDimensions", "Part",
           "frustum_volume"]

#: The ten parts, in the order used by every per-part array.
PART_NAMES: tuple[str, ...] = (
    "torso", "head",
    "l_upper_arm", "l_forearm", "r_upper_arm", "r_forearm",
    "l_thigh", "l_shin", "r_thigh", "r_shin",
)

# The body file gives no wrist, ankle or neck widths; these shape constants close the limbs.
# Anthropometric tables (e.g. the US Army ANSUR survey) give wrist/forearm and ankle/calf girth
# ratios of about 0.65–0.7; the head cone runs from the neck base to the head top, so its base is
# narrower than the head and its top a little wider than the base (a cone cannot round the skull).
WRIST_RATIO = 0.7
ANKLE_RATIO = 0.65
HEAD_BASE_SHARE = 0.75
HEAD_RATIO = 1.2
#: Share of the standing height below the ankle joints (floor → ankle), used to relate the
#: skeleton to the height (1780 mm · 0.045 ≈ 80 mm).
ANKLE_HEIGHT_SHARE = 0.045

_REFERENCE_HEIGHT = 1780.0
#: Skeleton lengths (fields of :class:`BodyDimensions`), in body-file order; all but the
#: torso and head are ``(left, right)`` pairs.
LENGTH_KEYS = ("torso", "head", "shoulder_offset", "shoulder_drop", "hip_offset", "hip_drop",
               "upper_arm", "forearm", "thigh", "shin")
#: Lengths that may be 0 (shoulders and hips level with the thorax and pelvis).
MAY_BE_ZERO = frozenset({"shoulder_drop", "hip_drop"})
#: Flesh half-width pairs (fields ``w_<key>`` of :class:`BodyDimensions`), in body-file order.
WIDTH_KEYS = ("torso", "chest", "head", "upper_arm", "forearm", "thigh", "shin")

# The average adult of the body-file contract (mm); widths are half-widths.
_AVERAGE_LENGTHS = {
    "torso": 520.0, "head": 250.0,
    "shoulder_offset": (185.0, 185.0), "shoulder_drop": (30.0, 30.0),
    "hip_offset": (95.0, 95.0), "hip_drop": (60.0, 60.0),
    "upper_arm": (290.0, 290.0), "forearm": (255.0, 255.0),
    "thigh": (440.0, 440.0), "shin": (430.0, 430.0),
}
_AVERAGE_WIDTHS = {
    "torso": (160.0, 105.0), "chest": (170.0, 110.0), "head": (80.0, 95.0),
    "upper_arm": (50.0, 50.0), "forearm": (42.0, 42.0), "thigh": (80.0, 80.0), "shin": (55.0, 55.0),
}


class Part(NamedTuple):
    """One truncated elliptic cone: base half-axes ``H`` (lateral), ``W`` (front-back), length
    ``L`` and end-to-base ratio ``R`` (all mm except ``R``)."""

    name: str
    H: float
    W: float
    L: float
    R: float

    @property
    def volume(self) -> float:
        """Analytic volume (mm³)."""
        return frustum_volume(self.H, self.W, self.L, self.R)


def frustum_volume(H, W, L, R):
    """Volume (mm³) of a truncated elliptic cone: ``π L H W (1 + R + R²) / 3``."""
    return math.pi * L * H * W * (1.0 + R + R * R) / 3.0


@dataclass(frozen=True)
class BodyDimensions:
    """A subject's skeleton lengths and flesh half-widths (mm); pairs are ``(left, right)``.

    The fields follow the ``[lengths_mm]`` and ``[widths_mm]`` tables of the body file; width
    fields carry a ``w_`` prefix. Build with :meth:`average`, :meth:`from_landmarks` or from a
    body file (:func:`voxelmocap.io.body_file.read_body_file`).
    """

    height: float
    torso: float
    head: float
    shoulder_offset: tuple[float, float]
    shoulder_drop: tuple[float, float]
    hip_offset: tuple[float, float]
    hip_drop: tuple[float, float]
    upper_arm: tuple[float, float]
    forearm: tuple[float, float]
    thigh: tuple[float, float]
    shin: tuple[float, float]
    w_torso: tuple[float, float]
    w_chest: tuple[float, float]
    w_head: tuple[float, float]
    w_upper_arm: tuple[float, float]
    w_forearm: tuple[float, float]
    w_thigh: tuple[float, float]
    w_shin: tuple[float, float]

    # ----------------------------------------------------------------------------- builders
    @classmethod
    def average(cls, height_mm: float = _REFERENCE_HEIGHT) -> BodyDimensions:
        """The average adult of the body-file contract, every dimension scaled to ``height_mm``."""
        height_mm = float(height_mm)
        if not (np.isfinite(height_mm) and height_mm > 0):
            raise InputError("height_mm", f"must be a positive number, got {height_mm!r}")
        s = height_mm / _REFERENCE_HEIGHT
        lengths = {k: _scale(v, s) for k, v in _AVERAGE_LENGTHS.items()}
        return cls(height=height_mm, **lengths, **_default_widths(height_mm))

    def scaled(self, height_mm: float) -> BodyDimensions:
        """These dimensions scaled uniformly so that the standing height is ``height_mm``."""
        height_mm = float(height_mm)
        if not (np.isfinite(height_mm) and height_mm > 0):
            raise InputError("height_mm", f"must be a positive number, got {height_mm!r}")
        s = height_mm / self.height
        fields = {k: _scale(v, s) for k, v in asdict(self).items() if k != "height"}
        return BodyDimensions(height=height_mm, **fields)

    @classmethod
    def from_landmarks(cls, landmarks, *, source: str = "landmarks") -> BodyDimensions:
        """Measure a skeleton from ground-truth landmarks; widths are the defaults for its height.

        Each length is the median over frames of the distance between its two landmarks. The
        shoulder (hip) offset and drop are the components of thorax→shoulder (pelvis→hip)
        perpendicular to and down along the torso axis pelvis→thorax; a negative drop is clipped
        to 0 (the hips hang from the pelvis frame, which landmarks do not show: the hip numbers are
        exact when the waist is straight). The height is the chain head top → ankle plus the ankle height
        (:data:`ANKLE_HEIGHT_SHARE`).

        Parameters
        ----------
        landmarks : (F, 15, 3) or (15, 3) array_like
            Landmarks (mm) in ``LANDMARK_NAMES`` order; frames with NaN are ignored.
        """
        lm = np.asarray(landmarks, dtype=float)
        if lm.ndim == 2:
            lm = lm[None]
        if lm.ndim != 3 or lm.shape[1:] != (15, 3):
            raise InputError(source, f"expected shape (F, 15, 3), got {np.shape(landmarks)}")
        lm = lm[np.all(np.isfinite(lm), axis=(1, 2))]
        if len(lm) == 0:
            raise InputError(source, "no frame has all 15 landmarks finite")
        (thorax, pelvis, lsh, lel, lwr, rsh, rel, rwr, lhip, lkn, lan, rhip, rkn, ran,
         head) = (lm[:, i] for i in range(15))

        def dist(a, b):
            return float(np.median(np.linalg.norm(a - b, axis=1)))

        axis = thorax - pelvis
        axis /= np.maximum(np.linalg.norm(axis, axis=1, keepdims=True), 1e-9)

        def offset_drop(point, origin):
            d = point - origin
            along = np.einsum("fi,fi->f", d, axis)
            perp = np.linalg.norm(d - along[:, None] * axis, axis=1)
            return float(np.median(perp)), max(0.0, float(np.median(-along)))

        lso, lsd = offset_drop(lsh, thorax)
        rso, rsd = offset_drop(rsh, thorax)
        lho, lhd = offset_drop(lhip, pelvis)
        rho, rhd = offset_drop(rhip, pelvis)
        lengths = {
            "torso": dist(thorax, pelvis), "head": dist(head, thorax),
            "shoulder_offset": (lso, rso), "shoulder_drop": (lsd, rsd),
            "hip_offset": (lho, rho), "hip_drop": (lhd, rhd),
            "upper_arm": (dist(lel, lsh), dist(rel, rsh)),
            "forearm": (dist(lwr, lel), dist(rwr, rel)),
            "thigh": (dist(lkn, lhip), dist(rkn, rhip)),
            "shin": (dist(lan, lkn), dist(ran, rkn)),
        }
        for key, value in lengths.items():
            values = value if isinstance(value, tuple) else (value,)
            if key not in MAY_BE_ZERO and min(values) <= 0:
                raise InputError(source, f"measured {key} length is zero (coincident landmarks)")
        chain = (lengths["head"] + lengths["torso"] + float(np.mean(lengths["hip_drop"]))
                 + float(np.mean(lengths["thigh"])) + float(np.mean(lengths["shin"])))
        height = chain / (1.0 - ANKLE_HEIGHT_SHARE)
        return cls(height=height, **lengths, **_default_widths(height))

    # ----------------------------------------------------------------------------- views
    def replace(self, **changes) -> BodyDimensions:
        """A copy with some fields changed (see :func:`dataclasses.replace`)."""
        return replace(self, **changes)

    def parts(self) -> tuple[Part, ...]:
        """The ten cones in :data:`PART_NAMES` order.

        Torso: base at the pelvis with the ``torso`` half-widths, ratio the mean of the
        chest/torso ratios. Head: neck base → head top, base :data:`HEAD_BASE_SHARE` of the head
        half-widths, ratio :data:`HEAD_RATIO`. Upper arm and thigh taper to the forearm and shin
        widths; forearm and shin taper by :data:`WRIST_RATIO` and :data:`ANKLE_RATIO`.
        """
        tH, tW = self.w_torso
        cH, cW = self.w_chest
        parts = [
            Part("torso", tH, tW, self.torso, 0.5 * (cH / tH + cW / tW)),
            Part("head", HEAD_BASE_SHARE * self.w_head[0], HEAD_BASE_SHARE * self.w_head[1],
                 self.head, HEAD_RATIO),
        ]
        for side, s in (("l", 0), ("r", 1)):
            ua, fa = self.w_upper_arm[s], self.w_forearm[s]
            parts.append(Part(f"{side}_upper_arm", ua, ua, self.upper_arm[s], fa / ua))
            parts.append(Part(f"{side}_forearm", fa, fa, self.forearm[s], WRIST_RATIO))
        for side, s in (("l", 0), ("r", 1)):
            th, sh = self.w_thigh[s], self.w_shin[s]
            parts.append(Part(f"{side}_thigh", th, th, self.thigh[s], sh / th))
            parts.append(Part(f"{side}_shin", sh, sh, self.shin[s], ANKLE_RATIO))
        return tuple(parts)


# --------------------------------------------------------------------------------- helpers
def _scale(value, s):
    if isinstance(value, tuple):
        return tuple(float(v) * s for v in value)
    return float(value) * s


def _default_widths(height: float) -> dict:
    s = height / _REFERENCE_HEIGHT
    return {f"w_{k}": _scale(v, s) for k, v in _AVERAGE_WIDTHS.items()}
