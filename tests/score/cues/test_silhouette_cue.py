"""The silhouette cue: the cover kernel against a brute-force point-in-hull reference (scipy),
the parts' outlines against densely sampled cone surfaces, the cue against a hand computation,
and the hierarchical search scoring image cues on whole states."""

import dataclasses

import numpy as np
import pytest
from scipy.spatial import ConvexHull, Delaunay
from test_cues import _camera

from voxelmocap.body import BodyModel
from voxelmocap.config import CuesConfig, TrackConfig, config_from_toml, with_overrides
from voxelmocap.errors import InputError
from voxelmocap.grid import VoxelGrid
from voxelmocap.measure import _silhouette_kernels as sk
from voxelmocap.measure.observation import VoxelObservation
from voxelmocap.score.cues import CueSet
from voxelmocap.score.cues.contours import project_outlines
from voxelmocap.score.likelihood import rasterise


def _drawn(points, valid, h, w):
    """Brute force: pixel centres inside the convex hull of any valid part's points."""
    yy, xx = np.mgrid[0:h, 0:w]
    centres = np.stack([xx.ravel(), yy.ravel()], axis=1).astype(float)
    drawn = np.zeros(h * w, bool)
    for q in range(points.shape[0]):
        if valid[q]:
            drawn |= Delaunay(points[q]).find_simplex(centres) >= 0
    return drawn.reshape(h, w)


@pytest.mark.parametrize("seed", range(8))
def test_cover_counts_equal_brute_force(seed):
    rng = np.random.default_rng(seed)
    n_p, n_parts, k, h, w = 6, 5, 16, 50, 70
    mask = rng.random((h, w)) < 0.4
    points = np.empty((n_p, n_parts, k, 2))
    for p in range(n_p):
        for q in range(n_parts):
            # parts partly outside the picture too
            points[p, q] = rng.uniform([-15, -15], [w + 15, h + 15]) + rng.normal(0, 10, (k, 2))
    valid = rng.random((n_p, n_parts)) < 0.8
    hit = np.empty(n_p, np.int64)
    extra = np.empty(n_p, np.int64)
    sk.cover_counts(points, valid, mask, hit, extra)
    for p in range(n_p):
        drawn = _drawn(points[p], valid[p], h, w)
        assert hit[p] == (drawn & mask).sum()
        assert extra[p] == (drawn & ~mask).sum()


@pytest.mark.parametrize("far", [1e20, np.inf, -np.inf, np.nan])
def test_a_part_projected_out_of_bounds_is_not_drawn(far):
    """A part with an outline point beyond 1e6 px or not finite (a cone grazing the lens,
    distorted) is left out, as ``body_mask`` leaves it out: the counts are those of the others
    (converting such a coordinate to a pixel index would overflow)."""
    rng = np.random.default_rng(9)
    mask = rng.random((20, 20)) < 0.5
    points = np.empty((1, 2, 3, 2))
    points[0, 0] = [[10, 3], [12, 3], [11, far]]              # the sliver towards the far point
    points[0, 1] = [[2, 2], [6, 2], [4, 15]]
    hit, extra = np.empty(1, np.int64), np.empty(1, np.int64)
    sk.cover_counts(points, np.ones((1, 2), bool), mask, hit, extra)
    drawn = _drawn(points[0, 1:], np.ones(1, bool), 20, 20)
    assert hit[0] == (drawn & mask).sum() and extra[0] == (drawn & ~mask).sum()


def test_cover_counts_of_nothing_drawn_are_zero():
    mask = np.ones((10, 10), bool)
    points = np.full((2, 1, 4, 2), 100.0)           # all outside the picture
    points[1, 0] = [[2, 2], [2, 2], [2, 2], [2, 2]]  # one point: no area
    hit = np.full(2, -1, np.int64)
    extra = np.full(2, -1, np.int64)
    sk.cover_counts(points, np.ones((2, 1), bool), mask, hit, extra)
    assert hit.tolist() == [0, 0] and extra.tolist() == [0, 0]


