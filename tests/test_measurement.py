"""The measurement stage end to end on images synthesised here: a sphere over textured backgrounds."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy import ndimage

from voxelmocap.carving import Carver
from voxelmocap.errors import InputError
from voxelmocap.grid import VoxelGrid
from voxelmocap.io.calibration import read_rig
from voxelmocap.measurement import MeasurementStage
from voxelmocap.silhouette import SilhouetteConfig, build_backgrounds
from voxelmocap.surface import smooth_surface, surface_voxels

RIG_DIR = Path(__file__).resolve().parents[1] / "calib" / "humaneva_i_like"
CENTRE, RADIUS = np.array([100.0, 50.0, 900.0]), 400.0


def _sphere_mask(cam):
    w, h = cam.size
    uu, vv = np.meshgrid(np.arange(w, dtype=float), np.arange(h, dtype=float))
    o, d = cam.rays(np.stack([uu.ravel(), vv.ravel()], axis=1))
    oc = CENTRE - o
    along = np.einsum("ij,ij->i", oc, d)
    perp2 = np.einsum("ij,ij->i", oc, oc) - along**2
    return ((perp2 <= RADIUS**2) & (along > 0)).reshape(h, w)


@pytest.fixture(scope="module")
def scene():
    rng = np.random.default_rng(7)
    rig = read_rig(RIG_DIR)
    grid = VoxelGrid.from_rig(rig, 40.0)
    backgrounds, images, truth = {}, {}, {}
    for cam in rig:
        gray = cam.name.startswith("BW")
        ch = 1 if gray else 3
        tex = ndimage.gaussian_filter(rng.normal(size=(cam.height, cam.width, ch)), (8, 8, 0))
        tex = 60 + 120 * (tex - tex.min()) / (tex.max() - tex.min())

        def noisy(img, gray=gray):
            out = np.clip(np.rint(img + rng.normal(0, 2.5, img.shape)), 0, 255).astype(np.uint8)
            return out[:, :, 0] if gray else out

        backgrounds[cam.name] = [noisy(tex) for _ in range(15)]
        mask = _sphere_mask(cam)
        img = tex.copy()
        img[mask] = 235.0 if gray else (30.0, 220.0, 90.0)
        images[cam.name] = noisy(img)
        truth[cam.name] = mask
    return rig, grid, backgrounds, images, truth


def test_stage_recovers_masks_and_hull(scene):
    rig, grid, bg_frames, images, truth = scene
    cfg = SilhouetteConfig()
    stage = MeasurementStage(rig, grid, build_backgrounds(cfg, rig.names, bg_frames), cfg,
                             sigma=1.0)
    masks, occ = stage.process(images)
    true_masks = np.array([truth[n] for n in rig.names])
    assert masks.shape == true_masks.shape
    for m, t in zip(masks, true_masks, strict=True):
        tp = np.sum(m & t)
        assert tp / m.sum() > 0.98 and tp / t.sum() > 0.98
    ref = Carver(rig, grid).carve(true_masks)
    iou = np.sum(occ & ref) / np.sum(occ | ref)
    assert iou > 0.95, iou
    m = stage.measure(images)
    assert np.array_equal(m.occupancy, occ) and np.array_equal(m.masks, masks)
    assert np.array_equal(m.surface, surface_voxels(occ))
    np.testing.assert_array_equal(m.smoothed, smooth_surface(m.surface, 1.0))
    assert set(m.timings) == {"subtract", "carve", "surface", "smooth"}


def test_stage_bad_input(scene):
    rig, grid, bg_frames, images, _ = scene
    cfg = SilhouetteConfig()
    models = build_backgrounds(cfg, rig.names, bg_frames)
    with pytest.raises(InputError, match="no background model for camera"):
        MeasurementStage(rig, grid, {k: v for k, v in models.items() if k != "C2"}, cfg)
    stage = MeasurementStage(rig, grid, models, cfg)
    with pytest.raises(InputError, match="no image for camera"):
        stage.process({k: v for k, v in images.items() if k != "BW3"})
    small = dict(images, C1=images["C1"][:100])
    with pytest.raises(InputError, match="image of C1 is 640x100"):
        stage.process(small)
