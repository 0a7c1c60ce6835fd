"""The measurement stage end to end on images synthesised here: a sphere over textured backgrounds."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy import ndimage

from voxelmocap.errors import InputError
from voxelmocap.grid import VoxelGrid
from voxelmocap.io.calibration import read_rig
from voxelmocap.measure.carving import Carver
from voxelmocap.measure.silhouette import SilhouetteConfig, build_backgrounds
from voxelmocap.measure.stage import MeasurementStage
from voxelmocap.measure.surface import smooth_surface, surface_voxels

RIG_DIR = Path(__file__).resolve().parents[2] / "calib" / "humaneva_i_like"
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


def _surface_by_neighbours(occ):
    """V^S by definition: occupied with an empty 6-neighbour, outside the grid empty."""
    pad = np.pad(occ, 1)
    c = pad[1:-1, 1:-1, 1:-1]
    full = (pad[:-2, 1:-1, 1:-1] & pad[2:, 1:-1, 1:-1] & pad[1:-1, :-2, 1:-1]
            & pad[1:-1, 2:, 1:-1] & pad[1:-1, 1:-1, :-2] & pad[1:-1, 1:-1, 2:])
    return c & ~full


def _smoothed_whole_grid(surface, sigma):
    """Ṽ^S by definition on the whole grid (no bounding box): Gaussian / centre weight, ≤ 1."""
    radius = int(4.0 * sigma + 0.5)
    g0 = 1.0 / np.exp(-0.5 * (np.arange(-radius, radius + 1) / sigma) ** 2).sum()
    out = ndimage.gaussian_filter(surface.astype(np.float32), sigma, mode="constant") / g0
    out = np.clip(out, 0.0, 1.0).astype(np.float32)
    out[surface] = 1.0
    return out


def test_stage_recovers_masks_and_hull(scene):
    rig, grid, bg_frames, images, truth = scene
    cfg = SilhouetteConfig()
    sigma = 1.5  # not the default, so that a stage ignoring its sigma fails
    stage = MeasurementStage(rig, grid, build_backgrounds(cfg, rig.names, bg_frames), cfg,
                             sigma=sigma)
    obs = stage.measure(images)
    masks, occ = obs.masks, obs.occupancy
    true_masks = np.array([truth[n] for n in rig.names])
    assert masks.shape == true_masks.shape
    for m, t in zip(masks, true_masks, strict=True):
        tp = np.sum(m & t)
        assert tp / m.sum() > 0.98 and tp / t.sum() > 0.98
    ref = Carver(rig, grid).carve(true_masks)
    iou = np.sum(occ & ref) / np.sum(occ | ref)
    assert iou > 0.95, iou
    # the occupancy is what its own masks carve into; surface and smoothing follow the definitions
    assert np.array_equal(occ, Carver(rig, grid).carve(masks))
    assert obs.surface.sum() > 100 and obs.surface.sum() < occ.sum()
    assert np.array_equal(obs.surface, _surface_by_neighbours(occ))
    np.testing.assert_allclose(obs.smoothed, _smoothed_whole_grid(obs.surface, sigma), atol=1e-6)
    # 1 on the surface, ~exp(-d²/2σ²) one voxel off it, decaying to 0 far away
    assert np.all(obs.smoothed[obs.surface] == 1.0) and obs.smoothed.min() == 0.0
    assert set(obs.timings) == {"subtract", "carve", "surface", "smooth"}
    assert not obs.empty and obs.excluded == {}


def test_observation_equals_the_old_two_paths(scene):
    """The stage's one observation holds exactly what dump (surface, smoothed) and track (the
    likelihood's quantised values and prefix sums) used to compute separately."""
    rig, grid, bg_frames, images, _ = scene
    cfg = SilhouetteConfig()
    stage = MeasurementStage(rig, grid, build_backgrounds(cfg, rig.names, bg_frames), cfg,
                             sigma=1.3)
    obs = stage.measure(images)
    occ = Carver(rig, grid).carve(stage.masks(images))
    surf = surface_voxels(occ)
    smooth = smooth_surface(surf, 1.3)
    q = np.rint(smooth.astype(np.float64) * 65535).astype(np.int32)
    nx, ny, nz = grid.shape
    prefix = np.zeros((nx, ny, nz + 1, 3), dtype=np.int32)
    np.cumsum(np.ones(grid.shape, bool), axis=2, out=prefix[:, :, 1:, 0])
    np.cumsum(occ, axis=2, out=prefix[:, :, 1:, 1])
    np.cumsum(q, axis=2, out=prefix[:, :, 1:, 2])
    assert np.array_equal(obs.occupancy, occ) and np.array_equal(obs.surface, surf)
    assert obs.smoothed.dtype == np.float32 and np.array_equal(obs.smoothed, smooth)
    assert np.array_equal(obs.smoothed_q, q) and np.array_equal(_whole_prefix(obs), prefix)
    assert obs.prefix.dtype == np.int32 and obs.prefix[..., -1, 2].max() > 0
    # the table holds the person's columns only (the rest of the grid is empty and in the scene)
    assert obs.prefix.shape[0] * obs.prefix.shape[1] < 0.2 * nx * ny


