"""Depth-shaded orthographic views of a voxel volume, against a per-ray loop."""

from __future__ import annotations

import numpy as np
import pytest

from voxelmocap.grid import VoxelGrid
from voxelmocap.viz.voxel_views import depth_view, views_figure


@pytest.mark.parametrize("axis", [0, 1, 2])
@pytest.mark.parametrize("from_high", [False, True])
def test_depth_view_matches_a_ray_walk(axis, from_high):
    rng = np.random.default_rng(axis + 3 * from_high)
    vol = rng.random((9, 7, 8)) < 0.08
    got = depth_view(vol, axis, from_high)
    moved = np.moveaxis(vol, axis, -1)
    firsts = {}
    for idx in np.ndindex(moved.shape[:2]):
        ray = moved[idx][::-1] if from_high else moved[idx]
        hits = np.flatnonzero(ray)
        if len(hits):
            firsts[idx] = hits[0]
    lo, hi = min(firsts.values()), max(firsts.values())
    for idx in np.ndindex(moved.shape[:2]):
        if idx in firsts:  # nearest seen → 1, farthest seen → 0.2
            assert got[idx] == pytest.approx(1.0 - 0.8 * (firsts[idx] - lo) / max(hi - lo, 1))
        else:
            assert np.isnan(got[idx])
    assert np.all(np.isnan(depth_view(np.zeros((3, 3, 3), bool), axis, from_high)))


def test_views_figure_has_three_views_and_one_panel_per_camera():
    from voxelmocap.camera import Camera

    grid = VoxelGrid((-100.0, -100.0, 0.0), 20.0, (10, 10, 10))
    vol = np.zeros(grid.shape, bool)
    vol[3:6, 4:7, 2:9] = True
    R = np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]])
    cams = [Camera(f"T{i}", fc=(500, 500), cc=(320, 240), R=R,
                   T=-R @ np.array([0, -3000.0 - 100 * i, 100.0])) for i in range(2)]
    fig = views_figure(grid, vol, 7, cameras=cams, masks=np.zeros((2, 480, 640), bool))
    titles = [ax.get_title() for ax in fig.axes]
    assert titles[:3] == ["front (looking +y)", "side (looking −x)", "top (looking −z)"]
    assert titles[3:] == ["T0: silhouette + voxels", "T1: silhouette + voxels"]
    assert fig._suptitle.get_text() == "frame 7"