def test_outline_hull_is_the_cone_image():
    """The hull of the outline points has the area of the image of the densely sampled cone
    surface (within 3 %) and differs from it on a thin rim only."""
    rng = np.random.default_rng(4)
    model = BodyModel()
    x = model.default_state()
    x[11:14] = (0.4, -0.3, 0.2)
    geo = model.geometry(x[None])
    cam = _camera(eye=(2500.0, -3000.0, 1800.0))
    outline, valid = project_outlines(geo, cam)
    assert valid.all()
    theta = rng.uniform(0, 2 * np.pi, 4000)
    t = rng.uniform(0, 1, 4000)
    for q in range(geo.base.shape[1]):
        h, w, length, ratio = geo.shape[q, 4], geo.shape[q, 5], geo.shape[q, 2], geo.shape[q, 6]
        s = 1 + (ratio - 1) * t
        surf = (geo.base[0, q] + (t * length)[:, None] * geo.axis[0, q]
                + (s * h * np.cos(theta))[:, None] * geo.u1[0, q]
                + (s * w * np.sin(theta))[:, None] * geo.u2[0, q])
        dense = cam.project(surf)
        area_dense = ConvexHull(dense).volume
        area_outline = ConvexHull(outline[0, q]).volume
        assert area_outline == pytest.approx(area_dense, rel=0.03)
        # the two regions on a fine lattice: they differ on a thin rim only
        lo, hi = dense.min(axis=0) - 2, dense.max(axis=0) + 2
        gx, gy = np.meshgrid(np.arange(lo[0], hi[0], 0.25), np.arange(lo[1], hi[1], 0.25))
        lattice = np.stack([gx.ravel(), gy.ravel()], axis=1)
        a = Delaunay(dense).find_simplex(lattice) >= 0
        b = Delaunay(outline[0, q]).find_simplex(lattice) >= 0
        assert (a ^ b).sum() / a.sum() < 0.06


def _observation(model, state, cameras, size):
    """Silhouettes drawn by the brute-force reference from ``state`` at the cue's resolution."""
    geo = model.geometry(state[None])
    masks = []
    for cam in cameras:
        w, h = cam.size
        outline, valid = project_outlines(geo, cam)
        masks.append(_drawn(outline[0], valid[0], h, w))
    grid = VoxelGrid((-1000.0, -1000.0, 0.0), 40.0, (50, 50, 50))
    occ = rasterise(model, state[None], grid) > 0
    images = [np.zeros((c.size[1], c.size[0]), np.uint8) for c in cameras]
    return VoxelObservation(occ, grid, masks=masks, images=images, cameras=list(cameras))


def test_silhouette_cue_is_zero_at_the_pose_and_equals_the_hand_count():
    model = BodyModel()
    x = model.default_state()
    cams = [_camera(size=(320, 240)), _camera("D", eye=(3000.0, -3000.0, 1500.0), size=(320, 240))]
    obs = _observation(model, x, cams, 320)
    cues = CueSet(model, CuesConfig(weights={"silhouette": 1.0}, silhouette_scale=0.05))
    moved = np.repeat(x[None], 2, axis=0)
    moved[1, 11] += 0.8                                    # an arm raised
    ll = cues.log_likelihood(obs, moved)
    assert ll[0] == pytest.approx(0.0, abs=1e-12)
    expected = 0.0
    for cam, mask in zip(cams, obs.masks, strict=True):
        outline, valid = project_outlines(model.geometry(moved[1:]), cam)
        drawn = _drawn(outline[0], valid[0], mask.shape[0], mask.shape[1])
        d = ((mask & ~drawn).sum() + (drawn & ~mask).sum()) / mask.sum()
        expected -= d / 0.05
    assert expected < -1.0
    assert ll[1] == pytest.approx(expected)


def test_never_seen_silhouette_pixels_cost_nothing_uncovered():
    """With a learnt plate's never-seen pixels (``observation.known``), a silhouette pixel there
    costs nothing when the body leaves it uncovered (``silhouette_unseen = "ignore"``); body
    pixels outside the silhouette still cost; ``count`` (the default) is the plain D."""
    model = BodyModel()
    x = model.default_state()
    cams = [_camera(size=(320, 240)), _camera("D", eye=(3000.0, -3000.0, 1500.0), size=(320, 240))]
    plain = _observation(model, x, cams, 320)
    rng = np.random.default_rng(3)
    ghosts, known = [], []
    for mask in plain.masks:
        ghost = mask.copy()
        ghost[100:160, 20:70] = True                       # a ghost beside the body
        k = rng.random(mask.shape) > 0.3                   # never-seen pixels scattered …
        k[100:160, 20:70] = False                          # … and the whole ghost
        ghosts.append(ghost)
        known.append(k)
    obs = VoxelObservation(plain.occupancy, plain.grid, masks=ghosts, images=plain.images,
                           cameras=cams, known=known)
    moved = np.repeat(x[None], 2, axis=0)
    moved[1, 11] += 0.8                                    # an arm raised
    ignore = CueSet(model, CuesConfig(weights={"silhouette": 1.0}, silhouette_scale=0.05,
                                      silhouette_unseen="ignore"))
    count = CueSet(model, CuesConfig(weights={"silhouette": 1.0}, silhouette_scale=0.05))
    expected_ignore, expected_count = np.zeros(2), np.zeros(2)
    for cam, mask, k in zip(cams, ghosts, known, strict=True):
        outline, valid = project_outlines(model.geometry(moved), cam)
        for p in range(2):
            drawn = _drawn(outline[p], valid[p], mask.shape[0], mask.shape[1])
            extra = (drawn & ~mask).sum()
            expected_ignore[p] -= ((mask & k & ~drawn).sum() + extra) / mask.sum() / 0.05
            expected_count[p] -= ((mask & ~drawn).sum() + extra) / mask.sum() / 0.05
    np.testing.assert_allclose(ignore.log_likelihood(obs, moved), expected_ignore)
    np.testing.assert_allclose(count.log_likelihood(obs, moved), expected_count)
    # the ghost no longer costs the true pose anything; counted, it does
    assert expected_ignore[0] > expected_count[0] + 1.0
    # without never-seen pixels the two settings agree
    np.testing.assert_allclose(ignore.log_likelihood(plain, moved),
                               count.log_likelihood(plain, moved))