def _whole_prefix(obs):
    """The observation's prefix table over the whole grid: its stored columns, and elsewhere
    what the kernels assume (nothing occupied, Ṽq = 0, every voxel in the scene)."""
    nx, ny, nz, i0, j0 = (int(v) for v in obs.prefix_lattice)
    whole = np.zeros((nx, ny, nz + 1, 3), dtype=np.int32)
    whole[:, :, :, 0] = np.arange(nz + 1)
    ni, nj = obs.prefix.shape[:2]
    whole[i0:i0 + ni, j0:j0 + nj] = obs.prefix
    return whole


def test_stage_bad_input(scene):
    rig, grid, bg_frames, images, _ = scene
    cfg = SilhouetteConfig()
    models = build_backgrounds(cfg, rig.names, bg_frames)
    with pytest.raises(InputError, match="no background model for camera"):
        MeasurementStage(rig, grid, {k: v for k, v in models.items() if k != "C2"}, cfg)
    with pytest.raises(InputError, match="min_views"):
        MeasurementStage(rig, grid, models, cfg, min_views=len(rig) + 1)
    stage = MeasurementStage(rig, grid, models, cfg)
    with pytest.raises(InputError, match="no image for camera"):
        stage.measure({k: v for k, v in images.items() if k != "BW3"})
    small = dict(images, C1=images["C1"][:100])
    with pytest.raises(InputError, match="image of C1 is 640x100"):
        stage.measure(small)


@pytest.mark.parametrize("min_views", [None, 3])
@pytest.mark.parametrize("broken", ["black", "white"])
def test_camera_without_picture_is_left_out(scene, min_views, broken):
    """A black frame (all foreground against this background) or a blown-out one: that camera is
    named and the occupancy is exactly the carving of the other cameras alone."""
    rig, grid, bg_frames, images, _ = scene
    cfg = SilhouetteConfig()
    stage = MeasurementStage(rig, grid, build_backgrounds(cfg, rig.names, bg_frames), cfg,
                             min_views=min_views)
    bad = dict(images, C2=np.full_like(images["C2"], 0 if broken == "black" else 255))
    obs = stage.measure(bad)
    assert list(obs.excluded) == ["C2"]
    assert ("black" in obs.excluded["C2"]) == (broken == "black")
    others = [i for i, n in enumerate(rig.names) if n != "C2"]
    ref = Carver([rig[i] for i in others], grid).carve(obs.masks[others], min_views=min_views)
    assert ref.any() and np.array_equal(obs.occupancy, ref)
    if min_views is not None:  # there the broken camera's full mask would have voted everywhere
        assert not np.array_equal(obs.occupancy, Carver(rig, grid).carve(obs.masks,
                                                                        min_views=min_views))


