"""Edge search, occlusion test and region sampling: kernels against the listings and brute force."""

import numpy as np
import pytest
from matplotlib.path import Path as MplPath

from voxelmocap.score.cues import _cue_kernels as k
from voxelmocap.score.cues import reference as ref


def _step_image(col, low=50.0, high=120.0, size=(100, 120)):
    """Grey image with a vertical step between columns ``col − 1`` and ``col``."""
    img = np.full(size, low, np.float32)
    img[:, col:] = high
    return img


def _one_segment(x1, y1, x2, y2):
    seg = np.zeros((1, 1, 2, 2, 2))
    seg[0, 0, 0] = [[x1, y1], [x2, y2]]
    seg[0, 0, 1] = [[x1, y1], [x2, y2]]
    return seg


@pytest.mark.parametrize("offset", [-12, -5, 0, 3, 14])
def test_edge_search_finds_step_at_offset(offset):
    # A vertical segment at u = 60 going down: the normal ((y1 − y2), (x2 − x1)) / l = (−1, 0), so
    # search sample j sits at u = 60 + δ − j and is compared with u − 1; the pair straddles the
    # step (columns col − 1 | col) at j0 = 60 + δ − col = δ + offset: the cost is offset².
    delta = 15
    col = 60 - offset
    img = _step_image(col)
    ssd, n = ref.go_through_line(img, 60.0, 20.0, 60.0, 70.0, search=delta)
    # the pair (u, u − 1) straddles the step when u = col: j = δ + 60 − col = δ + offset
    assert ssd == pytest.approx(n * offset ** 2)
    seg = _one_segment(60.0, 20.0, 60.0, 70.0)
    out_ssd, out_n = k.empty_outputs(1)
    k.edge_ssd(seg[:, :, :1].repeat(2, axis=2), np.ones((1, 1), bool), np.zeros((1, 1)), img, 5.0,
               delta, 12.0, 0.0, 225.0, 400.0, True, out_ssd, out_n)
    assert out_ssd[0] == pytest.approx(2 * n * offset ** 2) and out_n[0] == 2 * n


def test_no_edge_costs_c3_and_g_min_is_respected():
    flat = np.full((100, 120), 80.0, np.float32)
    ssd, n = ref.go_through_line(flat, 60.0, 20.0, 60.0, 70.0)
    assert ssd == pytest.approx(n * 20.0 ** 2)           # C3 = (δ + 5)²
    weak = _step_image(60, 80.0, 92.0)                    # a step of 12 = G_MIN: not an edge
    assert ref.go_through_line(weak, 60.0, 20.0, 60.0, 70.0)[0] == pytest.approx(n * 400.0)
    strong = _step_image(60, 80.0, 93.0)                  # 13 > G_MIN: found at offset 0
    assert ref.go_through_line(strong, 60.0, 20.0, 60.0, 70.0)[0] == pytest.approx(0.0)
    assert ref.go_through_line(weak, 60.0, 20.0, 60.0, 70.0, g_min=11.0)[0] == pytest.approx(0.0)


def test_search_leaving_picture_costs_c1_and_occluded_c2():
    img = _step_image(60)
    ssd, n = ref.go_through_line(img, 5.0, 20.0, 5.0, 70.0, c1=7.0)   # ±15 px leaves the image
    assert ssd == pytest.approx(7.0 * n)
    ssd, n = ref.go_through_line(img, 60.0, 20.0, 60.0, 70.0, occluded=lambda o: True)
    assert ssd == pytest.approx(225.0 * n)


def _random_quads(rng, n):
    """Quadrangles A1 A2 B2 B1 shaped like projected cones (convex or not, never crossed)."""
    out = []
    while len(out) < n:
        c = rng.uniform(20, 100, 2)
        d = rng.normal(size=2)
        d /= np.linalg.norm(d)
        nrm = np.array([-d[1], d[0]])
        length = rng.uniform(5, 60)
        w1, w2 = rng.uniform(1, 20, 2)
        a1 = c + w1 * nrm + rng.normal(0, 3, 2)
        b1 = c - w1 * nrm + rng.normal(0, 3, 2)
        a2 = c + length * d + w2 * nrm + rng.normal(0, 3, 2)
        b2 = c + length * d - w2 * nrm + rng.normal(0, 3, 2)
        quad = np.array([a1, a2, b2, b1])
        # keep simple polygons only (the sides A1A2 and B2B1 do not cross)
        if not _segments_cross(a1, a2, b2, b1) and not _segments_cross(a2, b2, b1, a1):
            out.append(quad)
    return out


def _segments_cross(p1, p2, q1, q2):
    def orient(a, b, c):
        return np.sign((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))
    return (orient(p1, p2, q1) * orient(p1, p2, q2) < 0) and (orient(q1, q2, p1) * orient(q1, q2, p2) < 0)


