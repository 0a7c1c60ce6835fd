"""Write tracked landmark trajectories as a BVH skeleton (importable by Blender and other tools).

The skeleton is the 15-landmark stick figure (:data:`voxelmocap.joints.LANDMARK_PARENTS`) rooted at
the pelvis, plus end sites beyond the wrists, ankles and head. The rest pose (the ``OFFSET``s) is
the first frame's pose. For every frame each joint's global rotation is the one that carries its
rest child bones onto the current ones (exact for one child; the least-squares Kabsch rotation for
the pelvis and thorax, which have several). Every joint has six channels, ``Xposition Yposition
Zposition Zrotation Xrotation Yrotation`` (as in the Bandai Namco files, which Blender imports):
the positions are the joint's offset from its parent in the parent's rotated frame, so every
landmark is reproduced exactly even where a rotation cannot explain all child bones.

BVH is conventionally Y-up: world ``(x, y, z)`` (Z up, mm) is written as ``(x, z, −y)``, in
centimetres (``units="cm"``) or millimetres.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from ..joints import LANDMARK_NAMES, LANDMARK_PARENTS
from ._atomic import atomic_write_text

__all__ = ["write_landmarks_bvh"]

_TO_BVH = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])  # Z-up → Y-up


def _children(parent_of):
    kids = {j: [] for j in range(len(parent_of))}
    for j, p in enumerate(parent_of):
        if p >= 0:
            kids[p].append(j)
    return kids


def _align(rest: np.ndarray, current: np.ndarray) -> np.ndarray:
    """Rotation matrix R minimising Σ|R·rest_i − current_i|² (Kabsch), or the minimal rotation."""
    if len(rest) == 1:
        a = rest[0] / np.linalg.norm(rest[0])
        b = current[0] / np.linalg.norm(current[0])
        v = np.cross(a, b)
        c = float(np.dot(a, b))
        if c < -1 + 1e-12:  # opposite: rotate by π about any axis perpendicular to a
            axis = np.cross(a, [1.0, 0, 0] if abs(a[0]) < 0.9 else [0, 1.0, 0])
            return Rotation.from_rotvec(np.pi * axis / np.linalg.norm(axis)).as_matrix()
        vx = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
        return np.eye(3) + vx + vx @ vx / (1 + c)
    h = rest.T @ current
    u, _, vt = np.linalg.svd(h)
    d = np.sign(np.linalg.det(vt.T @ u.T))
    return vt.T @ np.diag([1.0, 1.0, d]) @ u.T


def write_landmarks_bvh(path, landmarks, fps: float, *, units: str = "cm",
                        end_length_mm: float = 80.0) -> None:
    """Write ``(F, 15, 3)`` landmark trajectories (mm, Z up) as a BVH file, atomically.

    Parameters
    ----------
    path : str or os.PathLike
        Output ``.bvh`` file.
    landmarks : (F, 15, 3) array_like
        Landmarks in :data:`~voxelmocap.joints.LANDMARK_NAMES` order, finite.
    fps : float
        Frame rate in Hz, finite and > 0 (the BVH ``Frame Time`` is ``1 / fps``); take it from
        the data (``Sequence.frame_rate``), never assume one.
    units : {"cm", "mm"}
        Length unit written.
    end_length_mm : float
        Length of the end-site bones beyond the wrists, ankles and head (along the last bone).
    """
    lm = np.asarray(landmarks, dtype=float)
    if lm.ndim != 3 or lm.shape[1:] != (15, 3) or not np.all(np.isfinite(lm)):
        raise ValueError(f"landmarks must be finite (F, 15, 3), got shape {lm.shape}")
    if not (np.isfinite(fps) and fps > 0):
        raise ValueError(f"fps must be a finite frame rate > 0, got {fps!r}")
    scale = {"cm": 0.1, "mm": 1.0}[units]
    pts = lm @ _TO_BVH.T * scale  # (F, 15, 3) in BVH axes and units
    parents = LANDMARK_PARENTS
    kids = _children(parents)
    root = parents.index(-1)
    rest = pts[0]

    n_frames = len(pts)
    glob = np.zeros((n_frames, 15, 3, 3))
    for j in range(15):
        if kids[j]:
            rest_vecs = np.array([rest[c] - rest[j] for c in kids[j]])
            for t in range(n_frames):
                cur = np.array([pts[t, c] - pts[t, j] for c in kids[j]])
                glob[t, j] = _align(rest_vecs, cur)
    order = []  # depth-first joint order, as written in the hierarchy

    lines = ["HIERARCHY"]

    def emit(j, depth):
        order.append(j)
        pad = "  " * depth
        name = LANDMARK_NAMES[j]
        if j == root:
            lines.append(f"ROOT {name}")
            offset = rest[j]
        else:
            lines.append(f"{pad}JOINT {name}")
            offset = rest[j] - rest[parents[j]]
        channels = "6 Xposition Yposition Zposition Zrotation Xrotation Yrotation"
        lines.append(f"{pad}{{")
        lines.append(f"{pad}  OFFSET {offset[0]:.6f} {offset[1]:.6f} {offset[2]:.6f}")
        lines.append(f"{pad}  CHANNELS {channels}")
        if kids[j]:
            for c in kids[j]:
                emit(c, depth + 1)
        else:
            bone = rest[j] - rest[parents[j]]
            end = bone / np.linalg.norm(bone) * end_length_mm * scale
            lines.append(f"{pad}  End Site")
            lines.append(f"{pad}  {{")
            lines.append(f"{pad}    OFFSET {end[0]:.6f} {end[1]:.6f} {end[2]:.6f}")
            lines.append(f"{pad}  }}")
        lines.append(f"{pad}}}")

    emit(root, 0)
    # Joints without children take their parent's global rotation (zero local rotation).
    for j in order:
        if not kids[j]:
            glob[:, j] = glob[:, parents[j]]
    lines.append("MOTION")
    lines.append(f"Frames: {n_frames}")
    lines.append(f"Frame Time: {1.0 / float(fps):.8f}")
    for t in range(n_frames):
        values = []
        for j in order:
            if j == root:
                values.extend(pts[t, j])
                local = glob[t, j]
            else:
                parent_rot = glob[t, parents[j]]
                values.extend(parent_rot.T @ (pts[t, j] - pts[t, parents[j]]))
                local = parent_rot.T @ glob[t, j]
            z, x, y = Rotation.from_matrix(local).as_euler("ZXY", degrees=True)
            values.extend((z, x, y))
        lines.append(" ".join(f"{v:.6f}" for v in values))
    atomic_write_text(Path(path), "\n".join(lines) + "\n")
