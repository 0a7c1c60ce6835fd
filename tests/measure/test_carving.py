"""Carving against a brute-force reference and against closed-form visual hulls.

Silhouettes are drawn by the tests from their own geometry: a pixel is inside when the ray through
its centre (``Camera.rays``, which inverts the lens model) hits the analytic sphere or box. This
never uses the forward projection that the carver is built on.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from voxelmocap.camera import Camera, fov_radius, visible
from voxelmocap.errors import InputError
from voxelmocap.grid import VoxelGrid
from voxelmocap.io.calibration import read_rig
from voxelmocap.measure.carving import Carver, EmptySilhouetteWarning, carve, carve_reference

RIG_DIR = Path(__file__).resolve().parents[2] / "calib" / "humaneva_i_like"
SPHERE_C = np.array([150.0, -80.0, 1000.0])
SPHERE_R = 350.0
BOX = (np.array([-400.0, -250.0, 0.0]), np.array([300.0, 350.0, 1700.0]))


@pytest.fixture(scope="module")
def rig():
    return read_rig(RIG_DIR)


@pytest.fixture(scope="module")
def grid(rig):
    # min_views=5 makes a box larger than what all 7 cameras see: the "not seen" rule matters
    return VoxelGrid.from_rig(rig, 50.0, min_views=5)


def _pixel_rays(cam):
    w, h = cam.size
    uu, vv = np.meshgrid(np.arange(w, dtype=float), np.arange(h, dtype=float))
    return cam.rays(np.stack([uu.ravel(), vv.ravel()], axis=1))


def _sphere_masks(rig, centre=SPHERE_C, radius=SPHERE_R):
    masks = []
    for cam in rig:
        o, d = _pixel_rays(cam)
        oc = centre - o
        along = np.einsum("ij,ij->i", oc, d)
        perp2 = np.einsum("ij,ij->i", oc, oc) - along**2
        masks.append(((perp2 <= radius**2) & (along > 0)).reshape(cam.height, cam.width))
    return np.array(masks)


def _box_masks(rig, low=BOX[0], high=BOX[1]):
    masks = []
    for cam in rig:
        o, d = _pixel_rays(cam)
        with np.errstate(divide="ignore", invalid="ignore"):
            t1 = (low - o) / d
            t2 = (high - o) / d
        t_near = np.nanmax(np.minimum(t1, t2), axis=1)
        t_far = np.nanmin(np.maximum(t1, t2), axis=1)
        masks.append(((t_near <= t_far) & (t_far > 0)).reshape(cam.height, cam.width))
    return np.array(masks)


@pytest.fixture(scope="module")
def sphere_masks(rig):
    return _sphere_masks(rig)


@pytest.fixture(scope="module")
def carver(rig, grid):
    return Carver(rig, grid)


def test_sphere_equals_reference(rig, grid, carver, sphere_masks):
    occ = carver.carve(sphere_masks)
    ref = carve_reference(sphere_masks, rig, grid)
    assert occ.shape == grid.shape and occ.dtype == bool
    assert occ.sum() > 500
    assert np.array_equal(occ, ref)


def test_box_equals_reference_and_contains_box(rig, grid, carver):
    masks = _box_masks(rig)
    occ = carver.carve(masks)
    assert np.array_equal(occ, carve_reference(masks, rig, grid))
    c = grid.centres()
    inner = np.all((c > BOX[0] + 30.0) & (c < BOX[1] - 30.0), axis=1).reshape(grid.shape)
    assert inner.sum() > 1000 and np.all(occ[inner])


def test_sphere_matches_closed_form_visual_hull(rig, grid, carver, sphere_masks):
    """Exact hull: X is inside iff, for every camera, the ray C→X passes within R of the centre."""
    occ = carver.carve(sphere_masks)
    centres = grid.centres()
    all_seen = (carver.coverage() == len(rig)).ravel()
    # signed angular clearance (rad) of each voxel centre from each camera's tangent cone
    clearance = np.full(len(centres), np.inf)
    pixel = np.inf
    for cam in rig:
        to_x = centres - cam.center
        to_s = SPHERE_C - cam.center
        ds = np.linalg.norm(to_s)
        cosang = to_x @ to_s / (np.linalg.norm(to_x, axis=1) * ds)
        angle = np.arccos(np.clip(cosang, -1.0, 1.0))
        clearance = np.minimum(clearance, np.arcsin(SPHERE_R / ds) - angle)
        pixel = min(pixel, 1.0 / max(cam.fc))
    # 3 pixels of slack cover rounding and lens distortion near the silhouette's edge
    sure_in = all_seen & (clearance > 3 * pixel)
    sure_out = all_seen & (clearance < -3 * pixel)
    assert sure_in.sum() > 300 and sure_out.sum() > 10000
    flat = occ.ravel()
    assert np.all(flat[sure_in])
    assert not np.any(flat[sure_out])
    # the hull of a sphere from 7 views is a little larger than the sphere
    volume = occ.sum() * grid.voxel_size**3
    assert 1.0 < volume / (4 / 3 * np.pi * SPHERE_R**3) < 1.35


def test_min_views_survives_a_hole(rig, grid, carver, sphere_masks):
    holed = sphere_masks.copy()
    u, v = np.rint(rig[0].project(SPHERE_C[None])[0]).astype(int)
    yy, xx = np.mgrid[: holed.shape[1], : holed.shape[2]]
    holed[0][(xx - u) ** 2 + (yy - v) ** 2 < 15**2] = False
    full = carver.carve(sphere_masks)
    strict = carver.carve(holed)
    tolerant = carver.carve(holed, min_views=len(rig) - 1)
    assert strict.sum() < full.sum()               # the hole tunnels through the hull
    assert np.all(tolerant[full])                  # N-1 views bring every voxel back
    assert np.all(strict <= tolerant)
    for k in (2, len(rig) - 1):
        assert np.array_equal(carver.carve(holed, min_views=k),
                              carve_reference(holed, rig, grid, min_views=k))
    # inside all 7 silhouettes == the default rule wherever all 7 cameras see the voxel
    all_seen = carver.coverage() == len(rig)
    assert np.array_equal(carver.carve(holed, min_views=len(rig))[all_seen], strict[all_seen])


def test_brick_rejection_equals_plain_kernels(rig, grid, carver):
    """Random blobby masks (many partial bricks): brick path == per-voxel kernels == reference."""
    from scipy import ndimage

    rng = np.random.default_rng(11)
    noise = rng.random((len(rig), 480, 640))
    masks = ndimage.gaussian_filter(noise, (0, 6, 6)) > 0.49
    assert 0.3 < masks.mean() < 0.8
    results = {}
    for use_bricks in (True, False):
        carver.use_bricks = use_bricks
        try:
            results[use_bricks] = [carver.carve(masks, min_views=k) for k in (None, 3, 7)]
        finally:
            carver.use_bricks = True
    for a, b in zip(results[True], results[False], strict=True):
        assert a.any() and np.array_equal(a, b)
    assert np.array_equal(results[True][1], carve_reference(masks, rig, grid, min_views=3))


def test_counts_and_coverage(rig, carver, sphere_masks):
    seen, inside = carver.counts(sphere_masks)
    assert np.array_equal(seen, carver.coverage())
    assert np.all(inside <= seen)
    occ = carver.carve(sphere_masks)
    assert np.array_equal(occ, (inside == seen) & (seen > 0))


def test_carve_function_uses_same_rule(rig, grid, carver, sphere_masks):
    occ = carve(sphere_masks, rig, grid)
    assert np.array_equal(occ, carver.carve(sphere_masks))
    assert np.array_equal(carve(list(sphere_masks), list(rig), grid, min_views=3),
                          carver.carve(sphere_masks, min_views=3))


def test_mixed_image_sizes(rig):
    cams = [rig[0].with_size((320, 240)), rig[1], rig[2]]
    grid = VoxelGrid.from_bounds((-600, -600, 500), (600, 600, 1500), 60.0)
    masks = [m[: c.height, : c.width] for m, c in zip(_sphere_masks(rig[:3]), cams, strict=True)]
    occ = Carver(cams, grid).carve(masks)
    assert occ.any()
    assert np.array_equal(occ, carve_reference(masks, cams, grid))


def test_visible_rules():
    cam = Camera("T", fc=(500, 500), cc=(319.5, 239.5), R=np.eye(3), T=(0, 0, 0),
                 kc=(-0.3, 0.0, 0.0, 0.0, 0.0))
    # behind the camera: not seen, even though the pinhole would put it in the image
    u, v, seen = visible(cam, [[0.0, 0.0, -1000.0]])
    assert not seen[0]
    # in front, in the middle
    u, v, seen = visible(cam, [[0.0, 0.0, 1000.0]])
    assert seen[0] and (u[0], v[0]) == (320, 240)  # 319.5 rounds half to even
    # far off axis, the distortion polynomial folds the point back into the image ...
    far = np.array([[2.0 * 1000.0, 0.0, 1000.0]])
    pix = cam.project(far)[0]
    assert 0 <= pix[0] < 640 and 0 <= pix[1] < 480
    # ... but it is outside the field of view, so the camera does not see it
    assert 2.0 > fov_radius(cam)
    assert not visible(cam, far)[2][0]
    # rounding at the image border: -0.49 rounds to pixel 0, -0.51 is outside
    for x, expect in ((-0.49, True), (-0.51, False), (639.49, True), (639.51, False)):
        pt = np.array([[(x - 319.5) / 500 * 1000.0, 0.0, 1000.0]])
        cam0 = Camera("P", fc=(500, 500), cc=(319.5, 239.5), R=np.eye(3), T=(0, 0, 0))
        assert visible(cam0, pt)[2][0] == expect, x


def test_visible_pixels_are_camera_project(rig):
    rng = np.random.default_rng(3)
    pts = rng.uniform([-2500, -2500, -200], [2500, 2500, 2500], size=(20000, 3))
    for cam in rig:
        u, v, seen = visible(cam, pts)
        pix, depth = cam.project(pts, return_depth=True)
        assert seen.sum() > 1000
        assert np.array_equal(u[seen], np.rint(pix[seen, 0]))
        assert np.array_equal(v[seen], np.rint(pix[seen, 1]))
        assert np.all(depth[seen] > 0) and np.all(cam.in_image(pix[seen]))


def test_empty_silhouettes_warn_and_give_empty_grid(rig, grid, carver):
    masks = np.zeros((len(rig), 480, 640), bool)
    with pytest.warns(EmptySilhouetteWarning):
        occ = carver.carve(masks)
    assert occ.shape == grid.shape and not occ.any()


def test_bad_input(rig, grid, carver, sphere_masks):
    with pytest.raises(InputError, match="got 6 masks for 7 cameras"):
        carver.carve(sphere_masks[:6])
    with pytest.raises(InputError, match="camera C1 is 640x479"):
        carver.carve([m[:-1] if i == 0 else m for i, m in enumerate(sphere_masks)])
    with pytest.raises(InputError, match="N_C, H, W"):
        carver.carve(sphere_masks[0])
    for bad in (0, 8, 2.5, "two"):
        with pytest.raises(InputError, match="min_views"):
            carver.carve(sphere_masks, min_views=bad)
    with pytest.raises(InputError, match="masks"):
        carve(sphere_masks, rig[:3], grid)
    with pytest.raises(InputError, match="cameras"):
        Carver([], grid)
    huge = VoxelGrid(origin=(0, 0, 0), voxel_size=1.0, shape=(5000, 5000, 2000))
    with pytest.raises(InputError, match=r"would need .* GB"):
        Carver(rig, huge)


def test_tables_are_camera_project(rig, grid, carver):
    """Every table entry is Camera.project's rounded pixel (or -1 where the camera does not see)."""
    centres = grid.centres()
    offset = 0
    for c, cam in enumerate(rig):
        pix, depth = cam.project(centres, return_depth=True)
        xc = cam.world_to_camera(centres)
        r2 = (xc[:, 0] ** 2 + xc[:, 1] ** 2) / xc[:, 2] ** 2
        ok = (depth > 0) & (r2 <= fov_radius(cam) ** 2)
        u = np.rint(np.where(ok, pix[:, 0], -1.0))
        v = np.rint(np.where(ok, pix[:, 1], -1.0))
        ok &= (u >= 0) & (u < cam.width) & (v >= 0) & (v < cam.height)
        expected = np.where(ok, offset + v * cam.width + u, -1).astype(np.int64)
        assert np.array_equal(carver.tables[c], expected), cam.name
        assert 0 < ok.sum() < len(ok)  # both seen and unseen voxels are exercised
        offset += cam.width * cam.height


