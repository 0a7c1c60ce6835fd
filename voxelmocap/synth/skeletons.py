"""From any motion skeleton to the generator's 20 canonical body points and HumanEva's 20 endpoints.

Every motion source (BVH clips of different skeleton families, the procedural motions) is reduced
to the same 20 **canonical points** per frame (:data:`CANONICAL_NAMES`, mm, Z up): pelvis, thorax
(the neck base), head joint, head top, and per side shoulder, elbow, wrist, hand (knuckles), hip,
knee, ankle, toe. The renderer builds the body around them and the ground truth is read off them
(:func:`endpoints_from_canonical`), so the images and the truth cannot disagree.

Skeleton families (:data:`FAMILIES`, detected by joint names, :func:`detect_family`), and where
each canonical point comes from (``mid(a, b)`` = midpoint; ``along(j, v, ℓ)`` = the point at
distance ℓ from joint ``j`` along the local direction ``v`` carried by ``j``'s rotation):

========== ======================== ============================ ==============================
point      ``cmu_makehuman``        ``bandai``                   ``cmu_cgspeed``
           (05_01, 02_03)           (Bandai Namco 22 joints)     (01_01, 31 joints)
========== ======================== ============================ ==============================
pelvis     mid(lhip, rhip)          mid(UpperLeg_L, UpperLeg_R)  mid(LeftUpLeg, RightUpLeg)
thorax     neck                     Neck                         Neck1
head       head                     Head                         Head
shoulder   l/rshoulder              UpperArm_L/R                 Left/RightArm
elbow      l/relbow                 LowerArm_L/R                 Left/RightForeArm
wrist      l/rhand                  Hand_L/R                     Left/RightHand
hand       finger3-1.l/.r           along(Hand, bone axis, 0.4 × forearm)  L/RFingers
hip        l/rhip                   UpperLeg_L/R                 Left/RightUpLeg
knee       l/rknee                  LowerLeg_L/R                 Left/RightLeg
ankle      l/rfoot                  Foot_L/R                     Left/RightFoot
toe        toe3-1.l/.r              Toes_L/R                     Left/RightToeBase
========== ======================== ============================ ==============================

A fourth family, ``cmu_asf``, maps CMU ASF/AMC skeletons (:mod:`voxelmocap.io.asf`, joints named
after the bone that starts there): pelvis = mid(lfemur, rfemur), thorax = upperneck, head = head,
shoulder = l/rhumerus, elbow = l/rradius, wrist = l/rwrist, hand = l/rhand, hip = l/rfemur,
knee = l/rtibia, ankle = l/rfoot, toe = l/rtoes, head up axis = the head bone.

The **head top** (HumanEva ``headDistal``) is a point along the head bone above the head joint:
``along(head, up, ℓ)`` with ``up`` the head's local up direction (the offset of ``__jaw`` /
``Head_End`` for the CMU families, the neck→head bone axis for Bandai) and ℓ chosen so that the
thorax→head-top distance in the first frame is 0.6 × the pelvis→thorax (torso) length, the
proportion of an adult (C7 at ≈ 0.82 of the stature, hip joints at ≈ 0.52; the HumanEva toolkit's
own head length is a fixed 316 mm).

HumanEva's 20 endpoints follow ``body_toml.md``: torsoProximal = headProximal = thorax,
torsoDistal = pelvis, upper*ArmDistal = lower*ArmProximal = elbow, upper*LegDistal =
lower*LegProximal = knee, headDistal = head top.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation

from ..errors import InputError
from ..io.bvh import YUP_TO_ZUP, BvhClip

__all__ = [
    "CANONICAL_NAMES",
    "FAMILIES",
    "SkeletonFamily",
    "bvh_canonical_points",
    "detect_family",
    "endpoints_from_canonical",
]

CANONICAL_NAMES: tuple[str, ...] = (
    "pelvis", "thorax", "head", "head_top",
    "l_shoulder", "l_elbow", "l_wrist", "l_hand",
    "r_shoulder", "r_elbow", "r_wrist", "r_hand",
    "l_hip", "l_knee", "l_ankle", "l_toe",
    "r_hip", "r_knee", "r_ankle", "r_toe",
)
C = {name: i for i, name in enumerate(CANONICAL_NAMES)}

#: Canonical point index of each HumanEva endpoint (``voxelmocap.joints.ENDPOINT_NAMES`` order).
ENDPOINT_SOURCES: tuple[int, ...] = (
    C["thorax"], C["pelvis"],
    C["l_shoulder"], C["l_elbow"], C["l_elbow"], C["l_wrist"],
    C["r_shoulder"], C["r_elbow"], C["r_elbow"], C["r_wrist"],
    C["l_hip"], C["l_knee"], C["l_knee"], C["l_ankle"],
    C["r_hip"], C["r_knee"], C["r_knee"], C["r_ankle"],
    C["thorax"], C["head_top"],
)

#: thorax→head top distance as a fraction of the pelvis→thorax distance (see module docstring).
HEAD_TOP_RATIO = 0.6


@dataclass(frozen=True)
class SkeletonFamily:
    """How one skeleton family's joints give the canonical points.

    Attributes
    ----------
    name : str
        Family name.
    joints : dict of str to str or tuple of str
        Canonical name → joint name, or a pair of joint names whose midpoint is taken.
    head_up : str or None
        Joint whose ``OFFSET`` (a child of the head) gives the head's local up direction; None to
        use the head's own offset (the neck→head bone axis).
    hand_axis : str or None
        For families without a hand joint beyond the wrist: the wrist joint whose own offset
        direction (the forearm axis, in its local frame) carries the hand point.
    """

    name: str
    joints: dict[str, str | tuple[str, str]]
    head_up: str | None = None
    hand_axis: dict[str, str] = field(default_factory=dict)

    def required(self) -> set[str]:
        """Joint names the family needs."""
        out: set[str] = set()
        for v in self.joints.values():
            out.update((v,) if isinstance(v, str) else v)
        if self.head_up:
            out.add(self.head_up)
        out.update(self.hand_axis.values())
        return out


def _sided(template: dict[str, tuple[str, str]]) -> dict[str, str]:
    out = {}
    for key, (left, right) in template.items():
        out[f"l_{key}"] = left
        out[f"r_{key}"] = right
    return out


FAMILIES: tuple[SkeletonFamily, ...] = (
    SkeletonFamily(
        "cmu_makehuman",
        {"pelvis": ("lhip", "rhip"), "thorax": "neck", "head": "head",
         **_sided({"shoulder": ("lshoulder", "rshoulder"), "elbow": ("lelbow", "relbow"),
                   "wrist": ("lhand", "rhand"), "hand": ("finger3-1.l", "finger3-1.r"),
                   "hip": ("lhip", "rhip"), "knee": ("lknee", "rknee"),
                   "ankle": ("lfoot", "rfoot"), "toe": ("toe3-1.l", "toe3-1.r")})},
        head_up="__jaw",
    ),
    SkeletonFamily(
        "bandai",
        {"pelvis": ("UpperLeg_L", "UpperLeg_R"), "thorax": "Neck", "head": "Head",
         **_sided({"shoulder": ("UpperArm_L", "UpperArm_R"), "elbow": ("LowerArm_L", "LowerArm_R"),
                   "wrist": ("Hand_L", "Hand_R"),
                   "hip": ("UpperLeg_L", "UpperLeg_R"), "knee": ("LowerLeg_L", "LowerLeg_R"),
                   "ankle": ("Foot_L", "Foot_R"), "toe": ("Toes_L", "Toes_R")})},
        head_up=None,
        hand_axis={"l_hand": "Hand_L", "r_hand": "Hand_R"},
    ),
    SkeletonFamily(
        "cmu_cgspeed",
        {"pelvis": ("LeftUpLeg", "RightUpLeg"), "thorax": "Neck1", "head": "Head",
         **_sided({"shoulder": ("LeftArm", "RightArm"), "elbow": ("LeftForeArm", "RightForeArm"),
                   "wrist": ("LeftHand", "RightHand"), "hand": ("LFingers", "RFingers"),
                   "hip": ("LeftUpLeg", "RightUpLeg"), "knee": ("LeftLeg", "RightLeg"),
                   "ankle": ("LeftFoot", "RightFoot"), "toe": ("LeftToeBase", "RightToeBase")})},
        head_up="Head_End",
    ),
    SkeletonFamily(
        "cmu_asf",  # ASF/AMC read by voxelmocap.io.asf: a joint is named after the bone it starts
        {"pelvis": ("lfemur", "rfemur"), "thorax": "upperneck", "head": "head",
         **_sided({"shoulder": ("lhumerus", "rhumerus"), "elbow": ("lradius", "rradius"),
                   "wrist": ("lwrist", "rwrist"), "hand": ("lhand", "rhand"),
                   "hip": ("lfemur", "rfemur"), "knee": ("ltibia", "rtibia"),
                   "ankle": ("lfoot", "rfoot"), "toe": ("ltoes", "rtoes")})},
        head_up="head_End",
    ),
)

#: hand point distance from the wrist as a fraction of the forearm, when the skeleton has no hand
HAND_RATIO = 0.4


def detect_family(names, *, source="BVH") -> SkeletonFamily:
    """The first family of :data:`FAMILIES` whose joints are all present in ``names``.

    Raises
    ------
    InputError
        When no family matches (the message lists the families and what each lacks first).
    """
    have = set(names)
    missing = {}
    for fam in FAMILIES:
        lack = sorted(fam.required() - have)
        if not lack:
            return fam
        missing[fam.name] = lack
    detail = "; ".join(f"{k} lacks {', '.join(v[:3])}" for k, v in missing.items())
    raise InputError(source, f"unknown skeleton (no joint-name mapping fits: {detail})")


def _local_dir(clip: BvhClip, joint: int, child: str | None) -> np.ndarray:
    """Unit direction in ``joint``'s local BVH axes: a child's offset, or its own offset."""
    v = clip.offsets[clip.index(child)] if child else clip.offsets[joint]
    n = np.linalg.norm(v)
    if n == 0:
        raise InputError(clip.source, f"zero-length bone at {clip.names[joint]!r}")
    return v / n


def bvh_canonical_points(clip: BvhClip, times=None, *, family: SkeletonFamily | None = None
                         ) -> np.ndarray:
    """Canonical points ``(T, 20, 3)`` (mm, Z up) of a BVH clip at given times.

    Parameters
    ----------
    clip : BvhClip
        The clip (its ``scale`` sets the unit).
    times : (T,) array_like of float, optional
        Times in seconds from the clip's first frame (fractional frames are interpolated: root
        positions linearly, joint rotations by slerp). Default: every frame.
    family : SkeletonFamily, optional
        Detected from the joint names when omitted.

    Returns
    -------
    (T, 20, 3) ndarray
        In :data:`CANONICAL_NAMES` order.
    """
    family = family or detect_family(clip.names, source=clip.source)
    if times is None:
        rot, pos = _world(clip, np.arange(clip.n_frames, dtype=float))
    else:
        frames = np.asarray(times, dtype=float) / clip.frame_time
        if frames.size and (frames.min() < -1e-9 or frames.max() > clip.n_frames - 1 + 1e-9):
            raise InputError(clip.source, f"times outside the clip (0 to "
                                          f"{(clip.n_frames - 1) * clip.frame_time:.3f} s)")
        rot, pos = _world(clip, np.clip(frames, 0, clip.n_frames - 1))
    T = pos.shape[0]
    out = np.empty((T, len(CANONICAL_NAMES), 3))
    for name, src in family.joints.items():
        if isinstance(src, str):
            out[:, C[name]] = pos[:, clip.index(src)]
        else:
            out[:, C[name]] = 0.5 * (pos[:, clip.index(src[0])] + pos[:, clip.index(src[1])])
    for name, joint_name in family.hand_axis.items():
        j = clip.index(joint_name)
        d = _local_dir(clip, j, None)
        side = name[0]
        forearm = np.linalg.norm(out[0, C[f"{side}_wrist"]] - out[0, C[f"{side}_elbow"]])
        out[:, C[name]] = pos[:, j] + HAND_RATIO * forearm * (rot[:, j] @ (YUP_TO_ZUP @ d))
    # Head top: along the head's up axis, at the distance that makes thorax→top 0.6 × torso in
    # the clip's first frame (a property of the clip, whatever times are sampled).
    h = clip.index(family.joints["head"])
    local_up = YUP_TO_ZUP @ _local_dir(clip, h, family.head_up)
    up = rot[:, h] @ local_up
    s = _head_top_distance(clip, family, h, local_up)
    out[:, C["head_top"]] = out[:, C["head"]] + s * up
    return out


def _head_top_distance(clip, family, h, local_up) -> float:
    """Distance from the head joint to the head top along the head's up axis (mm)."""
    rot, pos = clip.rotations([0]), clip.positions([0])

    def point(src):
        if isinstance(src, str):
            return pos[0, clip.index(src)]
        return 0.5 * (pos[0, clip.index(src[0])] + pos[0, clip.index(src[1])])

    thorax, pelvis, head = (point(family.joints[k]) for k in ("thorax", "pelvis", "head"))
    target = HEAD_TOP_RATIO * np.linalg.norm(thorax - pelvis)
    up = rot[0, h] @ local_up
    # Solve |head + s·up − thorax| = target for s > 0.
    rel = head - thorax
    b = float(rel @ up)
    disc = b * b - (float(rel @ rel) - target * target)
    s = -b + np.sqrt(disc) if disc > 0 else target
    return max(s, 0.25 * target)


