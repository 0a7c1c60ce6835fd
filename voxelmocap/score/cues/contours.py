"""Projected contours of the truncated cones (paper 000 §3.1.2, eqs 4–10).

A part is the surface ``P(θ, t) = c + t n + H(t) u1 cos θ + W(t) u2 sin θ`` with
``H(t) = H s(t)``, ``W(t) = W s(t)``, ``s(t) = 1 + (R − 1) t / L`` (eqs 4–5). Its surface normal
is ``s(t) (W cos θ u1 + H sin θ u2 − H W (R − 1)/L n)``, independent of ``t``: each contour
generator seen from the camera centre ``v`` is a whole ruling ``θ = const``, and the tangency
condition ``normal · (P − v) = 0`` reduces to (dividing by ``W``)

    a cos θ + B sin θ + K = 0,   a = (c − v)·u1,  B = (H / W) (c − v)·u2,
                                  K = H (1 − (R − 1)/L · (c − v)·n).

This is eq 6 with the axial term as a constant: the paper's eq 6 multiplies it by ``sin θ``, and
its eqs 8–10 (``g² − 2 r g − 1 = 0``) drop ``H`` against ``(c − v)·u1``, an approximation for a
distant camera that fails as ``(c − v)·u1 → 0`` (hence the paper's special case ``θ = π, 0``).
With eq 7's substitution ``cos θ = (1 − g²)/(1 + g²)``, ``sin θ = 2g/(1 + g²)``,
``g = tan(θ/2)``, the exact condition is the quadratic

    (K − a) g² + 2 B g + (K + a) = 0,   discriminant  B² + a² − K².

Eq 7's degenerate case is ``K = a``: the leading coefficient vanishes and one root is ``g = ∞``,
``θ = π``. The roots are computed as ``θ = 2 atan2(q, K − a)`` and ``θ = 2 atan2(K + a, q)`` with
``q = −(B + sign(B) √disc)`` (the numerically stable pair of ``g₁, g₂``), which passes through the
degenerate case continuously. A negative discriminant means the camera looks into the cone along
its axis: one end ellipse hides the lateral surface in the image, there is no contour
generator, and the part has no segments (``valid`` False).

Distortion. The four end points ``A1, A2, B1, B2`` are projected with the camera's full model
(:meth:`voxelmocap.camera.Camera.project`, distortion included) and joined by straight image
segments. The distorted image of a ruling is slightly curved; on HumanEva-like lenses
(``|k1| ≈ 0.1``) and limb segments under 100 px long the chord is within a small fraction of a
pixel of the curve, far below the edge search's ±δ = 15 px, so the segments are not subdivided.

>>> import numpy as np
>>> from voxelmocap.body import BodyModel
>>> from voxelmocap.camera import Camera
>>> model = BodyModel()
>>> cam = Camera("C", fc=(800, 800), cc=(320, 240), R=[[1, 0, 0], [0, 0, -1], [0, 1, 0]],
...              T=[0, 1000, 4000])
>>> seg, valid, depth = project_contours(model.geometry(model.default_state()[None]), cam)
>>> seg.shape, bool(valid.all())
((1, 10, 2, 2, 2), True)
"""

from __future__ import annotations

import numpy as np

from ...thread_waits import serial

__all__ = ["body_mask", "contour_angles", "contour_points", "outline_pixels", "project_contours",
           "project_outlines"]


def contour_angles(geo, centre) -> tuple[np.ndarray, np.ndarray]:
    """Angles ``θ`` of the two contour rulings of every part seen from ``centre``.

    Parameters
    ----------
    geo : voxelmocap.body.PartGeometry
        Cone geometry of P particles (``base``, ``axis``, ``u1``, ``u2`` ``(P, n_parts, 3)``,
        ``shape`` ``(n_parts, 7)``).
    centre : (3,) array_like
        The camera centre ``v`` (mm, world).

    Returns
    -------
    theta : (P, n_parts, 2) float64 ndarray
        ``θ₁, θ₂`` (rad, in (−2π, 2π]); meaningless where ``valid`` is False.
    valid : (P, n_parts) bool ndarray
        The discriminant is non-negative (the part has a contour generator).
    """
    d = geo.base - np.asarray(centre, dtype=float)
    h, w, k_r = geo.shape[:, 4], geo.shape[:, 5], geo.shape[:, 3]
    a = np.einsum("pki,pki->pk", d, geo.u1)
    b = h / w * np.einsum("pki,pki->pk", d, geo.u2)
    k = h * (1.0 - k_r * np.einsum("pki,pki->pk", d, geo.axis))
    disc = b * b + a * a - k * k
    valid = disc >= 0.0
    root = np.sqrt(np.maximum(disc, 0.0))
    q = -(b + np.where(b >= 0.0, root, -root))
    theta = np.empty(a.shape + (2,))
    # g₁ = q / (K − a) and g₂ = (K + a) / q; θ = 2 atan(g), through atan2 so that K = a
    # (eq 7's g = ∞) gives θ = ±π instead of a division by zero.
    theta[..., 0] = 2.0 * np.arctan2(q, k - a)
    theta[..., 1] = 2.0 * np.arctan2(k + a, q)
    return theta, valid