def _holes_reference(masks, cameras, grid, holes, abstain):
    """Hole-tolerant carving voxel by voxel through ``Camera.project`` (the rule of
    ``Carver.carve_with_holes``: at least ``holes + 2`` counting views, at most ``holes`` of them
    outside), a camera not counting where its ``abstain`` pixel is set."""
    centres = grid.centres()
    seen = np.zeros(len(centres), int)
    inside = np.zeros(len(centres), int)
    for mask, off, cam in zip(masks, abstain, cameras, strict=True):
        pix, depth = cam.project(centres, return_depth=True)
        xc = cam.world_to_camera(centres)
        with np.errstate(invalid="ignore", divide="ignore"):
            ok = (depth > 0) & ((xc[:, 0] ** 2 + xc[:, 1] ** 2) / xc[:, 2] ** 2
                                <= fov_radius(cam) ** 2)
        u = np.rint(np.where(ok, pix[:, 0], -1.0)).astype(np.int64)
        v = np.rint(np.where(ok, pix[:, 1], -1.0)).astype(np.int64)
        ok &= (u >= 0) & (u < cam.width) & (v >= 0) & (v < cam.height)
        idx = np.flatnonzero(ok)
        if off is not None:
            idx = idx[~off[v[idx], u[idx]]]
        seen[idx] += 1
        inside[idx] += mask[v[idx], u[idx]]
    return ((seen >= holes + 2) & (inside >= seen - holes)).reshape(grid.shape)