def test_silhouette_cue_reduces_large_images():
    """A 640 × 480 silhouette compared at 160 pixels: the reduced mask is the area average."""
    model = BodyModel()
    x = model.default_state()
    cams = [_camera(), _camera("D", eye=(3000.0, -3000.0, 1500.0))]
    obs = _observation(model, x, cams, 640)
    cfg = CuesConfig(weights={"silhouette": 1.0}, silhouette_size=160)
    cues = CueSet(model, cfg)
    frame = cues.prepare(obs)
    small, scale = frame.silhouette(0, 160)
    assert small.shape == (120, 160) and scale == pytest.approx([0.25, 0.25])
    blocks = obs.masks[0].reshape(120, 4, 160, 4).mean(axis=(1, 3))
    assert np.array_equal(small, blocks >= 0.5)
    # at a quarter of the size the limbs are a few pixels wide: the reduction's rounding
    # leaves D (= −ll · scale) at a few per cent per camera
    d = -cues.log_likelihood(obs, x[None])[0] * cfg.silhouette_scale
    assert 0.0 <= d < 0.3


def test_hierarchical_search_adds_image_cues_on_whole_states():
    """With the voxel cue at weight 1 and an image cue, the search is hierarchical and each
    partition's callable equals the fused likelihood of the whole states."""
    from voxelmocap.pose.filter_setup import searches_hierarchically
    from voxelmocap.pose.hierarchy import body_partitions
    from voxelmocap.pose.tracker import BodyTracker

    model = BodyModel()
    x = model.default_state()
    cams = [_camera(size=(320, 240)), _camera("D", eye=(3000.0, -3000.0, 1500.0), size=(320, 240))]
    obs = _observation(model, x, cams, 320)
    config = with_overrides(TrackConfig(), **{"filter.layers": 2, "filter.particles": 30})
    config = dataclasses.replace(config, cues=CuesConfig(weights={"voxel": 1.0,
                                                                  "silhouette": 0.5}))
    assert searches_hierarchically(config)
    joint = dataclasses.replace(config, cues=CuesConfig(weights={"silhouette": 1.0}))
    assert not searches_hierarchically(joint)
    tracker = BodyTracker(model, config, seed=0)
    factory = tracker.partition_log_likelihood(obs)
    rng = np.random.default_rng(5)
    for k, part in enumerate(body_partitions(config.filter)):
        states = np.repeat(x[None], 4, axis=0)
        dims = list(part.dims)
        states[:, dims] += rng.normal(0.0, 0.1, (4, len(dims)))
        states = model.clip(states)
        got = factory(k, x)(states)
        assert np.allclose(got, tracker.cues.log_likelihood(obs, states))


