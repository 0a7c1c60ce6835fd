"""Ray casting and floor shadows against brute-force and closed-form references."""

from __future__ import annotations

import numpy as np
import pytest

from voxelmocap.camera import Camera, Rig
from voxelmocap.io.calibration import read_rig
from voxelmocap.synth import _render_kernels as K
from voxelmocap.synth.body_shape import Primitives
from voxelmocap.synth.render import Renderer, _shadow_discs
from voxelmocap.synth.scene import LIGHT, Scene


def _inside_capsule(p, cap):
    a, b, r = cap[:3], cap[3:6], cap[6]
    s = np.clip((p - a) @ (b - a) / ((b - a) @ (b - a)), 0, 1)
    return np.linalg.norm(p - (a + s[..., None] * (b - a)), axis=-1) <= r


def _inside_ellipsoid(p, ell):
    A = ell[3:].reshape(3, 3)
    return np.linalg.norm((p - ell[:3]) @ A.T, axis=-1) <= 1.0


def _first_hit(o, d, inside, far=4000.0, step=0.25):
    """Brute force: march along the ray, then bisect the first step that enters."""
    ts = np.arange(0.0, far, step)
    hits = np.flatnonzero(inside(o + ts[:, None] * d))
    if hits.size == 0:
        return -1.0
    lo, hi = ts[hits[0] - 1], ts[hits[0]]
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if inside(o + mid * d) else (mid, hi)
    return hi


def _ellipsoid_row(rng):
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    semi = rng.uniform(40, 200, 3)
    A = np.diag(1 / semi) @ q.T
    return np.concatenate([rng.uniform(-100, 100, 3), A.ravel()])


def test_ray_primitives_match_brute_force():
    rng = np.random.default_rng(5)
    checked = 0
    for _ in range(60):
        o = rng.uniform(-800, 800, 3) + np.array([0, 0, 1500.0])
        target = rng.uniform(-150, 150, 3)
        d = target - o
        d /= np.linalg.norm(d)
        cap = np.concatenate([rng.uniform(-200, 200, 3), rng.uniform(-200, 200, 3),
                              [rng.uniform(20, 90)]])
        ell = _ellipsoid_row(rng)
        for prim, fast, inside in ((cap, K.ray_capsule, _inside_capsule),
                                   (ell, K.ray_ellipsoid, _inside_ellipsoid)):
            t_fast = fast(*o, *d, prim)
            t_ref = _first_hit(o, d, lambda p, prim=prim, inside=inside: inside(p, prim))
            if t_ref < 0:
                assert t_fast < 0
            else:
                checked += 1
                assert t_fast == pytest.approx(t_ref, abs=1e-3)
    assert checked >= 40


def _pinhole(name="C0"):
    # 4 m away along −y, looking at the origin, mild distortion: x right, y down, z forward.
    R = np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]])
    C = np.array([0.0, -4000.0, 1000.0])
    return Camera(name, fc=(500, 500), cc=(160, 120), R=R, T=-R @ C,
                  kc=(-0.1, 0.02, 0, 0, 0), size=(320, 240))


def _sphere(c, r, colour):
    A = np.eye(3) / r
    return np.concatenate([c, A.ravel()]), np.asarray(colour, dtype=float)


def test_sphere_mask_is_the_set_of_rays_passing_within_its_radius():
    cam = _pinhole()
    scene = Scene(np.array([-6000.0, -6000, 0]), np.array([6000.0, 6000, 3000]))
    renderer = Renderer(Rig([cam]), scene=scene)
    c, r = np.array([100.0, 200.0, 1100.0]), 150.0
    ell, col = _sphere(c, r, (0.2, 0.4, 0.6))
    prims = Primitives(np.zeros((0, 7)), np.zeros((0, 3)), ell[None], col[None])
    _, mask = renderer.render("C0", prims, shadow=False)
    rays = renderer._views["C0"].rays.astype(float)
    o = cam.center
    # closed form: a ray meets the sphere iff its distance to the centre is below r (sphere ahead)
    v = c - o
    along = rays @ v
    dist = np.sqrt(np.maximum(v @ v - along ** 2, 0))
    expect = (dist < r) & (along > 0)
    margin = np.abs(dist - r) > 0.01  # ignore rays grazing the rim within float32 precision
    assert expect.sum() > 500
    np.testing.assert_array_equal(mask[margin], expect[margin])
    # and the projected centre (full lens model) lands inside the mask
    u, vv = np.round(cam.project(c[None])[0]).astype(int)
    assert mask[vv, u]


