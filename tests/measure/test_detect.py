"""Extremity detection on voxels: closed-form shapes and rendered cone bodies."""

from __future__ import annotations

import numpy as np
import pytest

from voxelmocap.body import BodyModel
from voxelmocap.errors import InputError
from voxelmocap.grid import VoxelGrid
from voxelmocap.measure.detect import find_extremities
from voxelmocap.score.likelihood import rasterise

#: Landmarks at the ends of the body: head top, L/R wrist, L/R ankle (LANDMARK_NAMES order).
ENDS = [14, 4, 7, 10, 13]


def _star(gap_at_rod: int | None = None, gap: int = 0):
    """A 5×5×5 cube at the centre of a 61³ grid with four rods along ±x, ±y and one along +z.

    Rod lengths (voxels beyond the cube face): 20, 15, 25, 10 and 18. Returns the occupancy and
    the expected tip indices with their geodesic distances from the cube centre (voxels).
    """
    occ = np.zeros((61, 61, 61), dtype=bool)
    c = 30
    occ[c - 2:c + 3, c - 2:c + 3, c - 2:c + 3] = True
    rods = [((1, 0, 0), 20), ((-1, 0, 0), 15), ((0, 1, 0), 25), ((0, -1, 0), 10), ((0, 0, 1), 18)]
    tips, dists = [], []
    for r, (direction, length) in enumerate(rods):
        d = np.array(direction)
        for s in range(3, 3 + length):
            if gap_at_rod == r and 3 + 4 <= s < 3 + 4 + gap:
                continue  # a hole cuts the rod
            occ[tuple(c + s * d)] = True
        tips.append(c + (2 + length) * d)
        dists.append(2 + length)
    return occ, np.array(tips), np.array(dists, dtype=float)


def test_star_tips_and_geodesic_distances_are_exact():
    grid = VoxelGrid((0.0, 0.0, 0.0), 10.0, (61, 61, 61))
    occ, tips, dists = _star()
    ex = find_extremities(occ, grid, max_extremities=5, min_geodesic_mm=50.0)
    np.testing.assert_array_equal(ex.centre, grid.centre_of([30, 30, 30]))
    # Farthest first: rods of 25, 20, 18, 15, 10 voxels (+2 to the cube face).
    order = np.argsort(-dists)
    np.testing.assert_allclose(ex.points, grid.centre_of(tips[order]))
    np.testing.assert_allclose(ex.geodesic_mm, dists[order] * 10.0)
    assert ex.n_voxels == int(occ.sum())
    # A shorter threshold than the shortest rod keeps every tip; a longer one drops it.
    ex4 = find_extremities(occ, grid, max_extremities=5, min_geodesic_mm=130.0)
    assert len(ex4.points) == 4


def test_piece_cut_off_by_a_hole_stays_attached():
    grid = VoxelGrid((0.0, 0.0, 0.0), 10.0, (61, 61, 61))
    occ, tips, dists = _star(gap_at_rod=2, gap=3)  # the longest rod loses 3 voxels
    ex = find_extremities(occ, grid, max_extremities=5, min_geodesic_mm=50.0, bridge_mm=45.0)
    # The piece beyond the hole is bridged by a 4-voxel edge: same tip, same geodesic length.
    np.testing.assert_allclose(ex.points[0], grid.centre_of(tips[2]))
    assert ex.geodesic_mm[0] == pytest.approx(dists[2] * 10.0)
    ex_far = find_extremities(occ, grid, max_extremities=5, min_geodesic_mm=50.0, bridge_mm=35.0)
    assert not np.any(np.all(ex_far.points == grid.centre_of(tips[2]), axis=1))


def _occupancy(model, x, grid):
    r = rasterise(model, x[None], grid)
    return (r[0] if r.ndim == 4 else r) > 0


@pytest.fixture(scope="module")
def body_grid():
    return BodyModel(), VoxelGrid((-1500.0, -1500.0, -200.0), 20.0, (150, 150, 120))


