"""Surface voxels V^S and the smoothed surface map Ṽ^S."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from voxelmocap.camera import Camera
from voxelmocap.grid import VoxelGrid
from voxelmocap.measure.carving import Carver
from voxelmocap.measure.surface import _bounding_box, smooth_surface, surface_voxels


def _shell(shape, lo, hi):
    """Voxels of the box [lo, hi) (indices) that lie on one of its six faces."""
    idx = np.indices(shape)
    inside = np.all([(idx[a] >= lo[a]) & (idx[a] < hi[a]) for a in range(3)], axis=0)
    face = np.any([(idx[a] == lo[a]) | (idx[a] == hi[a] - 1) for a in range(3)], axis=0)
    return inside & face, inside


def _far_camera(name, axis, distance=100_000.0, f=20_000.0):
    """A near-orthographic camera on +``axis`` looking at the origin."""
    forward = -np.eye(3)[axis]
    up = np.array([0.0, 0.0, 1.0]) if axis != 2 else np.array([0.0, 1.0, 0.0])
    right = np.cross(forward, up)
    down = np.cross(forward, right)
    R = np.stack([right, down, forward])
    centre = distance * np.eye(3)[axis]
    return Camera(name, fc=(f, f), cc=(319.5, 239.5), R=R, T=-R @ centre)


def _box_masks(cameras, low, high):
    masks = []
    for cam in cameras:
        w, h = cam.size
        uu, vv = np.meshgrid(np.arange(w, dtype=float), np.arange(h, dtype=float))
        o, d = cam.rays(np.stack([uu.ravel(), vv.ravel()], axis=1))
        with np.errstate(divide="ignore", invalid="ignore"):
            t1, t2 = (low - o) / d, (high - o) / d
        near = np.nanmax(np.minimum(t1, t2), axis=1)
        far = np.nanmin(np.maximum(t1, t2), axis=1)
        masks.append(((near <= far) & (far > 0)).reshape(h, w))
    return np.array(masks)


def test_surface_of_a_carved_cube_is_its_shell():
    grid = VoxelGrid(origin=(-600.0, -600.0, -600.0), voxel_size=50.0, shape=(24, 24, 24))
    low, high = np.array([-300.0, -250.0, -200.0]), np.array([300.0, 350.0, 400.0])
    cams = [_far_camera(n, a) for n, a in (("X", 0), ("Y", 1), ("Z", 2))]
    occ = Carver(cams, grid).carve(_box_masks(cams, low, high))
    lo = ((low - grid.low) / grid.voxel_size).astype(int)
    hi = ((high - grid.low) / grid.voxel_size).astype(int)
    shell, cube = _shell(grid.shape, lo, hi)
    assert np.array_equal(occ, cube)  # three orthogonal near-orthographic views carve the cube
    surf = surface_voxels(occ)
    assert np.array_equal(surf, shell)
    n = hi - lo
    assert surf.sum() == np.prod(n) - np.prod(n - 2)


def test_surface_at_the_grid_border_and_empty():
    occ = np.zeros((6, 7, 8), bool)
    occ[0:4, 2:7, 3:8] = True  # touches three grid faces
    shell, _ = _shell(occ.shape, (0, 2, 3), (4, 7, 8))
    assert np.array_equal(surface_voxels(occ), shell)
    assert not surface_voxels(np.zeros((3, 3, 3), bool)).any()
    assert not smooth_surface(np.zeros((3, 3, 3), bool), 1.0).any()
    with pytest.raises(ValueError):
        surface_voxels(np.zeros((3, 3), bool))


@pytest.mark.parametrize("sigma", [0.7, 1.0, 2.0])
def test_smoothing_equals_whole_grid_filter_and_stays_in_unit_range(sigma):
    rng = np.random.default_rng(int(sigma * 10))
    occ = np.zeros((40, 36, 30), bool)
    occ[12:25, 10:20, 3:28] = True
    occ &= rng.random(occ.shape) > 0.05  # ragged, with holes
    surf = surface_voxels(occ)
    # reference: scipy on the whole grid (no cropping), divided by the 1-D kernel's centre weight
    radius = int(4.0 * sigma + 0.5)
    x = np.arange(-radius, radius + 1)
    g0 = 1.0 / np.exp(-0.5 * (x / sigma) ** 2).sum()
    ref = ndimage.gaussian_filter(surf.astype(np.float64), sigma, mode="constant") / g0
    ref = np.clip(ref, 0.0, 1.0)
    ref[surf] = 1.0
    got = smooth_surface(surf, sigma)
    assert got.dtype == np.float32
    np.testing.assert_allclose(got, ref, atol=1e-5)
    assert got.min() >= 0.0 and got.max() <= 1.0
    assert np.all(got[surf] == 1.0)
    # the surface reference from scipy's erosion on the whole grid
    interior = ndimage.binary_erosion(occ, ndimage.generate_binary_structure(3, 1), border_value=0)
    assert np.array_equal(surf, occ & ~interior)


def test_flat_surface_profile_is_gaussian():
    """A plane of surface voxels: Ṽ^S at distance d is exp(-d²/2σ²) (exact for the normalised kernel)."""
    sigma = 1.5
    surf = np.zeros((30, 30, 30), bool)
    surf[:, :, 15] = True
    smooth = smooth_surface(surf, sigma)
    for d in range(0, 6):
        expected = np.exp(-(d**2) / (2 * sigma**2))
        # far from the x, y borders (where the constant mode loses mass)
        np.testing.assert_allclose(smooth[10:20, 10:20, 15 + d], expected, rtol=1e-5)
        np.testing.assert_allclose(smooth[10:20, 10:20, 15 - d], expected, rtol=1e-5)
    assert np.all(smooth[:, :, 15 + 7:] == 0.0)  # beyond the kernel's reach (radius 6)


@pytest.mark.parametrize("density", [0.0, 1e-5, 1e-3, 0.05])
def test_bounding_box_equals_the_box_of_np_nonzero(density):
    """The two-step reduction gives the box of ``np.nonzero`` (grown and clipped) exactly."""
    rng = np.random.default_rng(11)
    for shape in [(1, 1, 1), (7, 1, 9), (23, 17, 31), (40, 33, 12)]:
        vol = rng.random(shape) < density
        for pad in (0, 1, 4):
            got = _bounding_box(vol, pad)
            idx = np.nonzero(vol)
            if len(idx[0]) == 0:
                assert got is None
                continue
            want = tuple(slice(max(int(i.min()) - pad, 0), min(int(i.max()) + pad + 1, n))
                         for i, n in zip(idx, shape, strict=True))
            assert got == want