def _world(clip: BvhClip, frames: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World rotations (T, J, 3, 3, HumanEva axes) and positions (T, J, 3, mm) at fractional frames."""
    i0 = np.floor(frames).astype(int)
    i1 = np.minimum(i0 + 1, clip.n_frames - 1)
    w = frames - i0
    if np.all(w == 0):
        return clip.rotations(i0), clip.positions(i0)
    r0, t0 = clip.local_transforms(i0)
    r1, t1 = clip.local_transforms(i1)
    T, J = r0.shape[:2]
    rel = Rotation.from_matrix(np.einsum("tjki,tjkl->tjil", r0, r1).reshape(-1, 3, 3))
    step = Rotation.from_rotvec(rel.as_rotvec() * np.repeat(w, J)[:, None]).as_matrix()
    rot = r0 @ step.reshape(T, J, 3, 3)
    trans = t0 + (t1 - t0) * w[:, None, None]
    g_rot, g_pos = clip.forward_kinematics(rot, trans)
    return (YUP_TO_ZUP @ g_rot @ YUP_TO_ZUP.T), (g_pos @ YUP_TO_ZUP.T) * clip.scale


def endpoints_from_canonical(points) -> np.ndarray:
    """HumanEva's 20 ``body_pose`` endpoints ``(..., 20, 3)`` from canonical points ``(..., 20, 3)``."""
    points = np.asarray(points, dtype=float)
    return points[..., list(ENDPOINT_SOURCES), :]
