"""Drawing the body model and landmarks over camera images (OpenCV, BGR uint8).

:func:`cone_outline_points` samples each truncated elliptic cone as two ellipses (base and top)
and four generator lines, :func:`draw_pose` projects them (and optional landmarks) through a
camera's full model and draws them; :func:`overlay_frame` composes one frame of an overlay video
(cones, tracked landmarks, ground truth, a caption); :func:`overlay_all` puts every camera's
overlay of one frame side by side (:func:`mosaic`), to check a real run by eye. Pure functions
on arrays; writing videos is :func:`voxelmocap.run.inspection.overlay_video`'s job.
"""

from __future__ import annotations

import cv2
import numpy as np

from ..joints import LANDMARK_PARENTS

__all__ = ["TRACKED_COLOUR", "TRUTH_COLOUR", "cone_outline_points", "draw_landmarks", "draw_pose",
           "mosaic", "overlay_all", "overlay_frame"]

#: BGR colours of the ten parts (torso, head, arms, forearms, thighs, shins).
PART_COLOURS = ((60, 180, 255), (255, 255, 255), (80, 220, 80), (40, 160, 40), (255, 120, 60),
                (200, 80, 30), (230, 90, 230), (160, 40, 160), (60, 230, 230), (30, 150, 150))
#: BGR colours of the tracked landmarks (red) and of the ground truth (green).
TRACKED_COLOUR = (0, 0, 255)
TRUTH_COLOUR = (0, 220, 0)


def cone_outline_points(base, axis, u1, u2, H, W, L, R, n: int = 24) -> list[np.ndarray]:
    """Polylines outlining one truncated elliptic cone.

    Parameters
    ----------
    base, axis, u1, u2 : (3,) array_like
        Base centre (mm), unit axis and unit cross-section axes.
    H, W : float
        Base half-axes along ``u1`` and ``u2`` (mm).
    L : float
        Length along ``axis`` (mm).
    R : float
        Top-to-base radius ratio.
    n : int
        Samples per ellipse.

    Returns
    -------
    list of (k, 3) ndarray
        Base ellipse, top ellipse (closed) and four generator segments, in world mm.
    """
    base, axis, u1, u2 = (np.asarray(v, dtype=float) for v in (base, axis, u1, u2))
    t = np.linspace(0, 2 * np.pi, n + 1)
    ring = np.cos(t)[:, None] * H * u1 + np.sin(t)[:, None] * W * u2
    top = base + L * axis
    lines = [base + ring, top + R * ring]
    for k in range(4):
        a = k * np.pi / 2
        d = np.cos(a) * H * u1 + np.sin(a) * W * u2
        lines.append(np.stack([base + d, top + R * d]))
    return lines


def _polyline(image, camera, points, colour, thickness):
    pix, depth = camera.project(points, return_depth=True)
    if np.any(depth <= 0) or not np.all(np.isfinite(pix)):
        return
    pts = np.round(pix * 16).astype(np.int32).reshape(-1, 1, 2)  # 4 fractional bits
    cv2.polylines(image, [pts], False, colour, thickness, cv2.LINE_AA, shift=4)


def draw_pose(image, camera, model, state, *, colours=PART_COLOURS, thickness: int = 1):
    """Draw the cones of one body-model state into ``image`` (in place) and return it."""
    geo = model.geometry(np.asarray(state, dtype=float)[None], legal=False)
    for p, part in enumerate(model.parts):
        for line in cone_outline_points(geo.base[0, p], geo.axis[0, p], geo.u1[0, p],
                                        geo.u2[0, p], part.H, part.W, part.L, part.R):
            _polyline(image, camera, line, colours[p % len(colours)], thickness)
    return image


def draw_landmarks(image, camera, landmarks, colour=(0, 0, 255), *, radius: int = 3,
                   skeleton: bool = True):
    """Draw ``(15, 3)`` landmarks (and their stick figure) into ``image`` (in place)."""
    landmarks = np.asarray(landmarks, dtype=float)
    pix, depth = camera.project(landmarks, return_depth=True)
    ok = (depth > 0) & np.all(np.isfinite(pix), axis=1)
    if skeleton:
        for j, parent in enumerate(LANDMARK_PARENTS):
            if parent >= 0 and ok[j] and ok[parent]:
                p0 = tuple(np.round(pix[j]).astype(int))
                p1 = tuple(np.round(pix[parent]).astype(int))
                cv2.line(image, p0, p1, colour, 1, cv2.LINE_AA)
    for j in np.flatnonzero(ok):
        cv2.circle(image, tuple(np.round(pix[j]).astype(int)), radius, colour, -1, cv2.LINE_AA)
    return image


