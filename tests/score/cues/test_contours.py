"""Contour segments of the cones against a brute-force rendered silhouette (paper 000 §3.1.2)."""

from types import SimpleNamespace

import numpy as np
import pytest
from scipy import ndimage

from voxelmocap.body import BodyModel
from voxelmocap.camera import Camera
from voxelmocap.score.cues import contour_angles, contour_points, project_contours


def _frame(axis, rng):
    """Orthonormal (u1, u2) perpendicular to ``axis`` with a random roll."""
    helper = np.array([1.0, 0, 0]) if abs(axis[0]) < 0.9 else np.array([0, 1.0, 0])
    u1 = np.cross(axis, helper)
    u1 /= np.linalg.norm(u1)
    u2 = np.cross(axis, u1)
    roll = rng.uniform(0, 2 * np.pi)
    return np.cos(roll) * u1 + np.sin(roll) * u2, -np.sin(roll) * u1 + np.cos(roll) * u2


def _cone(rng, H=None, W=None, L=None, R=None):
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    u1, u2 = _frame(axis, rng)
    H = rng.uniform(40, 160) if H is None else H
    W = rng.uniform(40, 160) if W is None else W
    L = rng.uniform(200, 600) if L is None else L
    R = rng.uniform(0.5, 1.3) if R is None else R
    base = rng.uniform(-200, 200, size=3) + np.array([0, 0, 1000.0])
    geo = SimpleNamespace(base=base[None, None], axis=axis[None, None], u1=u1[None, None],
                          u2=u2[None, None],
                          shape=np.array([[1 / H, 1 / W, L, (R - 1) / L, H, W, R]]))
    return geo, (base, axis, u1, u2, H, W, L, R)


