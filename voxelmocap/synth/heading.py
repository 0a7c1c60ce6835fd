"""Turning a motion about the vertical through its start, and checking that it stays in view.

``voxelmocap synth --heading DEG`` (:func:`voxelmocap.synth.generate`, ``heading_deg``) renders a
motion with the person's heading turned by DEG degrees: every canonical point of every frame is
rotated counter-clockwise seen from above (about +Z, HumanEva's up) about the vertical line
through the pelvis at synchronised frame 1. The pelvis of frame 1 stays where it was, the path
turns with the body, and the ground truth written is that of the turned motion, so it stays
exact. The facing benchmark (``scripts/bench_facing.py``) renders each clip at eight headings
this way.

A turned path can leave the floor area the cameras share: :func:`frames_out_of_view` says, per
frame and camera, whether some body point is outside that camera's view, by the carver's
visibility rule (:func:`voxelmocap.camera.visible`).
"""

from __future__ import annotations

import numpy as np

from ..camera import visible
from .skeletons import CANONICAL_NAMES

__all__ = ["frames_out_of_view", "turn_about_vertical"]

_PELVIS = CANONICAL_NAMES.index("pelvis")


def turn_about_vertical(points, heading_deg: float, *, pivot_frame: int = 0,
                        root: int = _PELVIS) -> np.ndarray:
    """Rotate every point about the vertical through one frame's root.

    Parameters
    ----------
    points : (T, P, 3) array_like
        Points (mm), Z up (canonical points, or HumanEva endpoints with ``root=1``).
    heading_deg : float
        Angle (degrees), counter-clockwise seen from above (+x turns towards +y).
    pivot_frame : int
        Frame whose root position gives the vertical axis.
    root : int
        Index of the root point among the P points (default the canonical pelvis).

    Returns
    -------
    (T, P, 3) ndarray
        Turned copy: ``x' = c·(x − x₀) − s·(y − y₀) + x₀``, ``y' = s·(x − x₀) + c·(y − y₀) + y₀``,
        ``z' = z`` with ``c, s = cos, sin(heading)`` and ``(x₀, y₀)`` the pivot root's floor
        position.
    """
    P = np.array(points, dtype=float)
    if P.ndim != 3 or P.shape[-1] != 3:
        raise ValueError(f"points must be (T, P, 3), got shape {P.shape}")
    a = np.deg2rad(float(heading_deg))
    c, s = np.cos(a), np.sin(a)
    x0, y0 = P[pivot_frame, root, 0], P[pivot_frame, root, 1]
    dx, dy = P[..., 0] - x0, P[..., 1] - y0
    P[..., 0] = c * dx - s * dy + x0
    P[..., 1] = s * dx + c * dy + y0
    return P


def frames_out_of_view(rig, points) -> np.ndarray:
    """Which camera misses part of the body in which frame.

    Parameters
    ----------
    rig : sequence of voxelmocap.camera.Camera
        The cameras.
    points : (T, P, 3) array_like
        Body points per frame (mm), e.g. the 20 ground-truth endpoints.

    Returns
    -------
    (T, C) bool ndarray
        True where camera ``c`` does not see at least one of frame ``t``'s points (behind it,
        outside its trusted field of view or off its image). A frame is in the cameras'
        common view when its row is all False.
    """
    P = np.asarray(points, dtype=float)
    if P.ndim != 3 or P.shape[-1] != 3:
        raise ValueError(f"points must be (T, P, 3), got shape {P.shape}")
    T, n = P.shape[:2]
    flat = P.reshape(-1, 3)
    return np.stack([~visible(cam, flat)[2].reshape(T, n).all(axis=1) for cam in rig], axis=1)