def test_cone_body_with_free_limbs(body_grid):
    model, grid = body_grid
    names = list(model.state_names)
    x = model.default_state()
    for name, value in [("l_shoulder_abd", 0.8), ("r_shoulder_abd", 0.8), ("l_hip_abd", 0.2),
                        ("r_hip_abd", 0.2), ("root_yaw", 0.7)]:
        x[names.index(name)] = value
    ex = find_extremities(_occupancy(model, x, grid), grid, max_extremities=5)
    ends = model.landmarks(x[None])[0][ENDS]
    dist = np.linalg.norm(ends[:, None] - ex.points[None], axis=2)
    # Each end has its own extremity, within the end cap's radius (the extremity voxel is on the
    # cap's rim, not at the landmark in its centre).
    assert len(ex.points) == 5
    assert np.all(dist.min(axis=1) < 120.0), dist.min(axis=1)
    assert len(set(np.argmin(dist, axis=1))) == 5


def test_cone_bodies_in_random_legal_poses(body_grid):
    model, grid = body_grid
    rng = np.random.default_rng(7)
    found = []
    for _ in range(30):
        u = rng.uniform(model.low, model.high)
        x = model.default_state()
        x[3] = u[3]
        x[6:] = u[6:]  # every joint anywhere in its legal range; the trunk upright
        ex = find_extremities(_occupancy(model, x, grid), grid)
        ends = model.landmarks(x[None])[0][ENDS]
        found.append(np.linalg.norm(ends[:, None] - ex.points[None], axis=2).min(axis=1) < 120.0)
    recall = np.mean(found, axis=0)
    # Ends touching or hidden inside other parts cannot be tips; measured 0.99 at 100 mm
    # (40 poses of another seed).
    assert recall.mean() >= 0.9, recall
    assert recall.min() >= 0.8, recall


def test_height_of_a_standing_body(body_grid):
    model, grid = body_grid
    x = model.default_state()
    ex = find_extremities(_occupancy(model, x, grid), grid)
    lm = model.landmarks(x[None])[0]
    top, bottom = lm[14, 2], min(lm[10, 2], lm[13, 2])
    # Voxel-quantised: within two voxels plus the ankle cap's radius below the ankle.
    assert abs(ex.height_mm - (top - bottom)) < 2 * 20.0 + 60.0


def test_empty_and_bad_input():
    grid = VoxelGrid((0.0, 0.0, 0.0), 10.0, (8, 8, 8))
    assert find_extremities(np.zeros((8, 8, 8), bool), grid) is None
    with pytest.raises(InputError, match="does not match the grid"):
        find_extremities(np.zeros((8, 8, 7), bool), grid)


def test_height_ignores_a_raised_arm(body_grid):
    model, grid = body_grid
    names = list(model.state_names)
    x = model.default_state()
    standing = find_extremities(_occupancy(model, x, grid), grid)
    x[names.index("r_shoulder_flex")] = 3.0  # the right arm straight up
    waving = find_extremities(_occupancy(model, x, grid), grid)
    assert waving.extent_mm > standing.extent_mm + 200.0  # the hand is far above the head
    assert waving.height_mm == standing.height_mm


def test_height_ignores_a_hand_raised_right_above_the_head(body_grid):
    """A hand held straight over the head (the wrist 55 mm beside the head top's vertical,
    250 mm above it) is on the trunk's axis: its thin sections above the head's do not count."""
    model, grid = body_grid
    names = list(model.state_names)
    x = model.default_state()
    standing = find_extremities(_occupancy(model, x, grid), grid)
    x[names.index("r_shoulder_flex")], x[names.index("r_shoulder_abd")] = 3.1, -0.25
    lm = model.landmarks(x[None])[0]
    assert np.hypot(*(lm[7, :2] - lm[14, :2])) < 60 and lm[7, 2] > lm[14, 2] + 240
    occ = _occupancy(model, x, grid)
    over = find_extremities(occ, grid)
    centres = grid.centres()[occ.reshape(-1)]
    on_axis = np.hypot(*(centres[:, :2] - over.centre[:2]).T) <= 150.0
    # the highest voxel on the axis is the hand's, far above the head
    assert centres[on_axis, 2].max() > standing.height_mm + standing.low[2] + 200.0
    assert standing.height_mm <= over.height_mm <= standing.height_mm + 60.0