def contour_points(geo, centre) -> tuple[np.ndarray, np.ndarray]:
    """3D end points ``A1, A2`` (ruling θ₁) and ``B1, B2`` (θ₂) of every part's contour.

    Returns
    -------
    points : (P, n_parts, 2, 2, 3) float64 ndarray
        Segment (A, B), end (t = 0, t = L), xyz (mm).
    valid : (P, n_parts) bool ndarray
    """
    theta, valid = contour_angles(geo, centre)
    h, w, length, ratio = geo.shape[:, 4], geo.shape[:, 5], geo.shape[:, 2], geo.shape[:, 6]
    cos, sin = np.cos(theta)[..., None], np.sin(theta)[..., None]
    radial = (h[None, :, None, None] * geo.u1[:, :, None, :] * cos
              + w[None, :, None, None] * geo.u2[:, :, None, :] * sin)     # (P, n, 2, 3)
    points = np.empty(theta.shape + (2, 3))
    points[..., 0, :] = geo.base[:, :, None, :] + radial
    points[..., 1, :] = (geo.base[:, :, None, :] + length[None, :, None, None]
                         * geo.axis[:, :, None, :] + ratio[None, :, None, None] * radial)
    return points, valid


def project_contours(geo, camera) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Image segments of every part's contour in one camera.

    Parameters
    ----------
    geo : voxelmocap.body.PartGeometry
    camera : voxelmocap.camera.Camera

    Returns
    -------
    seg : (P, n_parts, 2, 2, 2) float64 ndarray
        Segment (A, B), end (t = 0, t = L), pixel ``(u, v)``.
    valid : (P, n_parts) bool ndarray
        The part has a contour and all four end points are in front of the camera.
    depth : (P, n_parts) float64 ndarray
        Camera-frame depth (mm) of the part's axis midpoint (occlusion order).
    """
    points, valid = contour_points(geo, camera.center)
    n_p, n_parts = valid.shape
    pixels, z = camera.project(points.reshape(-1, 3), return_depth=True)
    seg = np.ascontiguousarray(pixels.reshape(n_p, n_parts, 2, 2, 2))
    front = (z.reshape(n_p, n_parts, 4) > 1.0).all(axis=2)
    valid = valid & front & np.isfinite(seg).all(axis=(2, 3, 4))
    mid = geo.base + 0.5 * geo.shape[None, :, 2, None] * geo.axis
    depth = camera.world_to_camera(mid.reshape(-1, 3))[:, 2].reshape(n_p, n_parts)
    return seg, valid, np.ascontiguousarray(depth)


#: Points per end ellipse of :func:`project_outlines`.
OUTLINE_POINTS = 12


def _outline_directions(n: int) -> tuple[np.ndarray, np.ndarray]:
    """``grow · cos α_k``, ``grow · sin α_k`` of the ``n`` outline points per end ellipse, with
    ``grow = π / (n sin(π/n))`` (the polygon's mean width is the ellipse's)."""
    angle = 2.0 * np.pi * np.arange(n) / n
    grow = np.pi / (n * np.sin(np.pi / n))
    return grow * np.cos(angle), grow * np.sin(angle)


def project_outlines(geo, camera, *, n: int = OUTLINE_POINTS) -> tuple[np.ndarray, np.ndarray]:
    """Image points whose convex hull is each part's image (the ``silhouette`` cue).

    A truncated cone is the convex hull of its two end ellipses, and a perspective image of a
    convex body in front of the camera is the convex hull of the images of its points: ``n``
    points on each end ellipse give the part's image as a polygon. The points sit on an ellipse
    ``π / (n sin(π/n))`` times the part's (1.012 at n = 12), which gives the polygon the circle's
    mean width (a limb seen from the side is as wide as its end ellipses): its width is then
    within −2.3 … +1.2 % of the part's in every direction instead of falling short everywhere.

    Parameters
    ----------
    geo : voxelmocap.body.PartGeometry
    camera : voxelmocap.camera.Camera
    n : int
        Points per end ellipse.

    Returns
    -------
    points : (P, n_parts, 2 n, 2) float64 ndarray
        Pixel ``(u, v)`` of the points (base ellipse first).
    valid : (P, n_parts) bool ndarray
        Every point of the part is in front of the camera and finite.
    """
    cos, sin = _outline_directions(n)
    h, w, length, ratio = geo.shape[:, 4], geo.shape[:, 5], geo.shape[:, 2], geo.shape[:, 6]
    radial = (h[None, :, None, None] * cos[None, None, :, None] * geo.u1[:, :, None, :]
              + w[None, :, None, None] * sin[None, None, :, None]
              * geo.u2[:, :, None, :])                               # (P, n_parts, n, 3)
    top = geo.base + length[None, :, None] * geo.axis
    pts = np.concatenate([geo.base[:, :, None, :] + radial,
                          top[:, :, None, :] + ratio[None, :, None, None] * radial], axis=2)
    n_p, n_parts = geo.base.shape[:2]
    pixels, z = camera.project(pts.reshape(-1, 3), return_depth=True)
    pixels = np.ascontiguousarray(pixels.reshape(n_p, n_parts, 2 * n, 2))
    valid = ((z.reshape(n_p, n_parts, 2 * n) > 1.0).all(axis=2)
             & np.isfinite(pixels).all(axis=(2, 3)))
    return pixels, valid


def outline_pixels(geo, camera, scale, *, n: int = OUTLINE_POINTS
                   ) -> tuple[np.ndarray, np.ndarray]:
    """:func:`project_outlines` by the numba kernel, in the pixels of a mask reduced by
    ``scale`` (``(u + ½) · scale − ½``); the cue's hot path.

    Returns
    -------
    points : (P, n_parts, 2 n, 2) float64 ndarray
    valid : (P, n_parts) bool ndarray
    """
    from ...measure import _silhouette_kernels as _sk

    cos, sin = _outline_directions(n)
    n_p, n_parts = geo.base.shape[:2]
    points = np.empty((n_p, n_parts, 2 * n, 2))
    valid = np.empty((n_p, n_parts), np.bool_)
    kernel = _sk.outline_points_serial if serial(n_p) else _sk.outline_points
    kernel(np.ascontiguousarray(geo.base), np.ascontiguousarray(geo.axis),
           np.ascontiguousarray(geo.u1), np.ascontiguousarray(geo.u2),
           np.ascontiguousarray(geo.shape), cos, sin, np.ascontiguousarray(camera.R, dtype=float),
           np.asarray(camera.T, dtype=float), np.asarray(camera.fc, dtype=float),
           np.asarray(camera.cc, dtype=float), float(camera.alpha_c),
           np.asarray(camera.kc, dtype=float), np.asarray(scale, dtype=float), points, valid)
    return points, valid


def body_mask(geo, camera, *, size=None) -> np.ndarray:
    """The pixels of one camera that see the body of one state (every part's image filled).

    Each part's image is the convex polygon of :func:`project_outlines`; a part not wholly in
    front of the camera is left out.

    Parameters
    ----------
    geo : voxelmocap.body.PartGeometry
        The geometry of one state (its first is drawn).
    camera : voxelmocap.camera.Camera
    size : (int, int), optional
        Mask ``(W, H)``; default the camera's image size (the polygons stay in the camera's
        pixels: another size crops or pads on the right and at the bottom).

    Returns
    -------
    (H, W) bool ndarray
    """
    import cv2

    w, h = camera.size if size is None else size
    out = np.zeros((int(h), int(w)), np.uint8)
    points, valid = project_outlines(geo, camera)
    for p in np.flatnonzero(valid[0]):
        pts = points[0, p]
        if np.abs(pts).max() > 1e6:  # a part behind the lens's useful field: nothing to fill
            continue
        # 4 fractional bits: the vertices are not rounded to whole pixels (OpenCV still fills
        # every pixel whose centre a scanline's rounded ends reach: up to ½ px wider a side)
        hull = cv2.convexHull(np.round(pts * 16).astype(np.int32))
        cv2.fillConvexPoly(out, hull, 1, lineType=cv2.LINE_8, shift=4)
    return out.astype(bool)
