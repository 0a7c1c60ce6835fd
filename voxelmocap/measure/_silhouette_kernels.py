"""Numba kernels of the silhouettes: the background test and the body's image counted against a mask.

* :func:`gaussian_foreground` — :meth:`voxelmocap.measure.silhouette.GaussianBackground.foreground`
  (one component). NumPy evaluates the per-pixel Gaussian log-likelihood through whole-image
  temporaries (the difference, its square, the weighted channel sum, the constant) on one core;
  at 7 cameras this was half of the measurement stage. The kernel does the same float32
  arithmetic in the same order per pixel, rows spread over the cores, and writes the mask
  directly (``tests/measure/test_silhouette.py`` compares it with the NumPy expression).
* :func:`outline_points`, :func:`cover_counts`, :func:`cover_counts_prefixed`, :func:`draw_parts`,
  :func:`row_prefix` — the silhouette cue (:mod:`voxelmocap.score.cues`): each part's projected
  outline, its convex image rasterised at pixel centres and counted inside and outside a mask;
  ``_serial`` twins of the first and third for a few poses (:func:`voxelmocap.thread_waits.serial`;
  :func:`count_cover` picks for the counts), sharing each pose's code.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange


@njit(cache=True, parallel=True)
def gaussian_foreground(x, mean, inv_var, const, threshold, mask):
    """``mask = const − ½ Σ_c (x − mean)² · inv_var < threshold`` per pixel.

    Parameters
    ----------
    x : (H, W, C) float32 or uint8 ndarray
        Image (uint8 is read as it is: no float copy of the whole image).
    mean, inv_var : (H, W, C) float32 ndarray
        Background means and inverse variances.
    const : (H, W) float32 ndarray
        The Gaussian's log normalisation per pixel.
    threshold : float
        Log-likelihood below which a pixel is foreground (compared in float64).
    mask : (H, W) bool ndarray
        Output.
    """
    h, w, n_c = x.shape
    half = np.float32(0.5)
    for i in prange(h):
        for j in range(w):
            acc = np.float32(0.0)
            for c in range(n_c):
                d = np.float32(x[i, j, c]) - mean[i, j, c]
                acc += d * d * inv_var[i, j, c]
            mask[i, j] = np.float64(const[i, j] - half * acc) < threshold


@njit(cache=True, inline="always")
def _cross(ox, oy, ax, ay, bx, by):
    return (ax - ox) * (by - oy) - (ay - oy) * (bx - ox)


@njit(cache=True, inline="always")
def _convex_hull(xs, ys, n, order, hx, hy):
    """Andrew's monotone chain: the hull of ``n`` points into ``hx, hy`` (first vertex not
    repeated, collinear points dropped); returns the number of hull vertices."""
    for i in range(n):
        order[i] = i
    for i in range(1, n):  # insertion sort by (x, y): n is a couple of dozen points
        k = order[i]
        j = i - 1
        while j >= 0 and (xs[order[j]] > xs[k] or (xs[order[j]] == xs[k] and ys[order[j]] > ys[k])):
            order[j + 1] = order[j]
            j -= 1
        order[j + 1] = k
    m = 0
    for t in range(n):  # lower chain
        i = order[t]
        while m >= 2 and _cross(hx[m - 2], hy[m - 2], hx[m - 1], hy[m - 1], xs[i], ys[i]) <= 0.0:
            m -= 1
        hx[m] = xs[i]
        hy[m] = ys[i]
        m += 1
    floor = m + 1
    for t in range(n - 2, -1, -1):  # upper chain
        i = order[t]
        while m >= floor and _cross(hx[m - 2], hy[m - 2], hx[m - 1], hy[m - 1], xs[i], ys[i]) <= 0.0:
            m -= 1
        hx[m] = xs[i]
        hy[m] = ys[i]
        m += 1
    return m - 1


#: outline coordinates (mask pixels) beyond which a part is not drawn: a part grazing the
#: lens projects to ~1e24 px under distortion, where converting to pixel indices overflows
#: (``voxelmocap.score.cues.contours.body_mask`` skips such parts the same way)
MAX_OUTLINE_PIXELS = 1e6


@njit(cache=True)
def _drawable(pts) -> bool:
    """Whether every outline point ``(K, 2)`` is finite and within :data:`MAX_OUTLINE_PIXELS`."""
    for k in range(pts.shape[0]):
        for d in range(2):
            if not abs(pts[k, d]) <= MAX_OUTLINE_PIXELS:    # also False for NaN
                return False
    return True


@njit(cache=True, inline="always")
def _row_extent(hx, hy, nv, y):
    """``(lo, hi)``: where row ``y`` crosses the convex polygon ``hx, hy`` (``nv`` vertices);
    ``hi < lo`` when it misses it."""
    lo, hi = np.inf, -np.inf
    for v in range(nv):  # the row's crossings of the hull's edges
        ax, ay = hx[v], hy[v]
        bx, by = hx[(v + 1) % nv], hy[(v + 1) % nv]
        if (ay <= y <= by) or (by <= y <= ay):
            if ay == by:
                lo, hi = min(lo, ax, bx), max(hi, ax, bx)
            else:
                x = ax + (bx - ax) * (y - ay) / (by - ay)
                lo, hi = min(lo, x), max(hi, x)
    return lo, hi


@njit(cache=True)
def draw_parts(points, valid, out):
    """Set the pixels of the union of the parts' images in ``out``, each pixel as
    :func:`cover_counts` counts it (the same hulls, row crossings and rounding).

    Parameters
    ----------
    points : (n_parts, K, 2) float64 ndarray
        Outline points ``(x, y)`` of one state's parts in mask pixels.
    valid : (n_parts,) bool ndarray
    out : (H, W) bool ndarray
        Drawn into (pixels already set stay set).
    """
    n_parts, n_k = points.shape[0], points.shape[1]
    h, w = out.shape
    order = np.empty(n_k, np.int64)
    hx = np.empty(2 * n_k, np.float64)
    hy = np.empty(2 * n_k, np.float64)
    for q in range(n_parts):
        if not valid[q] or not _drawable(points[q]):
            continue
        m = _convex_hull(points[q, :, 0], points[q, :, 1], n_k, order, hx, hy)
        if m < 3:
            continue
        r0, r1 = h, -1
        for v in range(m):
            r0 = min(r0, int(np.ceil(hy[v])))
            r1 = max(r1, int(np.floor(hy[v])))
        for i in range(max(r0, 0), min(r1, h - 1) + 1):
            lo, hi = _row_extent(hx, hy, m, float(i))
            if hi < lo:
                continue
            for j in range(max(int(np.ceil(lo)), 0), min(int(np.floor(hi)), w - 1) + 1):
                out[i, j] = True


def cover_counts(points, valid, mask, hit, extra):
    """Pixels of a silhouette covered by the projected body, and body pixels outside it.

    Each part's image is the convex hull of its projected outline points (a truncated cone is the
    convex hull of its two end ellipses, and so is its perspective image); the union of the
    parts is rasterised at pixel centres (pixel ``(i, j)`` centred at ``x = j, y = i``).

    Parameters
    ----------
    points : (P, n_parts, K, 2) float64 ndarray
        Outline points ``(x, y)`` of every part in mask pixels.
    valid : (P, n_parts) bool ndarray
        The part is wholly in front of the camera (others are not drawn, nor is a part with an
        outline point beyond :data:`MAX_OUTLINE_PIXELS` or not finite).
    mask : (H, W) bool ndarray
        The silhouette.
    hit, extra : (P,) int64 ndarray
        Output: drawn pixels inside / outside the silhouette.
    """
    count_cover(points, valid, row_prefix(mask), hit, extra)


@njit(cache=True)
def row_prefix(mask):
    """``(H, W + 1)`` int64 row prefix sums of a ``(H, W)`` bool mask: a row's union of the
    parts' spans is counted per span, not per pixel (shared by every particle, and by every call
    of a search that scores against one mask: :mod:`voxelmocap.score.cues.partial`)."""
    h, w = mask.shape
    csum = np.zeros((h, w + 1), np.int64)
    for i in range(h):
        acc = 0
        for j in range(w):
            if mask[i, j]:
                acc += 1
            csum[i, j + 1] = acc
    return csum


@njit(cache=True)
def _cover_one(points, valid, csum, p):
    """Pose ``p``'s ``(hit, extra)`` of :func:`cover_counts_prefixed`."""
    n_parts, n_k = points.shape[1], points.shape[2]
    h, w = csum.shape[0], csum.shape[1] - 1
    order = np.empty(n_k, np.int64)
    hx = np.empty((n_parts, 2 * n_k), np.float64)
    hy = np.empty((n_parts, 2 * n_k), np.float64)
    m = np.zeros(n_parts, np.int64)
    q_lo = np.empty(n_parts, np.int64)
    q_hi = np.empty(n_parts, np.int64)
    span_lo = np.empty(n_parts, np.int64)
    span_hi = np.empty(n_parts, np.int64)
    r0, r1, c0, c1 = h, -1, w, -1
    for q in range(n_parts):
        q_lo[q], q_hi[q] = h, -1
        if not valid[p, q] or not _drawable(points[p, q]):
            continue
        m[q] = _convex_hull(points[p, q, :, 0], points[p, q, :, 1], n_k, order, hx[q], hy[q])
        for v in range(m[q]):
            q_lo[q] = min(q_lo[q], int(np.ceil(hy[q, v])))
            q_hi[q] = max(q_hi[q], int(np.floor(hy[q, v])))
            c0 = min(c0, int(np.ceil(hx[q, v])))
            c1 = max(c1, int(np.floor(hx[q, v])))
        r0, r1 = min(r0, q_lo[q]), max(r1, q_hi[q])
    r0, r1, c0, c1 = max(r0, 0), min(r1, h - 1), max(c0, 0), min(c1, w - 1)
    n_hit = 0
    n_extra = 0
    if r1 >= r0 and c1 >= c0:
        for i in range(r0, r1 + 1):
            y = float(i)
            k = 0
            for q in range(n_parts):
                nv = m[q]
                if nv < 3 or i < q_lo[q] or i > q_hi[q]:
                    continue
                lo, hi = _row_extent(hx[q], hy[q], nv, y)
                if hi < lo:
                    continue
                j0, j1 = max(int(np.ceil(lo)), c0), min(int(np.floor(hi)), c1)
                if j1 < j0:
                    continue
                # insertion by start: at most n_parts spans a row
                t = k
                while t > 0 and span_lo[t - 1] > j0:
                    span_lo[t], span_hi[t] = span_lo[t - 1], span_hi[t - 1]
                    t -= 1
                span_lo[t], span_hi[t] = j0, j1
                k += 1
            # the union of the spans, counted against the mask's prefix sums
            a, b = 0, -1
            for t in range(k):
                if span_lo[t] > b:
                    if b >= a:
                        inside = csum[i, b + 1] - csum[i, a]
                        n_hit += inside
                        n_extra += b - a + 1 - inside
                    a, b = span_lo[t], span_hi[t]
                elif span_hi[t] > b:
                    b = span_hi[t]
            if b >= a:
                inside = csum[i, b + 1] - csum[i, a]
                n_hit += inside
                n_extra += b - a + 1 - inside
    return n_hit, n_extra