def test_occlusion_test_agrees_with_point_in_polygon():
    rng = np.random.default_rng(3)
    n_checked = 0
    for quad in _random_quads(rng, 300):
        path = MplPath(quad)
        pts = rng.uniform(0, 140, size=(60, 2))
        truth = path.contains_points(pts)
        # points within 1e-6 of an edge are ambiguous for both tests
        for p, t in zip(pts, truth, strict=True):
            got_kernel = k.in_quadrangle(p[0], p[1], *quad[0], *quad[1], *quad[2], *quad[3])
            got_ref = ref.in_quadrangle_reference(p, quad[0], quad[1], quad[2], quad[3])
            assert got_kernel == got_ref == t
            n_checked += 1
    assert n_checked == 18000


def _random_bodies(rng, n_p=6, n_parts=5):
    seg = np.empty((n_p, n_parts, 2, 2, 2))
    for p in range(n_p):
        for part in range(n_parts):
            a1, a2, b2, b1 = _random_quads(rng, 1)[0]
            seg[p, part] = [[a1, a2], [b1, b2]]
    valid = rng.random((n_p, n_parts)) > 0.15
    depth = rng.uniform(1000, 5000, (n_p, n_parts))
    return seg, valid, depth


def test_edge_kernel_equals_reference():
    rng = np.random.default_rng(11)
    grey = rng.integers(0, 60, size=(130, 150)).astype(np.float32)
    grey[:, 70:] += 80
    grey[40:90, 20:60] += 50
    seg, valid, depth = _random_bodies(rng)
    for occlusion in (True, False):
        want = ref.edge_ssd_reference(seg, valid, depth, grey, occlusion=occlusion)
        ssd, n = k.empty_outputs(len(seg))
        k.edge_ssd(seg, valid, depth, grey, 5.0, 15, 12.0, 0.0, 225.0, 400.0, occlusion, ssd, n)
        np.testing.assert_array_equal(ssd, want[0])
        np.testing.assert_array_equal(n, want[1])


def test_dt_kernel_equals_reference():
    rng = np.random.default_rng(12)
    dt = rng.uniform(0, 30, size=(130, 150)).astype(np.float32)
    seg, valid, depth = _random_bodies(rng)
    want = ref.dt_sum_reference(seg, valid, depth, dt)
    total, n = k.empty_outputs(len(seg))
    k.dt_sum(seg, valid, depth, dt, 5.0, True, total, n)
    np.testing.assert_allclose(total, want[0], rtol=1e-12)
    np.testing.assert_array_equal(n, want[1])


def test_region_kernel_equals_reference():
    rng = np.random.default_rng(13)
    colour = rng.integers(0, 256, size=(130, 150, 3)).astype(np.float32)
    bins = rng.integers(0, 64, size=(130, 150)).astype(np.int32)
    seg, valid, depth = _random_bodies(rng)
    want_h, want_m = ref.region_stats_reference(seg, valid, depth, bins, colour, 64, n_s=4, n_t=6)
    hist = np.zeros_like(want_h)
    mom = np.zeros_like(want_m)
    k.region_stats(seg, valid, depth, bins, colour, 4, 6, True, hist, mom)
    np.testing.assert_array_equal(hist, want_h)
    np.testing.assert_allclose(mom, want_m, rtol=1e-12)
    assert hist.sum() > 100


def test_occluded_points_are_those_inside_nearer_parts():
    # part 1 (nearer) covers the middle of part 0's segment: those points cost C2 = 225
    seg = np.zeros((1, 2, 2, 2, 2))
    seg[0, 0] = [[[50, 20], [50, 80]], [[50, 20], [50, 80]]]          # a thin vertical part
    seg[0, 1] = [[[30, 40], [70, 40]], [[30, 60], [70, 60]]]          # a box u 30..70, v 40..60
    grey = _step_image(50)                                           # step right on part 0
    depth = np.array([[2000.0, 1000.0]])
    ssd, n = k.empty_outputs(1)
    k.edge_ssd(seg, np.array([[True, False]]), depth, grey, 5.0, 15, 12.0, 0.0, 225.0, 400.0, True,
               ssd, n)
    assert ssd[0] == 0.0 and n[0] == 28                              # 14 points per side, offset 0
    k.edge_ssd(seg, np.array([[True, True]]), depth, grey, 5.0, 15, 12.0, 0.0, 225.0, 400.0, True,
               ssd, n)
    vs = 20 + np.arange(14) * 60 / 13
    hidden = int(((vs >= 40) & (vs <= 60)).sum())                    # 4 points per side
    # part 1's horizontal sides (10 points each) search vertically and find no step: C3 = 400
    assert hidden == 4
    assert ssd[0] == 2 * hidden * 225.0 + 20 * 400.0
    assert n[0] == 28 + 20