def test_nearest_primitive_wins_and_background_objects_occlude():
    cam = _pinhole()
    box_lo, box_hi = np.array([-300.0, -2500, 0]), np.array([300.0, -2300, 800])
    from voxelmocap.synth.scene import Box

    scene = Scene(np.array([-6000.0, -6000, 0]), np.array([6000.0, 6000, 3000]),
                  [Box(box_lo, box_hi, np.array([0.5, 0.5, 0.5]))])
    renderer = Renderer(Rig([cam]), scene=scene)
    near, c_near = _sphere(np.array([0.0, -300, 1000]), 120, (1.0, 0.0, 0.0))
    far, c_far = _sphere(np.array([0.0, 300, 1000]), 300, (0.0, 0.0, 1.0))
    low, c_low = _sphere(np.array([0.0, 0, 400]), 150, (0.0, 1.0, 0.0))  # behind the box
    prims = Primitives(np.zeros((0, 7)), np.zeros((0, 3)), np.stack([far, near, low]),
                       np.stack([c_far, c_near, c_low]))
    img, mask = renderer.render("C0", prims, shadow=False)
    u, v = np.round(cam.project([[0.0, -300, 1000]])[0]).astype(int)
    assert mask[v, u] and img[v, u, 0] > img[v, u, 2]  # the near red sphere, not the blue one
    u, v = np.round(cam.project([[0.0, 0, 400]])[0]).astype(int)
    assert not mask[v, u]  # the box hides the green sphere


def test_shadow_culling_discs_change_nothing():
    rng = np.random.default_rng(2)
    cam = _pinhole()
    scene = Scene(np.array([-6000.0, -6000, 0]), np.array([6000.0, 6000, 3000]))
    view = Renderer(Rig([cam]), scene=scene)._views["C0"]
    caps = np.column_stack([rng.uniform(-300, 300, (6, 2)), rng.uniform(50, 1500, 6),
                            rng.uniform(-300, 300, (6, 2)), rng.uniform(50, 1500, 6),
                            rng.uniform(30, 80, 6)])
    ells = np.stack([_ellipsoid_row(rng) + np.r_[0, 0, 800, np.zeros(9)] for _ in range(6)])
    semi = 1 / np.linalg.svd(ells[:, 3:].reshape(-1, 3, 3), compute_uv=False)
    r_mean = semi.mean(axis=1)
    cap_cull, ell_cull = _shadow_discs(caps, ells[:, :3], semi.max(axis=1), r_mean)
    roi = np.array([0, 320, 0, 240], dtype=np.int64)
    fast = view.background.copy()
    K.floor_shadow(view.floor_points, view.is_floor, roi, caps, ells, r_mean, cap_cull, ell_cull,
                   LIGHT, 0.5, fast)
    no_cull = np.column_stack([np.zeros((6, 2)), np.full(6, 1e9)])
    ref = view.background.copy()
    K.floor_shadow(view.floor_points, view.is_floor, roi, caps, ells, r_mean, no_cull, no_cull,
                   LIGHT, 0.5, ref)
    assert np.any(ref < view.background - 1e-3)  # there is a shadow
    np.testing.assert_array_equal(fast, ref)


def test_primitive_boxes_change_nothing_on_a_real_body():
    from voxelmocap.synth import default_rig_path, procedural_points
    from voxelmocap.synth.body_shape import BodyShape, body_primitives

    rig = read_rig(default_rig_path(), names=["C3", "BW4"])
    renderer = Renderer(rig)
    shape = BodyShape.for_subject("S3", 1800)
    for kind in ("jog", "throwcatch"):
        prims = body_primitives(procedural_points(kind, [0.7])[0], shape)
        for cam in rig.names:
            view = renderer._views[cam]
            roi = renderer.roi(cam, prims)
            cap_box, ell_box = renderer.primitive_boxes(cam, prims)
            out = []
            for boxes in ((cap_box, ell_box),
                          (np.tile([-10**9, 10**9, -10**9, 10**9], (len(cap_box), 1)),
                           np.tile([-10**9, 10**9, -10**9, 10**9], (len(ell_box), 1)))):
                img = view.background.copy()
                mask = np.zeros(img.shape[:2], bool)
                depth = np.zeros(img.shape[:2], np.float32)
                K.cast_body(view.rays, view.origin, roi, prims.capsules, prims.capsule_colours,
                            np.ascontiguousarray(boxes[0], dtype=np.int64), prims.ellipsoids,
                            prims.ellipsoid_colours, np.ascontiguousarray(boxes[1], dtype=np.int64),
                            view.bg_depth, LIGHT, 0.4, img, mask, depth)
                out.append((img, mask))
            assert out[1][1].sum() > 1000
            np.testing.assert_array_equal(out[0][1], out[1][1])
            np.testing.assert_array_equal(out[0][0], out[1][0])