def _look_at(eye, target, *, kc=(0, 0, 0, 0, 0), f=700.0):
    z = target - eye
    z /= np.linalg.norm(z)
    x = np.cross(z, [0, 0, 1.0])
    if np.linalg.norm(x) < 1e-6:
        x = np.cross(z, [0, 1.0, 0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    rot = np.stack([x, y, z])
    return Camera("T", fc=(f, f), cc=(320.0, 240.0), R=rot, T=-rot @ eye, kc=kc)


SCALE = 4  # the brute-force silhouette is rendered at 4 × 4 sub-pixels per pixel


def _silhouette(cam, cone, size=(480, 640)):
    """Sub-pixel mask of the solid cone: dense surface and cap samples projected, holes closed."""
    base, axis, u1, u2, H, W, L, R = cone
    th = np.linspace(0, 2 * np.pi, 2880, endpoint=False)
    ring = np.outer(np.cos(th), u1) * H + np.outer(np.sin(th), u2) * W
    pts = []
    for t in np.linspace(0, L, 400):
        pts.append(base + t * axis + (1 + (R - 1) * t / L) * ring)
    for t in (0.0, L):
        for rho in np.linspace(0, 1, 200):
            pts.append(base + t * axis + rho * (1 + (R - 1) * t / L) * ring)
    uv = np.floor(cam.project(np.concatenate(pts)) * SCALE + 0.5).astype(int)
    h, w = size[0] * SCALE, size[1] * SCALE
    mask = np.zeros((h, w), bool)
    ok = (uv[:, 0] >= 0) & (uv[:, 0] < w) & (uv[:, 1] >= 0) & (uv[:, 1] < h)
    mask[uv[ok, 1], uv[ok, 0]] = True
    mask = ndimage.binary_fill_holes(ndimage.binary_closing(mask, iterations=2))
    return mask


def _boundary_distance(mask, uv):
    """Distance (pixels) from ``uv`` to the boundary of the sub-pixel mask."""
    edge = mask & ~ndimage.binary_erosion(mask)
    ys, xs = np.nonzero(edge)
    return float(np.min(np.hypot(xs / SCALE - uv[0], ys / SCALE - uv[1])))


def _on_boundary(mask, uv, radius=1.0):
    return _boundary_distance(mask, uv) <= radius


def _check_case(geo, cone, cam):
    seg, valid, _ = project_contours(geo, cam)
    assert valid[0, 0]
    mask = _silhouette(cam, cone)
    ys, xs = np.nonzero(mask)
    pix = np.stack([xs, ys], axis=1) / SCALE
    for s in range(2):
        for e in range(2):
            assert _on_boundary(mask, seg[0, 0, s, e]), (s, e, seg[0, 0, s, e])
        # the segment's line supports the silhouette: no part of it lies beyond (1 px)
        a, b = seg[0, 0, s]
        if np.linalg.norm(b - a) > 2.0:
            n = np.array([a[1] - b[1], b[0] - a[0]]) / np.linalg.norm(b - a)
            side = (pix - a) @ n
            assert min(side.max(), -side.min()) <= 1.0 + 1.0 / SCALE


@pytest.mark.parametrize("seed", range(6))
def test_endpoints_on_silhouette_boundary(seed):
    rng = np.random.default_rng(seed)
    geo, cone = _cone(rng)
    centre = cone[0] + 0.5 * cone[6] * cone[1]
    direction = rng.normal(size=3)
    direction /= np.linalg.norm(direction)
    kc = (-0.11, 0.08, 0.0004, -0.0003, -0.012) if seed % 2 else (0, 0, 0, 0, 0)
    # near cameras (1.5 m) make the paper's far-camera approximation of eqs 8-10 visibly wrong
    cam = _look_at(centre + rng.uniform(1500, 3000) * direction, centre, kc=kc)
    _check_case(geo, cone, cam)


@pytest.mark.parametrize("seed", range(4))
def test_near_degenerate_view_along_axis(seed):
    """Camera close to the axis line, just outside the region with no contour generator."""
    rng = np.random.default_rng(100 + seed)
    geo, cone = _cone(rng, R=0.6 if seed % 2 else 1.0)
    base, axis, u1, _u2, _H, _W, L, _R = cone
    end = base + L * axis if seed < 2 else base
    out = axis if seed < 2 else -axis
    dist = 1500.0
    # smallest tilt away from the axis at which both rulings exist, then a little more
    tilts = np.linspace(0, 0.6, 6001)
    for tilt in tilts:
        eye = end + dist * (np.cos(tilt) * out + np.sin(tilt) * u1)
        if contour_angles(geo, eye)[1][0, 0]:
            break
    eye = end + dist * (np.cos(tilt + 0.002) * out + np.sin(tilt + 0.002) * u1)
    cam = _look_at(eye, base + 0.5 * L * axis)
    _check_case(geo, cone, cam)


def test_on_axis_has_no_contour_and_degenerate_root():
    rng = np.random.default_rng(7)
    geo, (base, axis, u1, u2, H, W, L, _R) = _cone(rng, R=1.0)
    assert not contour_angles(geo, base + (L + 1000) * axis)[1][0, 0]
    # K = a (eq 7's degenerate case): a cylinder seen from v with (c − v)·u1 = H → θ = π a root
    v = base - H * u1 + 1000 * u2 + 300 * axis
    theta, valid = contour_angles(geo, v)
    assert valid[0, 0]
    assert np.isclose(abs(np.cos(theta[0, 0, 0])), 1.0) or np.isclose(abs(np.cos(theta[0, 0, 1])), 1.0)
    points, _ = contour_points(geo, v)
    # every contour point satisfies the tangency: the view ray is perpendicular to the normal
    for s in range(2):
        p = points[0, 0, s, 0]
        th = theta[0, 0, s]
        normal = W * np.cos(th) * u1 + H * np.sin(th) * u2
        assert abs(np.dot(normal, p - v)) < 1e-6 * np.linalg.norm(p - v) * H * W


def test_body_model_contours_shapes_and_depth():
    model = BodyModel()
    cam = _look_at(np.array([0.0, -4000.0, 1000.0]), np.array([0.0, 0.0, 1000.0]))
    x = np.repeat(model.default_state()[None], 3, axis=0)
    seg, valid, depth = project_contours(model.geometry(x), cam)
    assert seg.shape == (3, 10, 2, 2, 2) and valid.all()
    assert np.allclose(depth, 4000.0, atol=200.0)


@pytest.mark.parametrize("seed", [0, 1])
def test_body_mask_is_the_image_of_points_sampled_inside_the_cones(seed):
    """Every point inside a cone projects into the mask, and every mask pixel lies within a
    pixel of such a point (dense sampling of the solid cones: a brute-force image)."""
    from voxelmocap.score.cues.contours import body_mask

    rng = np.random.default_rng(seed)
    model = BodyModel()
    state = model.default_state()
    state[6:] += rng.uniform(-0.4, 0.4, size=len(state) - 6)      # joints moved
    geo = model.geometry(state[None], legal=False)
    cam = _look_at(np.array([500.0, -4000.0, 1200.0]), np.array([0.0, 0.0, 1000.0]),
                   kc=(-0.1, 0.02, 0, 0, 0))
    mask = body_mask(geo, cam, size=(640, 480))
    n = 40000
    pts = []
    for p, part in enumerate(model.parts):
        t = rng.uniform(0, 1, n)
        rho = np.sqrt(rng.uniform(0, 1, n)) * (1 + (part.R - 1) * t)
        a = rng.uniform(0, 2 * np.pi, n)
        pts.append(geo.base[0, p] + (t * part.L)[:, None] * geo.axis[0, p]
                   + (rho * part.H * np.cos(a))[:, None] * geo.u1[0, p]
                   + (rho * part.W * np.sin(a))[:, None] * geo.u2[0, p])
    pix = np.round(cam.project(np.concatenate(pts))).astype(int)
    inside = (pix[:, 0] >= 0) & (pix[:, 0] < 640) & (pix[:, 1] >= 0) & (pix[:, 1] < 480)
    pix = pix[inside]
    image = np.zeros((480, 640), bool)
    image[pix[:, 1], pix[:, 0]] = True
    grown = ndimage.binary_dilation(mask, iterations=1)
    assert grown[pix[:, 1], pix[:, 0]].mean() > 0.999
    near = ndimage.binary_dilation(image, iterations=2)
    assert mask[~near].sum() < 0.01 * mask.sum()
    assert 0.9 < image.sum() / mask.sum() < 1.1
    # no shift: OpenCV's fill widens the polygons evenly, so the centroids agree
    centre = np.argwhere(mask).mean(axis=0)
    assert np.abs(centre - np.argwhere(image).mean(axis=0)).max() < 0.25
