"""VoxelGrid: index ↔ world arithmetic, the rig-derived capture box and the memory check."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from voxelmocap.camera import Camera
from voxelmocap.errors import InputError
from voxelmocap.grid import VoxelGrid
from voxelmocap.io.calibration import read_rig

RIG_DIR = Path(__file__).resolve().parents[1] / "calib" / "humaneva_i_like"


@pytest.fixture(scope="module")
def rig():
    return read_rig(RIG_DIR)


def _views(rig, points):
    """Brute force: how many cameras see each point (in front, pixel rounding into the image)."""
    n = np.zeros(len(points), int)
    for cam in rig:
        pix, depth = cam.project(points, return_depth=True)
        n += (depth > 0) & cam.in_image(pix)
    return n


def test_centres_and_indices_round_trip():
    grid = VoxelGrid(origin=(-100.0, 50.0, 0.0), voxel_size=25.0, shape=(4, 3, 5))
    c = grid.centres()
    assert c.shape == (60, 3)
    np.testing.assert_allclose(c[0], [-87.5, 62.5, 12.5])
    idx = np.stack(np.unravel_index(np.arange(60), grid.shape), axis=1)
    np.testing.assert_array_equal(grid.index_of(c), idx)
    np.testing.assert_allclose(grid.high, [0.0, 125.0, 125.0])
    assert VoxelGrid.from_dict(grid.to_dict()) == grid


def test_from_rig_box_holds_what_all_cameras_see(rig):
    height = 2000.0
    grid = VoxelGrid.from_rig(rig, 20.0, height=height)
    assert grid.origin[2] == 0.0 and grid.high[2] == pytest.approx(height)
    assert grid.origin[0] % 20.0 == 0 and grid.origin[1] % 20.0 == 0
    # the capture area's centre (the rig README's 3 m × 2 m box) lies inside
    assert np.all(grid.low[:2] <= [-1500, -1000]) and np.all(grid.high[:2] >= [1500, 1000])
    # any floor point seen by all 7 cameras, with its point `height` above, lies in the box (the
    # lattice pitch of 50 mm bounds how far outside a point between lattice nodes can be)
    rng = np.random.default_rng(0)
    xy = rng.uniform(-6000, 6000, size=(200_000, 2))
    floor = np.column_stack([xy, np.zeros(len(xy))])
    top = floor + [0, 0, height]
    both = (_views(rig, floor) == 7) & (_views(rig, top) == 7)
    assert both.sum() > 1000
    inside = np.all((xy[both] >= grid.low[:2] - 50) & (xy[both] <= grid.high[:2] + 50), axis=1)
    assert inside.all()
    # and the box is tight: each side has such points within 100 mm (+ the snap to voxels)
    seen_xy = xy[both]
    assert np.all(np.abs(seen_xy.min(axis=0) - grid.low[:2]) < 100 + 20)
    assert np.all(np.abs(seen_xy.max(axis=0) - grid.high[:2]) < 100 + 20)


def test_from_rig_fewer_views_bigger_box_and_margin(rig):
    all7 = VoxelGrid.from_rig(rig, 40.0)
    five = VoxelGrid.from_rig(rig, 40.0, min_views=5)
    assert np.all(five.low <= all7.low) and np.all(five.high >= all7.high)
    grown = VoxelGrid.from_rig(rig, 40.0, margin=200.0)
    assert np.all(grown.low[:2] <= all7.low[:2] - 160) and np.all(grown.high[:2] >= all7.high[:2] + 200)


def test_from_rig_bad_input(rig):
    for bad in (0, 8):
        with pytest.raises(InputError, match="min_views"):
            VoxelGrid.from_rig(rig, 20.0, min_views=bad)
    with pytest.raises(InputError, match="no cameras"):
        VoxelGrid.from_rig([], 20.0)
    # a camera looking straight up sees no floor
    up = Camera("UP", fc=(500, 500), cc=(320, 240), R=np.diag([1.0, -1.0, -1.0]),
                T=-np.diag([1.0, -1.0, -1.0]) @ np.array([0.0, 0.0, 3000.0]))
    assert up.optical_axis[2] == -1.0  # sanity: this one looks down ...
    sky = Camera("SKY", fc=(500, 500), cc=(320, 240), R=np.diag([1.0, 1.0, 1.0]),
                 T=(0.0, 0.0, -3000.0))
    assert sky.optical_axis[2] == 1.0  # ... and this one looks up from 3 m
    assert VoxelGrid.from_rig([up], 50.0, height=1000.0).n_voxels > 0
    with pytest.raises(InputError, match="no floor area is seen"):
        VoxelGrid.from_rig([sky], 50.0)


def test_memory_check_names_the_size():
    grid = VoxelGrid(origin=(0, 0, 0), voxel_size=10.0, shape=(1000, 1000, 500))
    assert grid.nbytes(4) == 2_000_000_000
    with pytest.raises(InputError, match=r"1000x1000x500 voxels of 10 mm would need 1\.9 GB"):
        grid.check_memory(4, what="tables", available=1_000_000_000)
    assert grid.check_memory(4, available=10_000_000_000) == 2_000_000_000
    huge = VoxelGrid(origin=(0, 0, 0), voxel_size=1.0, shape=(100_000, 100_000, 10_000))
    with pytest.raises(InputError, match=r"would need .* TB"):
        huge.empty()
    small = VoxelGrid(origin=(0, 0, 0), voxel_size=1.0, shape=(2, 3, 4))
    assert small.empty(np.float32).shape == (2, 3, 4)


def test_from_rig_refuses_grids_too_coarse_to_hold_a_body(rig):
    # 1000 mm high: 200 mm voxels give 5 layers, 125 mm give exactly 8
    with pytest.raises(InputError, match=r"^measurement\.voxel_size: 200 mm voxels give a "
                                         r"\d+x\d+x5 grid .* at least 8 voxels") as info:
        VoxelGrid.from_rig(rig, 200.0, height=1000.0)
    assert "\n" not in str(info.value)
    assert VoxelGrid.from_rig(rig, 125.0, height=1000.0).shape[2] == 8
    with pytest.raises(InputError, match="at least 8 voxels"):
        VoxelGrid.from_rig(rig, 1e9)  # the 2 x 2 x 1 grid of the issue


def test_from_rig_memory_refusal(rig):
    with pytest.raises(InputError, match="would need"):
        VoxelGrid.from_rig(rig, 1.0, bytes_per_voxel=64)