def overlay_frame(image, camera, model, state, landmarks, *, truth=None, caption: str = ""):
    """One frame of an overlay video: a BGR copy of ``image`` with the tracked pose drawn on it.

    Parameters
    ----------
    image : (H, W) or (H, W, 3) uint8 ndarray
        The camera's frame (gray frames are converted to BGR).
    camera : Camera
        The camera that took it.
    model : BodyModel
        The tracked body model.
    state : (27,) array_like
        The tracked state (cones, in :data:`PART_COLOURS`).
    landmarks : (15, 3) array_like
        The tracked landmarks (mm), drawn in :data:`TRACKED_COLOUR`.
    truth : (15, 3) array_like, optional
        Ground-truth landmarks (mm), drawn in :data:`TRUTH_COLOUR` under the tracked ones.
    caption : str
        Text at the top left.

    Returns
    -------
    (H, W, 3) uint8 ndarray
    """
    image = np.asarray(image)
    out = cv2.cvtColor(image, cv2.COLOR_GRAY2BGR) if image.ndim == 2 else image.copy()
    draw_pose(out, camera, model, state)
    if truth is not None:
        draw_landmarks(out, camera, truth, TRUTH_COLOUR)
    draw_landmarks(out, camera, landmarks, TRACKED_COLOUR)
    if caption:
        cv2.putText(out, caption, (8, 18), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (255, 255, 255), 1,
                    cv2.LINE_AA)
    return np.ascontiguousarray(out)


def mosaic(panels, *, max_width: int = 1920, aspect: float = 16 / 9, labels=None):
    """Tile images of any sizes into one: equal panel heights, the layout closest to ``aspect``.

    Parameters
    ----------
    panels : sequence of (H_i, W_i, 3) uint8 ndarray
    max_width : int
        The mosaic is shrunk (never enlarged) to at most this width; its sides are even (video
        encoders need that).
    aspect : float
        Preferred width / height of the whole mosaic.
    labels : sequence of str, optional
        Drawn at the bottom left of each panel.

    Returns
    -------
    (H, W, 3) uint8 ndarray
    """
    panels = [np.asarray(p) for p in panels]
    if not panels:
        raise ValueError("no panels")
    h0 = min(p.shape[0] for p in panels)
    scaled = [cv2.resize(p, (max(1, round(p.shape[1] * h0 / p.shape[0])), h0),
                         interpolation=cv2.INTER_AREA) if p.shape[0] != h0 else p for p in panels]
    w0 = max(p.shape[1] for p in scaled)
    n = len(scaled)
    cols = min(range(1, n + 1), key=lambda c: abs(np.log(c * w0 / (-(-n // c) * h0) / aspect)))
    rows = -(-n // cols)
    out = np.zeros((rows * h0, cols * w0, 3), np.uint8)
    for i, p in enumerate(scaled):
        r, c = divmod(i, cols)
        out[r * h0:(r + 1) * h0, c * w0:c * w0 + p.shape[1]] = p
        if labels is not None:
            cv2.putText(out, str(labels[i]), (c * w0 + 8, (r + 1) * h0 - 10),
                        cv2.FONT_HERSHEY_SIMPLEX, max(0.5, h0 / 600), (255, 255, 255), 2,
                        cv2.LINE_AA)
    scale = min(1.0, max_width / out.shape[1])
    w = max(2, int(out.shape[1] * scale) // 2 * 2)
    h = max(2, int(out.shape[0] * scale) // 2 * 2)
    return cv2.resize(out, (w, h), interpolation=cv2.INTER_AREA)


def overlay_all(images, cameras, model, state, landmarks, *, truth=None, caption: str = "",
                max_width: int = 1920):
    """Every camera's overlay of one frame in one image (one panel per camera).

    Parameters
    ----------
    images : mapping of str to (H, W) or (H, W, 3) uint8 ndarray
        The frame of each camera, by name.
    cameras : sequence of Camera
        The cameras, in panel order.
    model, state, landmarks, truth
        As :func:`overlay_frame`.
    caption : str
        Written at the top left of the first panel.
    max_width : int
        Width limit of the mosaic (:func:`mosaic`).

    Returns
    -------
    (H, W, 3) uint8 ndarray
    """
    panels = []
    for i, cam in enumerate(cameras):
        image = np.asarray(images[cam.name])
        panel = cv2.cvtColor(image, cv2.COLOR_GRAY2BGR) if image.ndim == 2 else image.copy()
        # lines drawn for a 480-row image vanish when a 1920-row panel is shrunk: scale them
        k = max(1, int(round(panel.shape[0] / 600)))
        draw_pose(panel, cam, model, state, thickness=k)
        if truth is not None:
            draw_landmarks(panel, cam, truth, TRUTH_COLOUR, radius=3 * k)
        draw_landmarks(panel, cam, landmarks, TRACKED_COLOUR, radius=3 * k)
        if i == 0 and caption:
            cv2.putText(panel, caption, (8, 24 * k), cv2.FONT_HERSHEY_SIMPLEX, 0.6 * k,
                        (255, 255, 255), k, cv2.LINE_AA)
        panels.append(panel)
    return mosaic(panels, max_width=max_width, labels=[c.name for c in cameras])