@njit(cache=True, parallel=True)
def cover_counts_prefixed(points, valid, csum, hit, extra):
    """:func:`cover_counts` against a mask given by its :func:`row_prefix` ``(H, W + 1)``."""
    for p in prange(points.shape[0]):
        hit[p], extra[p] = _cover_one(points, valid, csum, p)


@njit(cache=True)
def cover_counts_prefixed_serial(points, valid, csum, hit, extra):
    """:func:`cover_counts_prefixed` on one thread: for a few poses
    (:func:`voxelmocap.thread_waits.serial`)."""
    for p in range(points.shape[0]):
        hit[p], extra[p] = _cover_one(points, valid, csum, p)


def count_cover(points, valid, csum, hit, extra):
    """:func:`cover_counts_prefixed`, on one thread for a few poses
    (:func:`voxelmocap.thread_waits.serial`): the same values either way."""
    from ..thread_waits import serial

    kernel = cover_counts_prefixed_serial if serial(points.shape[0]) else cover_counts_prefixed
    kernel(points, valid, csum, hit, extra)


@njit(cache=True)
def _outline_one(base, axis, u1, u2, shape, cosines, sines, rot, trans, fc, cc, alpha, kc,
                 scale, points, valid, p):
    """Pose ``p``'s outline points and validity of :func:`outline_points`."""
    n_parts = base.shape[1]
    n = cosines.shape[0]
    k1, k2, p1, p2, k3 = kc[0], kc[1], kc[2], kc[3], kc[4]
    for q in range(n_parts):
        h, w, length, ratio = shape[q, 4], shape[q, 5], shape[q, 2], shape[q, 6]
        ok = True
        for end in range(2):
            s = 1.0 if end == 0 else ratio
            t = 0.0 if end == 0 else length
            for k in range(n):
                hc, ws = s * h * cosines[k], s * w * sines[k]
                wx = base[p, q, 0] + t * axis[p, q, 0] + hc * u1[p, q, 0] + ws * u2[p, q, 0]
                wy = base[p, q, 1] + t * axis[p, q, 1] + hc * u1[p, q, 1] + ws * u2[p, q, 1]
                wz = base[p, q, 2] + t * axis[p, q, 2] + hc * u1[p, q, 2] + ws * u2[p, q, 2]
                xc = rot[0, 0] * wx + rot[0, 1] * wy + rot[0, 2] * wz + trans[0]
                yc = rot[1, 0] * wx + rot[1, 1] * wy + rot[1, 2] * wz + trans[1]
                zc = rot[2, 0] * wx + rot[2, 1] * wy + rot[2, 2] * wz + trans[2]
                i = end * n + k
                if not zc > 1.0:
                    ok = False
                    points[p, q, i, 0] = 0.0
                    points[p, q, i, 1] = 0.0
                    continue
                a = xc / zc
                b = yc / zc
                r2 = a * a + b * b
                radial = 1.0 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2
                xd = a * radial + 2.0 * p1 * a * b + p2 * (r2 + 2.0 * a * a)
                yd = b * radial + p1 * (r2 + 2.0 * b * b) + 2.0 * p2 * a * b
                u = fc[0] * (xd + alpha * yd) + cc[0]
                v = fc[1] * yd + cc[1]
                points[p, q, i, 0] = (u + 0.5) * scale[0] - 0.5
                points[p, q, i, 1] = (v + 0.5) * scale[1] - 0.5
        valid[p, q] = ok


