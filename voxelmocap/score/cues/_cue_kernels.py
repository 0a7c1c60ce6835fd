"""Numba kernels of the image cues (:mod:`voxelmocap.score.cues`), parallel over particles.

Every kernel reads one camera's projected body: per particle the two contour segments of every
part (``seg (P, n_parts, 2, 2, 2)``: part, segment A/B, end t = 0 / t = L, pixel u/v), whether
the part has them (``valid (P, n_parts)``) and the depth of each part's axis midpoint
(``depth (P, n_parts)``, mm). A part's image region is the quadrangle ``A1 A2 B2 B1`` of its
segments (paper 000 §4.3).

* :func:`edge_ssd` — Azad's walk along the projected segments with on-the-fly edge search
  (paper 000 §4.1.1, the listing) and the fast occlusion test (§4.3);
* :func:`dt_sum` — Fontmarty's distance-transform edge distance: the distance image sampled at the
  same walk's visible points (paper 004 §III-B.1);
* :func:`region_stats` — colour histograms and colour moments of the visible pixels sampled
  inside every part's quadrangle (paper 004 §III-B.2, §III-B.5).

Plain numpy references of the same loops are in :mod:`voxelmocap.score.cues.reference`; the tests
hold these kernels to them. Pixel ``(u, v)`` is column ``u``, row ``v``; a sample position is
rounded to the nearest pixel with ``floor(x + 0.5)``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange


@njit(cache=True, inline="always")
def _rnd(x):
    return int(math.floor(x + 0.5))


@njit(cache=True, inline="always")
def _same_side(p1x, p1y, p2x, p2y, ax, ay, bx, by):
    """Azad's SameSide2D: p1 and p2 on the same side of the line ab (or on it)."""
    ba0 = bx - ax
    ba1 = by - ay
    cp1 = ba0 * (p1y - ay) - ba1 * (p1x - ax)
    cp2 = ba0 * (p2y - ay) - ba1 * (p2x - ax)
    return cp1 * cp2 >= 0.0


@njit(cache=True, inline="always")
def _in_triangle(px, py, ax, ay, bx, by, cx, cy):
    """Azad's PointInTriangle2D from three sign tests (multiplications only)."""
    return (_same_side(px, py, ax, ay, bx, by, cx, cy)
            and _same_side(px, py, bx, by, ax, ay, cx, cy)
            and _same_side(px, py, cx, cy, ax, ay, bx, by))


@njit(cache=True)
def in_quadrangle(px, py, a1x, a1y, a2x, a2y, b2x, b2y, b1x, b1y):
    """Point in the quadrangle ``A1 A2 B2 B1`` as two triangles split along an inner diagonal.

    The listing of paper 000 §4.3 tests the triangles (a1, a2, b1) and (b1, b2, a1), which
    cover the polygon a1 a2 b1 b2; our polygon runs A1 A2 B2 B1, so the split is along the
    diagonal A1 B2 when A2 and B1 lie on opposite sides of it (it is then inside the polygon),
    else along A2 B1 (a non-convex quadrangle has only one inner diagonal).
    """
    dx = b2x - a1x
    dy = b2y - a1y
    s2 = dx * (a2y - a1y) - dy * (a2x - a1x)
    s1 = dx * (b1y - a1y) - dy * (b1x - a1x)
    if s1 * s2 < 0.0:
        return (_in_triangle(px, py, a1x, a1y, a2x, a2y, b2x, b2y)
                or _in_triangle(px, py, a1x, a1y, b2x, b2y, b1x, b1y))
    return (_in_triangle(px, py, a1x, a1y, a2x, a2y, b1x, b1y)
            or _in_triangle(px, py, a2x, a2y, b2x, b2y, b1x, b1y))


@njit(cache=True)
def _boxes(seg, p):
    """``(n_parts, 4)`` bounding boxes (u min, u max, v min, v max) of particle p's quadrangles."""
    n_parts = seg.shape[1]
    box = np.empty((n_parts, 4))
    for q in range(n_parts):
        box[q, 0] = box[q, 1] = seg[p, q, 0, 0, 0]
        box[q, 2] = box[q, 3] = seg[p, q, 0, 0, 1]
        for s in range(2):
            for e in range(2):
                u = seg[p, q, s, e, 0]
                v = seg[p, q, s, e, 1]
                box[q, 0] = min(box[q, 0], u)
                box[q, 1] = max(box[q, 1], u)
                box[q, 2] = min(box[q, 2], v)
                box[q, 3] = max(box[q, 3], v)
    return box