def test_the_limb_searches_score_the_other_cues_on_whole_states(monkeypatch):
    """The start's and the periodic limb search get the fused likelihood of the cues other than
    the voxel one (a visual hull offers phantom volume the silhouettes rule out); with the voxel
    cue alone they get none."""
    import voxelmocap.pose.limb_search as limb_search
    from voxelmocap.pose.tracker import BodyTracker

    model = BodyModel()
    x = model.default_state()
    cams = [_camera(size=(320, 240)), _camera("D", eye=(3000.0, -3000.0, 1500.0), size=(320, 240))]
    obs = _observation(model, x, cams, 320)
    seen = []
    real = limb_search.sweep_limbs

    def spy(observation, model, state, **kw):
        seen.append(kw["scoring"].others)
        return real(observation, model, state, **{**kw, "samples": 8, "refine_evaluations": 4})

    monkeypatch.setattr(limb_search, "sweep_limbs", spy)
    rng = np.random.default_rng(2)
    states = model.clip(x[None] + rng.normal(0.0, 0.2, (5, 27)) * (np.arange(27) >= 6))
    for weights, fused in (({"voxel": 1.0, "silhouette": 0.5}, True), ({"voxel": 1.0}, False)):
        config = with_overrides(TrackConfig(), **{"filter.layers": 2, "filter.particles": 30,
                                                  "filter.limb_sweep_every": 1,
                                                  "filter.limb_sweep_max_hull": 1e6})
        config = dataclasses.replace(config, cues=CuesConfig(weights=weights))
        tracker = BodyTracker(model, config, seed=0)
        seen.clear()
        tracker.sweep_limbs(obs, x[None])                    # the start's search
        tracker.start("test", x)
        tracker.step(obs)                                    # the periodic one
        assert len(seen) == 2
        for others in seen:
            if fused:                                        # the silhouette term, weighted
                np.testing.assert_allclose(
                    others(states), tracker.cues.log_likelihood(obs, states)
                    - tracker.cues.log_likelihood(obs, states, without=("silhouette",)))
                assert np.ptp(others(states)) > 0
            else:
                assert others is None


def test_the_start_search_scores_the_silhouettes_before_other_cues_have_a_reference():
    """With a cue that learns its reference appearance from a pose (roi) beside the silhouette
    cue, the start's limb search (no pose yet) still gets the silhouette term; the roi term,
    not learnt, adds 0."""
    from voxelmocap.pose.tracker import BodyTracker

    model = BodyModel()
    x = model.default_state()
    cams = [_camera(size=(320, 240)), _camera("D", eye=(3000.0, -3000.0, 1500.0), size=(320, 240))]
    obs = _observation(model, x, cams, 320)
    config = dataclasses.replace(TrackConfig(), cues=CuesConfig(
        weights={"voxel": 1.0, "silhouette": 0.5, "roi": 1.0}))
    tracker = BodyTracker(model, config, seed=0)
    others = tracker._other_cues(obs)
    assert tracker.cues.needs_reference                  # nothing to learn roi from yet
    rng = np.random.default_rng(4)
    states = model.clip(x[None] + rng.normal(0.0, 0.2, (5, 27)) * (np.arange(27) >= 6))
    silhouette = 0.5 * tracker.cues.evaluate(obs, states, ["silhouette"])["silhouette"]
    np.testing.assert_allclose(others(states), silhouette)
    assert np.ptp(silhouette) > 0


def test_silhouette_settings_are_checked():
    with pytest.raises(InputError, match="silhouette_size"):
        config_from_toml("[cues]\nsilhouette_size = 0\n", "f.toml")
    with pytest.raises(InputError, match="silhouette_scale"):
        config_from_toml("[cues]\nsilhouette_scale = -1\n", "f.toml")


def test_silhouette_cue_without_masks_is_refused():
    model = BodyModel()
    x = model.default_state()
    cam = _camera()
    grid = VoxelGrid((-1000.0, -1000.0, 0.0), 40.0, (50, 50, 50))
    obs = VoxelObservation(rasterise(model, x[None], grid) > 0, grid,
                           images=[np.zeros((480, 640), np.uint8)], cameras=[cam])
    cues = CueSet(model, CuesConfig(weights={"silhouette": 1.0}))
    with pytest.raises(InputError, match="silhouettes"):
        cues.log_likelihood(obs, x[None])


def test_outline_kernel_equals_numpy_reference():
    """The numba outline kernel (the cue's hot path) against :func:`project_outlines`, with lens
    distortion and skew, and parts behind the camera marked invalid."""
    from voxelmocap.score.cues.contours import outline_pixels

    rng = np.random.default_rng(6)
    model = BodyModel()
    states = np.repeat(model.default_state()[None], 20, axis=0)
    states[:, 7:] += rng.normal(0.0, 0.3, (20, states.shape[1] - 7))
    states[:, :3] += rng.normal(0.0, 300.0, (20, 3))
    states = model.clip(states)
    states[0, :3] = (0.0, -2000.0, 1000.0)       # at the camera: parts behind it
    geo = model.geometry(states)
    cam = _camera(eye=(0.0, -2000.0, 1000.0), size=(1920, 1080))
    cam = dataclasses.replace(cam, kc=np.array([-0.2, 0.05, 0.001, -0.002, 0.01]), alpha_c=0.001)
    ref, ref_valid = project_outlines(geo, cam)
    scale = np.array([1 / 6, 0.17])
    got, valid = outline_pixels(geo, cam, scale)
    assert np.array_equal(valid, ref_valid) and not valid[0].all() and valid[1:].all()
    expected = (ref + 0.5) * scale - 0.5
    assert np.allclose(got[valid], expected[valid], rtol=1e-10, atol=1e-9)