@njit(cache=True, parallel=True)
def outline_points(base, axis, u1, u2, shape, cosines, sines, rot, trans, fc, cc, alpha, kc,
                   scale, points, valid):
    """:func:`voxelmocap.score.cues.contours.project_outlines` in one pass, in mask pixels.

    Parameters
    ----------
    base, axis, u1, u2 : (P, n_parts, 3) float64 ndarray
    shape : (n_parts, 7) float64 ndarray
        :class:`~voxelmocap.body.model.PartGeometry`'s ``shape``.
    cosines, sines : (n,) float64 ndarray
        ``grow · cos α_k``, ``grow · sin α_k`` of the ``n`` points per end ellipse.
    rot, trans, fc, cc, alpha, kc
        The camera (:class:`~voxelmocap.camera.Camera` ``R``, ``T``, ``fc``, ``cc``,
        ``alpha_c``, ``kc``).
    scale : (2,) float64 ndarray
        Image → mask pixels: ``(u + ½) · scale − ½``.
    points : (P, n_parts, 2 n, 2) float64 ndarray
        Output.
    valid : (P, n_parts) bool ndarray
        Output: every point in front of the camera (depth > 1 mm).
    """
    for p in prange(base.shape[0]):
        _outline_one(base, axis, u1, u2, shape, cosines, sines, rot, trans, fc, cc, alpha, kc,
                     scale, points, valid, p)


@njit(cache=True)
def outline_points_serial(base, axis, u1, u2, shape, cosines, sines, rot, trans, fc, cc, alpha,
                          kc, scale, points, valid):
    """:func:`outline_points` on one thread: for a few poses
    (:func:`voxelmocap.thread_waits.serial`)."""
    for p in range(base.shape[0]):
        _outline_one(base, axis, u1, u2, shape, cosines, sines, rot, trans, fc, cc, alpha, kc,
                     scale, points, valid, p)