@njit(cache=True, inline="always")
def _occluded(seg, valid, depth, box, p, part, ox, oy):
    """A point of ``part`` hidden by a nearer part's quadrangle (paper 000 §4.3).

    A point outside a quadrangle's bounding box is outside it: the sign tests run only inside
    the box (the same answer, several times faster).
    """
    for q in range(seg.shape[1]):
        if q == part or not valid[p, q] or depth[p, q] >= depth[p, part]:
            continue
        if ox < box[q, 0] or ox > box[q, 1] or oy < box[q, 2] or oy > box[q, 3]:
            continue
        if in_quadrangle(ox, oy, seg[p, q, 0, 0, 0], seg[p, q, 0, 0, 1],
                         seg[p, q, 0, 1, 0], seg[p, q, 0, 1, 1],
                         seg[p, q, 1, 1, 0], seg[p, q, 1, 1, 1],
                         seg[p, q, 1, 0, 0], seg[p, q, 1, 0, 1]):
            return True
    return False


@njit(cache=True, inline="always")
def _in_picture(x, y, width, height):
    u = _rnd(x)
    v = _rnd(y)
    return 0 <= u < width and 0 <= v < height


@njit(cache=True, parallel=True)
def edge_ssd(seg, valid, depth, grey, spacing, search, g_min, c1, c2, c3, occlusion,
             out_ssd, out_count):
    """Azad's GoThroughLine over every segment of every particle (paper 000 §4.1.1).

    Parameters
    ----------
    seg : (P, n_parts, 2, 2, 2) float64
    valid : (P, n_parts) bool
    depth : (P, n_parts) float64
    grey : (H, W) float32
        Grey image.
    spacing : float
        Δ, pixels between observed points along a segment.
    search : int
        δ, the search reaches δ pixels to each side along the normal.
    g_min : float
        G_MIN, smallest grey-level step that counts as an edge.
    c1, c2, c3 : float
        Costs of a point whose search leaves the picture, of an occluded point and of a point
        with no edge.
    occlusion : bool
        Apply the occlusion test.
    out_ssd, out_count : (P,) float64
        Sum of the costs and number of observed points, per particle.
    """
    n_p, n_parts = valid.shape
    height, width = grey.shape
    for p in prange(n_p):
        box = _boxes(seg, p)
        ssd = 0.0
        count = 0.0
        for part in range(n_parts):
            if not valid[p, part]:
                continue
            for s in range(2):
                x1 = seg[p, part, s, 0, 0]
                y1 = seg[p, part, s, 0, 1]
                x2 = seg[p, part, s, 1, 0]
                y2 = seg[p, part, s, 1, 1]
                length = math.sqrt((x2 - x1) ** 2 + (y1 - y2) ** 2)
                if length < 1e-9:
                    continue
                nx = (y1 - y2) / length
                ny = (x2 - x1) / length
                m_steps = int(math.floor(length / spacing)) + 1
                dx = (x2 - x1) / m_steps
                dy = (y2 - y1) / m_steps
                for m in range(m_steps + 1):
                    ox = x1 + m * dx
                    oy = y1 + m * dy
                    count += 1.0
                    p1x = ox - search * nx
                    p1y = oy - search * ny
                    # the last pair compares the sample at +δ with the one beyond it
                    p2x = ox + (search + 1) * nx
                    p2y = oy + (search + 1) * ny
                    if not (_in_picture(p1x, p1y, width, height)
                            and _in_picture(p2x, p2y, width, height)):
                        ssd += c1
                    elif occlusion and _occluded(seg, valid, depth, box, p, part, ox, oy):
                        ssd += c2
                    else:
                        j0 = -1
                        g0 = g_min
                        px = p1x
                        py = p1y
                        # the listing reads I(p) and I(p + n) and then steps p += n: the second
                        # read is the next step's first (the same float sum), so it is reused
                        i1 = grey[_rnd(py), _rnd(px)]
                        for j in range(2 * search + 1):
                            px += nx
                            py += ny
                            i2 = grey[_rnd(py), _rnd(px)]
                            g = abs(i1 - i2)
                            if g > g0:
                                j0 = j
                                g0 = g
                            i1 = i2
                        if j0 == -1:
                            ssd += c3
                        else:
                            ssd += (j0 - search) ** 2
        out_ssd[p] = ssd
        out_count[p] = count


