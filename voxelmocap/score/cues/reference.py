"""Plain-python references of the cue kernels (:mod:`voxelmocap.score.cues._cue_kernels`), for the tests.

They follow the listings of paper 000 §4.1.1 (GoThroughLine) and §4.3 (SameSide2D,
PointInTriangle2D, IsOccluded) line by line, one particle at a time, with the kernels' rounding
(``floor(x + 0.5)``), so that the kernels must reproduce them exactly.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["dt_sum_reference", "edge_ssd_reference", "go_through_line", "in_quadrangle_reference",
           "point_in_triangle", "region_stats_reference"]


def _rnd(x: float) -> int:
    return int(math.floor(x + 0.5))


def same_side(p1, p2, a, b) -> bool:
    """SameSide2D of the listing."""
    ba0, ba1 = b[0] - a[0], b[1] - a[1]
    cp1 = ba0 * (p1[1] - a[1]) - ba1 * (p1[0] - a[0])
    cp2 = ba0 * (p2[1] - a[1]) - ba1 * (p2[0] - a[0])
    return cp1 * cp2 >= 0.0


def point_in_triangle(p, a, b, c) -> bool:
    """PointInTriangle2D of the listing."""
    return same_side(p, a, b, c) and same_side(p, b, a, c) and same_side(p, c, a, b)


def in_quadrangle_reference(p, a1, a2, b2, b1) -> bool:
    """Point in the quadrangle ``A1 A2 B2 B1`` (two triangles along an inner diagonal)."""
    d = (b2[0] - a1[0], b2[1] - a1[1])
    s2 = d[0] * (a2[1] - a1[1]) - d[1] * (a2[0] - a1[0])
    s1 = d[0] * (b1[1] - a1[1]) - d[1] * (b1[0] - a1[0])
    if s1 * s2 < 0.0:
        return point_in_triangle(p, a1, a2, b2) or point_in_triangle(p, a1, b2, b1)
    return point_in_triangle(p, a1, a2, b1) or point_in_triangle(p, a2, b2, b1)


def _occluded(seg, valid, depth, part, o) -> bool:
    for q in range(len(valid)):
        if q == part or not valid[q] or depth[q] >= depth[part]:
            continue
        if in_quadrangle_reference(o, seg[q, 0, 0], seg[q, 0, 1], seg[q, 1, 1], seg[q, 1, 0]):
            return True
    return False


def _walk(x1, y1, x2, y2, spacing):
    """The observed points of one segment, and its unit normal (None for a null segment)."""
    length = math.sqrt((x2 - x1) ** 2 + (y1 - y2) ** 2)
    if length < 1e-9:
        return [], None
    normal = ((y1 - y2) / length, (x2 - x1) / length)
    m_steps = int(math.floor(length / spacing)) + 1
    dx, dy = (x2 - x1) / m_steps, (y2 - y1) / m_steps
    return [(x1 + m * dx, y1 + m * dy) for m in range(m_steps + 1)], normal


def go_through_line(grey, x1, y1, x2, y2, *, spacing=5.0, search=15, g_min=12.0, c1=0.0,
                    c2=None, c3=None, occluded=lambda o: False) -> tuple[float, int]:
    """GoThroughLine of paper 000 §4.1.1 for one segment: ``(ssd, observed points)``.

    The listing returns ``ssd / M²``; here the sum and the count are returned so that several
    segments add up to one contour (:func:`edge_ssd_reference`).
    """
    c2 = float(search) ** 2 if c2 is None else c2
    c3 = float(search + 5) ** 2 if c3 is None else c3
    height, width = grey.shape
    points, normal = _walk(x1, y1, x2, y2, spacing)
    ssd = 0.0
    for ox, oy in points:
        nx, ny = normal
        p1 = (ox - search * nx, oy - search * ny)
        p2 = (ox + (search + 1) * nx, oy + (search + 1) * ny)
        inside = all(0 <= _rnd(p[0]) < width and 0 <= _rnd(p[1]) < height for p in (p1, p2))
        if not inside:
            ssd += c1
        elif occluded((ox, oy)):
            ssd += c2
        else:
            j0, g0 = -1, g_min
            px, py = p1
            for j in range(2 * search + 1):
                i1 = float(grey[_rnd(py), _rnd(px)])
                i2 = float(grey[_rnd(py + ny), _rnd(px + nx)])
                g = abs(i1 - i2)
                if g > g0:
                    j0, g0 = j, g
                px, py = px + nx, py + ny
            ssd += c3 if j0 == -1 else float((j0 - search) ** 2)
    return ssd, len(points)


def edge_ssd_reference(seg, valid, depth, grey, *, spacing=5.0, search=15, g_min=12.0, c1=0.0,
                       c2=None, c3=None, occlusion=True):
    """``(ssd (P,), count (P,))`` of :func:`voxelmocap.score.cues._cue_kernels.edge_ssd`, one
    particle at a time."""
    n_p, n_parts = valid.shape
    ssd, count = np.zeros(n_p), np.zeros(n_p)
    for p in range(n_p):
        for part in range(n_parts):
            if not valid[p, part]:
                continue
            for s in range(2):
                (x1, y1), (x2, y2) = seg[p, part, s]

                def occ(o, p=p, part=part):
                    return occlusion and _occluded(seg[p], valid[p], depth[p], part, o)

                v, n = go_through_line(grey, x1, y1, x2, y2, spacing=spacing, search=search,
                                       g_min=g_min, c1=c1, c2=c2, c3=c3, occluded=occ)
                ssd[p] += v
                count[p] += n
    return ssd, count


def dt_sum_reference(seg, valid, depth, dt, *, spacing=5.0, occlusion=True):
    """``(sum (P,), count (P,))`` of :func:`voxelmocap.score.cues._cue_kernels.dt_sum`."""
    n_p, n_parts = valid.shape
    height, width = dt.shape
    total, count = np.zeros(n_p), np.zeros(n_p)
    for p in range(n_p):
        for part in range(n_parts):
            if not valid[p, part]:
                continue
            for s in range(2):
                (x1, y1), (x2, y2) = seg[p, part, s]
                for ox, oy in _walk(x1, y1, x2, y2, spacing)[0]:
                    u, v = _rnd(ox), _rnd(oy)
                    if not (0 <= u < width and 0 <= v < height):
                        continue
                    if occlusion and _occluded(seg[p], valid[p], depth[p], part, (ox, oy)):
                        continue
                    total[p] += float(dt[v, u])
                    count[p] += 1
    return total, count


def region_stats_reference(seg, valid, depth, bins, colour, n_bins, *, n_s=4, n_t=6,
                           occlusion=True):
    """``(hist, moments)`` of :func:`voxelmocap.score.cues._cue_kernels.region_stats`."""
    n_p, n_parts = valid.shape
    height, width = bins.shape
    n_c = colour.shape[2]
    hist = np.zeros((n_p, n_parts, n_bins))
    moments = np.zeros((n_p, n_parts, 1 + 2 * n_c))
    for p in range(n_p):
        for part in range(n_parts):
            if not valid[p, part]:
                continue
            (a1, a2), (b1, b2) = seg[p, part]
            for i in range(n_s):
                s = (i + 0.5) / n_s
                for k in range(n_t):
                    t = (k + 0.5) / n_t
                    x, y = (1 - t) * ((1 - s) * a1 + s * b1) + t * ((1 - s) * a2 + s * b2)
                    u, v = _rnd(x), _rnd(y)
                    if not (0 <= u < width and 0 <= v < height):
                        continue
                    if occlusion and _occluded(seg[p], valid[p], depth[p], part, (x, y)):
                        continue
                    hist[p, part, bins[v, u]] += 1
                    moments[p, part, 0] += 1
                    for c in range(n_c):
                        val = float(colour[v, u, c])
                        moments[p, part, 1 + 2 * c] += val
                        moments[p, part, 2 + 2 * c] += val * val
    return hist, moments