def test_abstaining_pixels_do_not_count_in_the_hole_tolerant_carving(rig, grid, carver):
    """Two grey cameras miss the torso's middle (where their plate never saw the background);
    with one hole tolerated that band is carved away, unless those pixels abstain."""
    masks = _box_masks(rig)
    names = [c.name for c in rig]
    band = np.zeros_like(masks)
    for c in (names.index("BW1"), names.index("BW2")):
        rows = np.flatnonzero(masks[c].any(axis=1))
        mid = (rows.min() + rows.max()) // 2
        band[c, mid - 15:mid + 15] = True
    holed = masks & ~band
    abstain = [band[c] if band[c].any() else None for c in range(len(rig))]
    plain = carver.carve_with_holes(holed, 1)
    counted = carver.carve_with_holes(holed, 1, abstain=abstain)
    np.testing.assert_array_equal(counted, _holes_reference(holed, rig, grid, 1, abstain))
    np.testing.assert_array_equal(plain, _holes_reference(holed, rig, grid, 1,
                                                          [None] * len(rig)))
    box = carver.carve_with_holes(masks, 1)
    assert (box & ~plain).sum() > 0.05 * box.sum()          # the band is cut out …
    assert (box & ~counted).sum() == 0                      # … unless it abstains
    np.testing.assert_array_equal(carver.carve_with_holes(holed, 1, abstain=[None] * len(rig)),
                                  plain)
    # a camera left out does not abstain on top of it
    c = names.index("BW1")
    np.testing.assert_array_equal(carver.carve_with_holes(holed, 1, ignore=[c], abstain=abstain),
                                  carver.carve_with_holes(holed, 1, ignore=[c], abstain=[
                                      None if k == c else a for k, a in enumerate(abstain)]))


def test_the_reach_dilation_on_the_silhouettes_box_is_opencvs_on_the_whole_image():
    """The hole rule's reach: a silhouette dilated on its bounding box grown by the radius gives
    OpenCV's whole-image dilation exactly, at the image edges too, and nothing for no person."""
    import cv2

    from voxelmocap.measure.carving import _dilated

    rng = np.random.default_rng(8)
    for _ in range(30):
        h, w = rng.integers(20, 90, 2)
        mask = np.zeros((h, w), np.uint8)
        for _ in range(rng.integers(0, 4)):          # blobs, some touching an edge
            y, x = rng.integers(0, h), rng.integers(0, w)
            mask[y:y + rng.integers(1, 15), x:x + rng.integers(1, 15)] = 1
        r = int(rng.integers(1, 9))
        disk = (np.hypot(*np.mgrid[-r:r + 1, -r:r + 1]) <= r).astype(np.uint8)
        want = cv2.dilate(mask, disk).astype(bool)
        np.testing.assert_array_equal(_dilated(mask, disk, r), want)