@njit(cache=True, parallel=True)
def dt_sum(seg, valid, depth, dt, spacing, occlusion, out_sum, out_count):
    """Distance-image values summed over the visible points of the segment walk.

    The points are those of :func:`edge_ssd` (spacing Δ, both ends included); points outside
    the picture and points hidden by a nearer part are left out (paper 004 §III-B.1: "removal
    of its hidden parts").

    Parameters
    ----------
    dt : (H, W) float32
        Distance (pixels) to the nearest edge pixel.
    out_sum, out_count : (P,) float64
    """
    n_p, n_parts = valid.shape
    height, width = dt.shape
    for p in prange(n_p):
        box = _boxes(seg, p)
        total = 0.0
        count = 0.0
        for part in range(n_parts):
            if not valid[p, part]:
                continue
            for s in range(2):
                x1 = seg[p, part, s, 0, 0]
                y1 = seg[p, part, s, 0, 1]
                x2 = seg[p, part, s, 1, 0]
                y2 = seg[p, part, s, 1, 1]
                length = math.sqrt((x2 - x1) ** 2 + (y1 - y2) ** 2)
                if length < 1e-9:
                    continue
                m_steps = int(math.floor(length / spacing)) + 1
                dx = (x2 - x1) / m_steps
                dy = (y2 - y1) / m_steps
                for m in range(m_steps + 1):
                    ox = x1 + m * dx
                    oy = y1 + m * dy
                    if not _in_picture(ox, oy, width, height):
                        continue
                    if occlusion and _occluded(seg, valid, depth, box, p, part, ox, oy):
                        continue
                    total += dt[_rnd(oy), _rnd(ox)]
                    count += 1.0
        out_sum[p] = total
        out_count[p] = count


@njit(cache=True, parallel=True)
def region_stats(seg, valid, depth, bins, colour, n_s, n_t, occlusion, out_hist, out_moments):
    """Histograms and colour moments of the visible samples inside every part's quadrangle.

    Sample ``(i, k)`` of a part is the bilinear point ``(1 − t)((1 − s) A1 + s B1) +
    t((1 − s) A2 + s B2)`` with ``s = (i + ½)/n_s``, ``t = (k + ½)/n_t``; samples outside the
    picture or hidden by a nearer part are skipped.

    Parameters
    ----------
    bins : (H, W) int32
        Histogram bin of every pixel (computed once per frame).
    colour : (H, W, C) float32
        The image's channels (C = 3, or 1 for a grey camera).
    n_s, n_t : int
        Samples across and along a part.
    out_hist : (P, n_parts, n_bins) float64
        Sample counts per bin (zeroed by the caller).
    out_moments : (P, n_parts, 1 + 2 C) float64
        Number of samples, then per channel the sum and the sum of squares (zeroed by the caller).
    """
    n_p, n_parts = valid.shape
    height, width = bins.shape
    n_c = colour.shape[2]
    for p in prange(n_p):
        box = _boxes(seg, p)
        for part in range(n_parts):
            if not valid[p, part]:
                continue
            a1x = seg[p, part, 0, 0, 0]
            a1y = seg[p, part, 0, 0, 1]
            a2x = seg[p, part, 0, 1, 0]
            a2y = seg[p, part, 0, 1, 1]
            b1x = seg[p, part, 1, 0, 0]
            b1y = seg[p, part, 1, 0, 1]
            b2x = seg[p, part, 1, 1, 0]
            b2y = seg[p, part, 1, 1, 1]
            for i in range(n_s):
                s = (i + 0.5) / n_s
                for k in range(n_t):
                    t = (k + 0.5) / n_t
                    x = (1.0 - t) * ((1.0 - s) * a1x + s * b1x) + t * ((1.0 - s) * a2x + s * b2x)
                    y = (1.0 - t) * ((1.0 - s) * a1y + s * b1y) + t * ((1.0 - s) * a2y + s * b2y)
                    if not _in_picture(x, y, width, height):
                        continue
                    if occlusion and _occluded(seg, valid, depth, box, p, part, x, y):
                        continue
                    u = _rnd(x)
                    v = _rnd(y)
                    out_hist[p, part, bins[v, u]] += 1.0
                    out_moments[p, part, 0] += 1.0
                    for c in range(n_c):
                        val = colour[v, u, c]
                        out_moments[p, part, 1 + 2 * c] += val
                        out_moments[p, part, 2 + 2 * c] += val * val


def empty_outputs(n_p: int) -> tuple[np.ndarray, np.ndarray]:
    """Two zeroed ``(P,)`` float64 accumulators."""
    return np.zeros(n_p), np.zeros(n_p)