def test_no_person_in_view_is_an_empty_observation_without_warning(scene):
    rig, grid, bg_frames, _, _ = scene
    cfg = SilhouetteConfig()
    stage = MeasurementStage(rig, grid, build_backgrounds(cfg, rig.names, bg_frames), cfg)
    obs = stage.measure({n: frames[0] for n, frames in bg_frames.items()})  # warnings are errors
    assert obs.empty and not obs.occupancy.any() and not obs.surface.any()
    assert obs.excluded == {}


def test_prefix_kernel_equals_numpy_on_a_masked_scene():
    """The parallel prefix-sum kernel against NumPy's quantise + cumsum, with a scene mask that
    is not all ones and smoothed values on rounding ties (rint rounds them to even)."""
    from voxelmocap.grid import VoxelGrid
    from voxelmocap.measure.observation import QMAX, VoxelObservation

    rng = np.random.default_rng(7)
    grid = VoxelGrid((0.0, 0.0, 0.0), 20.0, (9, 7, 23))
    occ = rng.random(grid.shape) < 0.3
    scene = rng.random(grid.shape) < 0.8
    obs = VoxelObservation(occ, grid, sigma=1.0, scene=scene)
    ties = (np.arange(6, dtype=np.float64) + 0.5) / QMAX  # k + ½ quanta
    obs.smoothed[0, 0, :6] = ties.astype(np.float32)
    q = np.rint(obs.smoothed.astype(np.float64) * QMAX).astype(np.int32)
    expect = np.zeros(grid.shape[:2] + (grid.shape[2] + 1, 3), np.int32)
    for t, table in enumerate((scene, occ & scene, q)):
        expect[:, :, 1:, t] = np.cumsum(table, axis=2)
    assert np.array_equal(_whole_prefix(obs), expect)
    assert np.array_equal(obs.smoothed_q, q)


def test_masks_of_learnt_plates_are_the_same_with_one_and_two_threads(scene, opencv_threads):
    """The cameras are segmented side by side (:mod:`voxelmocap.measure.threads`): with plates
    that never saw a band around the sphere's outline (GrabCut decides it, its k-means start drawn from
    OpenCV's per-thread generator) the masks equal a camera-by-camera loop, with one OpenCV
    thread and with two."""
    from voxelmocap.measure.plate import PlateBackground, plate_from_frames
    from voxelmocap.measure.silhouette import segment

    rig, grid, bg_frames, images, truth = scene
    cfg = SilhouetteConfig(plate_unknown="grabcut")
    plates = {}
    for cam in rig:
        learnt = plate_from_frames(np.asarray(bg_frames[cam.name]), cfg)
        edge = (ndimage.binary_dilation(truth[cam.name], iterations=10)
                & ~ndimage.binary_erosion(truth[cam.name], iterations=10))
        # never seen around the outline
        plates[cam.name] = PlateBackground(learnt.plate, learnt.sigma, ~edge)
    loop = [segment(images[n], plates[n], cfg, camera=n) for n in rig.names]
    stage = MeasurementStage(rig, grid, plates, cfg)
    got = {}
    for n in (1, 2):
        opencv_threads(n)
        got[n] = stage.masks(images)
    for n in (1, 2):
        assert np.array_equal(got[n], np.stack(loop))
    # GrabCut did decide the never-seen pixels: the masks are the sphere, not the whole band
    for m, name in zip(got[2], rig.names, strict=True):
        t = truth[name]
        assert (m & t).sum() / (m | t).sum() > 0.9


def test_gaussian_models_segment_in_the_calling_thread(scene, monkeypatch):
    """The Gaussian model's numba kernel is parallel already, and numba's workqueue layer
    aborts on launches from two threads: such a stage never hands a camera to the pool."""
    import voxelmocap.measure.stage as stage_module

    def refuse(*args, **kwargs):
        raise AssertionError("handed to the thread pool")

    rig, grid, bg_frames, images, _ = scene
    cfg = SilhouetteConfig()
    stage = MeasurementStage(rig, grid, build_backgrounds(cfg, rig.names, bg_frames), cfg)
    expected = stage.masks(images)
    monkeypatch.setattr(stage_module, "each", refuse)
    np.testing.assert_array_equal(stage.masks(images), expected)
