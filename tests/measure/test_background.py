"""Background plates learnt from the sequence (voxelmocap.measure.background) and the real-video rules
that go with them: noise-based thresholds, shadows, hole-tolerant carving, ghost rejection."""

from collections.abc import Mapping

import numpy as np
import pytest
from scipy import stats

from voxelmocap.config import SilhouetteConfig
from voxelmocap.errors import InputError
from voxelmocap.measure.background import learn_plates, person_component
from voxelmocap.measure.plate import PlateBackground, masked_median, plate_from_frames


def _textured(rng, h=120, w=160):
    """A smooth random colour texture (0–255) with no flat areas."""
    import cv2

    base = rng.uniform(40, 215, size=(h // 8, w // 8, 3)).astype(np.float32)
    return cv2.resize(base, (w, h), interpolation=cv2.INTER_CUBIC).clip(20, 235)


# ---------------------------------------------------------------------- noise and threshold
def test_noise_level_and_false_alarm_rate_match_the_closed_form():
    rng = np.random.default_rng(0)
    plate = _textured(rng)
    sigma = 3.0
    frames = np.clip(np.round(plate + rng.normal(0, sigma, (60, *plate.shape))), 0, 255)
    cfg = SilhouetteConfig(false_alarm=0.01)
    bg = plate_from_frames(frames.astype(np.uint8), cfg)
    # IQR / 1.349 is σ for Gaussian noise (rounding to integers adds 1/12 to the variance)
    assert bg.camera_sigma == pytest.approx(np.sqrt(sigma ** 2 + 1 / 12), rel=0.1)
    assert bg.threshold == pytest.approx(stats.chi2.isf(0.01, 3))
    # on fresh noise frames the share of foreground pixels is the χ² tail probability
    test = np.clip(np.round(plate + rng.normal(0, sigma, (20, *plate.shape))), 0, 255)
    rate = np.mean([bg.foreground(t.astype(np.uint8)).mean() for t in test])
    assert 0.4 * 0.01 < rate < 2.0 * 0.01
    # the threshold follows each camera's own noise: a noisier camera keeps the same rate
    frames6 = np.clip(np.round(plate + rng.normal(0, 2 * sigma, (60, *plate.shape))), 0, 255)
    bg6 = plate_from_frames(frames6.astype(np.uint8), cfg)
    assert bg6.camera_sigma == pytest.approx(2 * sigma, rel=0.1)
    test6 = np.clip(np.round(plate + rng.normal(0, 2 * sigma, (20, *plate.shape))), 0, 255)
    rate6 = np.mean([bg6.foreground(t.astype(np.uint8)).mean() for t in test6])
    assert 0.4 * 0.01 < rate6 < 2.0 * 0.01


def test_masked_median_equals_numpy_per_pixel():
    rng = np.random.default_rng(1)
    frames = rng.integers(0, 256, size=(9, 7, 5, 3), dtype=np.uint8)
    keep = rng.random((9, 7, 5)) < 0.6
    med, count = masked_median(frames, keep)
    for i in range(7):
        for j in range(5):
            k = keep[:, i, j]
            assert count[i, j] == k.sum()
            if k.any():
                np.testing.assert_allclose(med[i, j], np.median(frames[k, i, j], axis=0))


def test_exposure_gain_is_compensated():
    rng = np.random.default_rng(2)
    plate = _textured(rng)
    bg = PlateBackground(plate, 2.0, false_alarm=1e-4, shadows=False)
    brighter = np.clip(plate * 1.08, 0, 255).astype(np.uint8)   # auto-exposure step
    assert bg.foreground(brighter).mean() < 0.01


# ---------------------------------------------------------------------- shadows
def test_cast_shadow_is_background_and_a_coloured_region_is_not():
    rng = np.random.default_rng(3)
    plate = _textured(rng)
    bg = PlateBackground(plate, 2.0, false_alarm=1e-4, shadows=True)
    img = plate.copy()
    img[20:60, 20:80] *= 0.65                                      # darkened: a shadow
    img[70:110, 90:150] = (30, 200, 60)                            # a green shirt
    fg = bg.foreground(np.clip(img, 0, 255).astype(np.uint8))
    assert fg[22:58, 22:78].mean() < 0.02
    assert fg[72:108, 92:148].mean() > 0.98
    no_shadow = PlateBackground(plate, 2.0, false_alarm=1e-4, shadows=False)
    assert no_shadow.foreground(np.clip(img, 0, 255).astype(np.uint8))[22:58, 22:78].mean() > 0.9


def test_unknown_pixels_are_foreground():
    plate = np.full((10, 12, 3), 100.0)
    known = np.ones((10, 12), bool)
    known[2:4, 3:5] = False
    fg = PlateBackground(plate, 2.0, known).foreground(plate.astype(np.uint8))
    assert fg.sum() == 4 and not fg[known].any()


# ---------------------------------------------------------------------- the learnt plate
@pytest.fixture(scope="module")
def still_walk():
    from still_fixture import render_still_then_walk

    return render_still_then_walk(24, shadow=False)


def test_learnt_plate_recovers_the_true_background_of_a_person_standing_half_the_time(
        still_walk):
    from voxelmocap.grid import VoxelGrid

    rig, frames, truth, masks, _ = still_walk
    coarse = VoxelGrid.from_rig(rig, 50.0, min_views=3, height=2500, probe_height=1000)
    cfg = SilhouetteConfig()
    plates = learn_plates(frames, rig, coarse, cfg)
    for cam in rig:
        n = cam.name
        assert not plates[n].unknown_margin                      # where the person stood
        median = plate_from_frames(frames[n], cfg)
        known = plates[n].known
        bad_median = (np.abs(median.plate - truth[n]).max(axis=2) > 15).sum()
        bad = (np.abs(plates[n].plate - truth[n]).max(axis=2) > 15)[known].sum()
        # the median holds the standing person; the learnt plate does not
        assert bad_median > 1000
        assert bad < 0.002 * known.size and bad < bad_median / 5
        # pixels never seen empty are where the person was
        ever = masks[n].any(axis=0)
        import cv2
        ever = cv2.dilate(ever.astype(np.uint8), np.ones((15, 15), np.uint8)).astype(bool)
        assert (~known & ~ever).mean() < 0.01


class _OnAccess(Mapping):
    """Frames per camera handed out as fresh copies, counting who holds what: the lazy
    mapping a run passes (``io.synchronised.FramesByCamera``), with a ledger."""

    def __init__(self, frames):
        self._frames, self.taken, self.alive, self.most_alive = frames, [], set(), 0

    def __getitem__(self, name):
        copy = _Tracked(self._frames[name])
        copy.owner, copy.ledger = name, self
        self.taken.append(name)
        self.alive.add(id(copy))
        self.most_alive = max(self.most_alive, len(self.alive))
        return copy

    def __contains__(self, name):
        return name in self._frames

    def __iter__(self):
        return iter(self._frames)

    def __len__(self):
        return len(self._frames)


class _Tracked(np.ndarray):
    """An array that leaves its ledger's ``alive`` set when garbage-collected."""

    def __new__(cls, array):
        return np.array(array).view(cls)

    def __array_finalize__(self, obj):
        self.ledger = None

    def __del__(self):
        if self.ledger is not None:
            self.ledger.alive.discard(id(self))


def test_learnt_plates_take_one_camera_s_frames_at_a_time(still_walk):
    from voxelmocap.grid import VoxelGrid

    rig, frames, _, _, _ = still_walk
    coarse = VoxelGrid.from_rig(rig, 50.0, min_views=3, height=2500, probe_height=1000)
    cfg = SilhouetteConfig()
    lazy = _OnAccess(frames)
    from_lazy = learn_plates(lazy, rig, coarse, cfg)
    names = [c.name for c in rig]
    assert lazy.taken == names + names           # downscaled copies, then the final medians
    assert lazy.most_alive == 1                  # never two cameras' frames at once
    for n, plate in learn_plates(frames, rig, coarse, cfg).items():
        np.testing.assert_array_equal(from_lazy[n].plate, plate.plate)
        np.testing.assert_array_equal(from_lazy[n].sigma, plate.sigma)
        np.testing.assert_array_equal(from_lazy[n].known, plate.known)


def test_plates_from_the_true_covers_are_the_true_background_where_it_was_seen(still_walk):
    import cv2

    from voxelmocap.measure.background import plates_from_covers

    rig, frames, truth, masks, _ = still_walk
    cfg = SilhouetteConfig()
    # the covers at a quarter of the resolution, grown by two of their pixels (as a body's
    # image is drawn): resized back by the plate
    covers = {}
    for cam in rig:
        h, w = masks[cam.name].shape[1:]
        covers[cam.name] = np.stack([cv2.dilate(cv2.resize(m.astype(np.uint8), (w // 4, h // 4),
                                                           interpolation=cv2.INTER_AREA),
                                                np.ones((5, 5), np.uint8)).astype(bool)
                                     for m in masks[cam.name]])
    plates = plates_from_covers(frames, rig, covers, cfg)
    for cam in rig:
        n = cam.name
        known = plates[n].known
        bad = (np.abs(plates[n].plate - truth[n]).max(axis=2) > 15) & known
        assert bad.sum() < 0.001 * known.size
        # never seen: exactly the pixels every (resized) cover holds
        h, w = known.shape
        every = np.all([cv2.resize(c.astype(np.uint8), (w, h), interpolation=cv2.INTER_NEAREST)
                        for c in covers[n]], axis=0).astype(bool)
        assert np.array_equal(~known, every)
    with pytest.raises(InputError, match="covers for"):
        plates_from_covers(frames, rig, {c: v[:-1] for c, v in covers.items()}, cfg)


def test_a_person_who_barely_moves_is_left_out_of_the_plate():
    """A person who stands and gestures is in the temporal median; only the moving arm carves
    (far below :data:`MIN_PERSON_MM3`), so the column around it is covered: the plate keeps no
    part of the body as background, and leaves the body's pixels unknown (the renderer's empty
    scene and the person's true masks are the reference)."""
    from still_fixture import render_still_then_walk

    from voxelmocap.grid import VoxelGrid

    rig, frames, truth, masks, points = render_still_then_walk(24, motion="gestures",
                                                               still_share=0.0, shadow=False)
    assert np.ptp(points[:, 0], axis=0).max() < 20          # the pelvis stays within 2 cm
    coarse = VoxelGrid.from_rig(rig, 50.0, min_views=3, height=2500, probe_height=1000)
    cfg = SilhouetteConfig()
    lines = []
    plates = learn_plates(frames, rig, coarse, cfg, log=lines.append)
    assert any("left unknown within 0.4 m of the carved parts" in m for m in lines)
    for cam in rig:
        n = cam.name
        body = masks[n].any(axis=0)
        median = plate_from_frames(frames[n], cfg)
        known = plates[n].known
        wrong = np.abs(plates[n].plate - truth[n]).max(axis=2) > 15
        wrong_median = np.abs(median.plate - truth[n]).max(axis=2) > 15
        assert (wrong_median & body).sum() > 0.5 * body.sum()      # the median holds the body
        assert (wrong & known).sum() < 0.001 * known.size
        assert (body & ~known).sum() > 0.98 * body.sum()
        assert (~known).mean() < cfg.plate_max_unknown           # still a plate
        assert plates[n].unknown_margin                          # a margin, GrabCut decides it


def test_person_column_is_the_carved_floor_plan_grown_by_the_radius():
    from voxelmocap.grid import VoxelGrid
    from voxelmocap.measure import background as bg

    rng = np.random.default_rng(3)
    grid = VoxelGrid((-1000, -800, -100), 100.0, (22, 18, 26))
    person = np.zeros(grid.shape, bool)
    person[tuple(rng.integers(0, s, 4) for s in grid.shape)] = True
    column = bg.person_column(person, grid)
    centres = grid.centres().reshape(*grid.shape, 3)
    carved = centres[person]
    # brute force: every voxel against every carved voxel
    d = np.sqrt(((centres[:, :, :, None, :2] - carved[None, None, None, :, :2]) ** 2)
                .sum(axis=-1)).min(axis=-1)
    expected = (d <= bg.PERSON_COLUMN_RADIUS_MM) \
        & (centres[..., 2] <= grid.low[2] + bg.PERSON_COLUMN_HEIGHT_MM)
    np.testing.assert_array_equal(column, expected)
    assert not bg.person_column(np.zeros(grid.shape, bool), grid).any()


def test_a_person_who_never_moves_cannot_give_a_plate():
    from voxelmocap.camera import Camera
    from voxelmocap.grid import VoxelGrid

    rng = np.random.default_rng(4)
    plate = _textured(rng, 48, 64)
    frames = np.repeat(plate[None].astype(np.uint8), 8, axis=0)      # nothing ever changes
    cams = [Camera(f"C{i}", (60, 60), (31.5, 23.5), np.eye(3), (0, 0, 3000), size=(64, 48))
            for i in range(4)]
    grid = VoxelGrid((-500, -500, -500), 50.0, (20, 20, 20))
    with pytest.raises(InputError, match="no person found"):
        learn_plates({c.name: frames for c in cams}, cams, grid)


# ---------------------------------------------------------------------- 3D rules
def _ring_rig():
    """Four cameras on a circle of 4 m, 1.5 m up, looking at a point 0.9 m above the origin."""
    return [_ring_camera(f"C{i + 1}", a) for i, a in enumerate(np.radians([0, 90, 180, 270]))]


def _project_masks(cams, occupancy, grid):
    import cv2

    pts = grid.centres()[occupancy.reshape(-1)]
    masks = []
    for cam in cams:
        m = np.zeros((cam.size[1], cam.size[0]), np.uint8)
        uv = np.round(cam.project(pts)).astype(int)
        ok = (uv[:, 0] >= 0) & (uv[:, 0] < cam.size[0]) & (uv[:, 1] >= 0) & (uv[:, 1] < cam.size[1])
        m[uv[ok, 1], uv[ok, 0]] = 1
        masks.append(cv2.dilate(m, np.ones((7, 7), np.uint8)).astype(bool))
    return masks


def _body(grid, *, leg=0.0, arm=0.0):
    """A box person (torso, legs, head) with a leg and an arm stretched sideways (mm)."""
    c = grid.centres().reshape(*grid.shape, 3)
    x, y, z = c[..., 0], c[..., 1], c[..., 2]
    occ = (np.abs(x) < 180) & (np.abs(y) < 120) & (z > 0) & (z < 1700)
    occ |= (x > 0) & (x < 180 + arm) & (np.abs(y) < 60) & (np.abs(z - 1400) < 60)
    occ |= (x < 0) & (x > -180 - leg) & (np.abs(y) < 70) & (np.abs(z - 500) < 70)
    return occ


def test_carving_tolerates_a_hole_in_one_view_only():
    from voxelmocap.grid import VoxelGrid
    from voxelmocap.measure.carving import Carver, carve_reference

    cams = _ring_rig()
    grid = VoxelGrid((-600, -600, 0), 40.0, (30, 30, 45))
    body = _body(grid)
    masks = _project_masks(cams, body, grid)
    holed = [m.copy() for m in masks]
    holed[0][110:130, :] = False                 # dark shorts on a dark floor in camera 1
    carver = Carver(cams, grid)
    strict = carver.carve(holed)
    tolerant = carver.carve_with_holes(holed, 1)
    # every voxel is seen by all four cameras here, so one hole allowed = "inside ≥ 3 of 4"
    assert carver.coverage().min() == 4
    np.testing.assert_array_equal(tolerant, carve_reference(holed, cams, grid, min_views=3))
    assert (body & ~tolerant).sum() < 0.02 * body.sum() < (body & ~strict).sum()
    # holes in two views are not tolerated
    holed[1][110:130, :] = False
    assert (body & ~carver.carve_with_holes(holed, 1)).sum() > (body & ~tolerant).sum()


def test_a_blob_in_one_view_carves_into_nothing_and_is_rejected():
    from voxelmocap.grid import VoxelGrid
    from voxelmocap.measure.stage import MeasurementStage

    cams = _ring_rig()
    grid = VoxelGrid((-1200, -1200, 0), 40.0, (60, 60, 45))
    body = _body(grid)
    masks = _project_masks(cams, body, grid)
    ghost = [m.copy() for m in masks]
    ghost[2][10:60, 20:70] = True              # a ghost / a background person in camera 3 only
    backgrounds = {c.name: PlateBackground(np.zeros((240, 320)), 2.0) for c in cams}
    stage = MeasurementStage(cams, grid, backgrounds, holes=1, person_only=True)
    clean, _ = stage.carve(masks)
    with_ghost, _ = stage.carve(ghost)
    np.testing.assert_array_equal(with_ghost, clean)
    # a second, separate 3D blob (another person seen by every camera) is dropped too
    other = body.copy()
    other[:] = False
    c = grid.centres().reshape(*grid.shape, 3)
    other |= (np.abs(c[..., 0] - 900) < 100) & (np.abs(c[..., 1] + 900) < 100) & (c[..., 2] < 600)
    both = [a | b for a, b in zip(masks, _project_masks(cams, other, grid), strict=True)]
    two, _ = stage.carve(both)
    assert (two & other).sum() == 0 and (two & body).sum() > 0.95 * body.sum()


def test_a_phantom_two_views_agree_on_at_the_edge_of_a_large_rig_is_not_the_person():
    """Seven cameras on a ring: where only three see, two agreeing blobs carve a phantom (one
    hole tolerated) larger than the person's few moving voxels; the person is searched only
    where at least half the rig looks (four cameras), so the small real one is kept."""
    from voxelmocap.grid import VoxelGrid
    from voxelmocap.measure.background import carve_person, watched_voxels
    from voxelmocap.measure.carving import Carver

    cams = [_ring_camera(f"C{i}", a) for i, a in enumerate(np.radians(np.arange(7) * 50.0))]
    grid = VoxelGrid((-3000, -3000, 0), 100.0, (60, 60, 20))
    carver = Carver(cams, grid)
    coverage = carver.coverage()
    c = grid.centres().reshape(*grid.shape, 3)
    hand = (np.abs(c[..., 0]) < 150) & (np.abs(c[..., 1]) < 150) & (np.abs(c[..., 2] - 1200) < 150)
    assert coverage[hand].min() == 7
    # the phantom: the voxels the same three cameras see, near one of them
    seen_by = (carver.tables >= 0).reshape(len(cams), *grid.shape)
    three = np.argwhere(coverage == 3)
    centre = three[np.argmin(np.abs(three - np.array(grid.shape) / 2).sum(axis=1))]
    who = seen_by[(slice(None), *centre)]
    box = np.zeros(grid.shape, bool)
    box[tuple(slice(max(0, k - 2), k + 3) for k in centre)] = True
    phantom = box & (coverage == 3) & np.all(seen_by == who[:, None, None, None], axis=0)
    assert phantom.sum() > 2 * hand.sum()
    hand_masks = _project_masks(cams, hand, grid)
    ghost_masks = _project_masks(cams, phantom, grid)
    two = np.flatnonzero(who)[:2]
    masks = [h | g if k in two else h
             for k, (h, g) in enumerate(zip(hand_masks, ghost_masks, strict=True))]
    everywhere = person_component(carver.carve_with_holes(masks, 1))
    assert (everywhere & phantom).sum() >= phantom.sum() // 2 and not (everywhere & hand).any()
    person = carve_person(carver, masks, 1)
    assert (person & hand).sum() >= hand.sum() // 2 and not (person & phantom).any()
    np.testing.assert_array_equal(watched_voxels(carver, 1), coverage >= 4)
    # four cameras: the carving's own rule (three views for one hole), nothing more
    four = Carver(cams[:4], grid)
    np.testing.assert_array_equal(watched_voxels(four, 1), four.coverage() >= 3)


def test_the_moving_parts_are_above_the_floor_a_cast_shadow_is_not():
    """A waving arm (8 litres at shoulder height) and its shadow swept over the floor (a slab
    one voxel high, larger): the shadow carves, and is the largest component; the moving parts
    are the arm."""
    from voxelmocap.grid import VoxelGrid
    from voxelmocap.measure.background import SHADOW_HEIGHT_MM, moving_parts
    from voxelmocap.measure.carving import Carver

    cams = _ring_rig()
    grid = VoxelGrid((-1200, -1200, 0), 50.0, (48, 48, 44))
    c = grid.centres().reshape(*grid.shape, 3)
    arm = (np.abs(c[..., 0] - 100) < 100) & (np.abs(c[..., 1]) < 100) \
        & (np.abs(c[..., 2] - 1400) < 100)
    shadow = (np.abs(c[..., 0] + 600) < 300) & (np.abs(c[..., 1] - 300) < 300) \
        & (c[..., 2] < grid.voxel_size)
    assert shadow.sum() > arm.sum() and c[..., 2][shadow].max() < SHADOW_HEIGHT_MM
    masks = [a | s for a, s in zip(_project_masks(cams, arm, grid),
                                   _project_masks(cams, shadow, grid), strict=True)]
    carver = Carver(cams, grid)
    found = person_component(carver.carve_with_holes(masks, 1))
    assert (found & shadow).any() and not (found & arm).any()
    parts = moving_parts(carver, masks, 1)
    assert (parts & arm).sum() == arm.sum() and not (parts & shadow).any()


def _ring_camera(name, angle, radius=4000.0):
    """A 320 × 240 camera on a circle of ``radius`` mm, 1.5 m up, looking at (0, 0, 0.9 m)."""
    from voxelmocap.camera import Camera

    c = np.array([radius * np.cos(angle), radius * np.sin(angle), 1500.0])
    z = np.array([0, 0, 900.0]) - c
    z /= np.linalg.norm(z)
    x = np.cross(z, [0, 0, 1.0])
    x /= np.linalg.norm(x)
    R = np.stack([x, np.cross(z, x), z])
    return Camera(name, (300, 300), (159.5, 119.5), R, -R @ c, size=(320, 240))


def test_person_component_keeps_the_largest_and_joins_close_fragments():
    occ = np.zeros((20, 20, 20), bool)
    occ[2:8, 2:8, 2:8] = True                  # 216: the person
    occ[2:8, 9:11, 2:8] = True                 # an arm one empty voxel away: joined
    occ[15:18, 15:18, 15:18] = True            # 27: another blob
    p = person_component(occ)
    assert p.sum() == 216 + 72 and not p[15:18, 15:18, 15:18].any()
    assert not person_component(np.zeros((3, 3, 3), bool)).any()


def test_auto_grid_encloses_a_body_with_extended_limbs():
    from voxelmocap.grid import VoxelGrid
    from voxelmocap.measure.stage import MeasurementStage
    from voxelmocap.run.measurement import person_grid

    cams = _ring_rig()
    truth_grid = VoxelGrid((-1500, -1500, 0), 20.0, (150, 150, 100))
    body = _body(truth_grid, leg=700, arm=650)
    masks = _project_masks(cams, body, truth_grid)
    coarse = VoxelGrid((-1500, -1500, 0), 50.0, (60, 60, 50))
    backgrounds = {c.name: PlateBackground(np.zeros((240, 320)), 2.0, shadows=False)
                   for c in cams}
    stage = MeasurementStage(cams, coarse, backgrounds, holes=1, person_only=True)
    samples = [{c.name: (m * 255).astype(np.uint8) for c, m in zip(cams, masks, strict=True)}]
    grid = person_grid(stage, samples, 20.0, margin=200.0)
    pts = truth_grid.centres()[body.reshape(-1)]
    assert np.all(pts >= grid.low) and np.all(pts <= grid.high)
    # the margin is there on every side but the floor, and the box is not the whole area
    assert grid.high[0] >= pts[:, 0].max() + 200 - 50
    assert grid.low[0] <= pts[:, 0].min() - 200 + 50
    assert grid.low[2] == 0.0
    assert grid.n_voxels < 0.5 * VoxelGrid((-1500, -1500, 0), 20.0, (150, 150, 125)).n_voxels


def test_runner_learns_the_plate_and_places_the_grid_without_background_videos(tmp_path):
    """A HumanEva-layout sequence without Background/: plate from the sequence, grid around
    the person, one hole tolerated with four cameras, the person's component only."""
    import shutil

    from voxelmocap.config import TrackConfig
    from voxelmocap.io.humaneva import Dataset
    from voxelmocap.run.measurement import MeasurementRunner
    from voxelmocap.synth import generate

    root = generate(tmp_path / "data", motion="walk", frames=24, fps=8, cameras=["C1", "C2",
                    "C3", "BW1"], progress=False, background_frames=2, seed=5)
    shutil.rmtree(root / "Background")
    seq = Dataset(root).sequence("S1", "Walking_1")
    said = []
    runner = MeasurementRunner(seq, TrackConfig(), log=said.append)
    assert runner.learnt_plate and runner.holes == 1 and runner.person_only
    assert any("background plate learnt from" in s for s in said)
    assert any("grid placed around the person" in s for s in said)
    gt = seq.ground_truth()
    pts = gt.endpoints.reshape(-1, 3)
    assert np.all(pts >= runner.grid.low) and np.all(pts <= runner.grid.high)
    # the person is measured where the ground truth says
    _, obs = next(runner.observations([12]))
    centre = runner.grid.centre_of(np.argwhere(obs.occupancy)).mean(axis=0)
    pelvis = gt.endpoints[list(gt.frames).index(12)].mean(axis=0)
    assert np.linalg.norm(centre[:2] - pelvis[:2]) < 150


def test_hole_reach_equals_the_brute_force_rule_and_drops_far_phantoms():
    """One hole tolerated only near the silhouette = "inside ≥ N−1 masks" and "inside every
    mask dilated by the reach" (carve_reference on scipy-dilated masks)."""
    from scipy import ndimage

    from voxelmocap.grid import VoxelGrid
    from voxelmocap.measure.carving import Carver, carve_reference

    cams = _ring_rig()
    grid = VoxelGrid((-1200, -1200, 0), 40.0, (60, 60, 45))
    body = _body(grid)
    masks = _project_masks(cams, body, grid)
    masks[0][114:126, :] = False                       # a hole inside the person in camera 1
    # a phantom seen by cameras 2–4 (e.g. a never-seen region) where camera 1 sees background,
    # far from its silhouette
    c = grid.centres().reshape(*grid.shape, 3)
    phantom = (np.abs(c[..., 0] - 700) < 150) & (np.abs(c[..., 1] - 700) < 150) & (c[..., 2] < 400)
    extra = _project_masks(cams, phantom, grid)
    masks = [m | (e if i else False) for i, (m, e) in enumerate(zip(masks, extra, strict=True))]
    carver = Carver(cams, grid)
    reach = 0.02                                       # 8 pixels of a 400-pixel diagonal
    got = carver.carve_with_holes(masks, 1, reach=reach)
    r = int(round(reach * np.hypot(320, 240)))
    disk = np.hypot(*np.mgrid[-r:r + 1, -r:r + 1]) <= r
    near = [ndimage.binary_dilation(m, structure=disk) for m in masks]
    expected = (carve_reference(masks, cams, grid, min_views=3)
                & carve_reference(near, cams, grid))
    assert carver.coverage().min() == 4
    np.testing.assert_array_equal(got, expected)
    anywhere = carver.carve_with_holes(masks, 1)
    assert (anywhere & phantom).sum() > 0.5 * phantom.sum()       # kept without the reach
    assert (got & phantom).sum() == 0                              # dropped with it
    assert (body & ~got).sum() < 0.02 * body.sum()                 # the inner hole still bridged


def test_grabcut_decides_never_seen_pixels_from_the_frames_colours():
    """A plate that never saw a region larger than the person: the old rule makes the whole
    region foreground; GrabCut keeps the person (a colour unlike the background) only."""
    rng = np.random.default_rng(3)
    h, w = 240, 200
    plate = np.zeros((h, w, 3), np.float32)
    plate[:] = (200, 190, 180)                                     # a pale wall …
    plate[:, : w // 2] = (170, 180, 200)                           # … in two tones
    plate += rng.normal(0, 2, plate.shape)
    person = np.zeros((h, w), bool)
    person[60:200, 80:120] = True                                  # torso and legs
    person[40:60, 90:110] = True                                   # head
    image = plate.copy()
    image[person] = (40, 60, 150)                                  # dark red clothing (BGR)
    image = np.clip(image + rng.normal(0, 2, image.shape), 0, 255).astype(np.uint8)
    known = np.ones((h, w), bool)
    known[30:160, 50:150] = False                                  # never seen empty
    bg = PlateBackground(plate.clip(0, 255), 2.0, known)

    def iou(m):
        return (m & person).sum() / (m | person).sum()

    old = segment_with(bg, image, "foreground")
    new = segment_with(bg, image, "grabcut")
    assert iou(old) < 0.6
    assert iou(new) > 0.9
    # known pixels are never changed; the result is the same on a second call
    np.testing.assert_array_equal(new[known], old[known])
    np.testing.assert_array_equal(segment_with(bg, image, "grabcut"), new)
    # nothing known in the crop to learn the person from: the mask is left as it is
    blind = PlateBackground(plate.clip(0, 255), 2.0, np.zeros((h, w), bool))
    np.testing.assert_array_equal(segment_with(blind, image, "grabcut"), np.ones((h, w), bool))


def test_grabcut_decides_a_person_whose_pixels_were_all_never_seen():
    """A person who barely moved is unknown from head to foot (no pixel of the person is known
    foreground): GrabCut still separates it, its colour model started from the whole unknown
    region against the known background around (GrabCut's rectangle use)."""
    rng = np.random.default_rng(5)
    h, w = 240, 200
    plate = np.zeros((h, w, 3), np.float32)
    plate[:] = (200, 190, 180)
    plate[150:] = (120, 130, 140)                                  # a floor below the wall
    plate += rng.normal(0, 2, plate.shape)
    person = np.zeros((h, w), bool)
    person[60:200, 85:115] = True
    person[40:60, 92:108] = True
    image = plate.copy()
    image[person] = (40, 60, 150)
    image = np.clip(image + rng.normal(0, 2, image.shape), 0, 255).astype(np.uint8)
    known = np.ones((h, w), bool)
    known[20:225, 40:160] = False                                  # the person and more
    bg = PlateBackground(plate.clip(0, 255), 2.0, known, unknown_margin=True)
    assert not (person & known).any()
    new = segment_with(bg, image, "grabcut")
    assert (new & person).sum() / (new | person).sum() > 0.85
    np.testing.assert_array_equal(new[known], False)
    # where the never-seen region is where the person stood throughout (not a margin), a blob
    # of never-seen pixels alone is mostly the person: it is kept whole
    stood = PlateBackground(plate.clip(0, 255), 2.0, known)
    np.testing.assert_array_equal(segment_with(stood, image, "grabcut"),
                                  segment_with(stood, image, "foreground"))
    assert segment_with(stood, image, "grabcut")[~known].mean() > 0.95


def _refine_whole_image(bg, image, mask, config):
    """``PlateBackground.refine`` as it was written first: the blobs labelled on the whole
    image (the reference of the bounding-box labelling)."""
    import cv2

    from voxelmocap.measure.plate import _grabcut

    mask = np.array(mask, bool)
    unknown = mask & ~bg.known
    if not unknown.any():
        return mask
    img = np.ascontiguousarray(image)
    n, labels, st, _ = cv2.connectedComponentsWithStats(mask.astype(np.uint8), connectivity=8)
    has_unknown = np.bincount(labels[unknown], minlength=n) > 0
    h, w = mask.shape
    for k in np.flatnonzero(has_unknown[1:]) + 1:
        x, y, bw, bh = (int(st[k, i]) for i in (0, 1, 2, 3))
        pad = max(bw, bh) // 4 + 8
        box = (slice(max(y - pad, 0), min(y + bh + pad, h)),
               slice(max(x - pad, 0), min(x + bw + pad, w)))
        mask[box] = _grabcut(img[box], mask[box], bg.known[box], config.grabcut_scale,
                             config.grabcut_iterations, unknown_alone=bg.unknown_margin)
    return mask


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_grabcut_on_blobs_labelled_in_the_bounding_box_equals_the_whole_image_labelling(seed):
    # several blobs, some crossing the never-seen region, some touching the image's edges,
    # some nested in another's box: each decided as when labelled on the whole image
    rng = np.random.default_rng(seed)
    h, w = 180, 240
    plate = rng.uniform(120, 200, (h, w, 3)).astype(np.float32)
    image = np.clip(plate + rng.normal(0, 2, plate.shape), 0, 255).astype(np.uint8)
    mask = np.zeros((h, w), bool)
    for _ in range(12):
        y, x = rng.integers(0, h), rng.integers(0, w)
        ry, rx = rng.integers(2, 25, 2)
        mask[max(y - ry, 0):y + ry, max(x - rx, 0):x + rx] = True
        image[max(y - ry, 0):y + ry, max(x - rx, 0):x + rx] = rng.integers(0, 80, 3)
    known = np.ones((h, w), bool)
    known[40:150, 60:200] = False
    for margin in (False, True):
        bg = PlateBackground(plate, 2.0, known, unknown_margin=margin)
        config = SilhouetteConfig()
        np.testing.assert_array_equal(bg.refine(image, mask, config),
                                      _refine_whole_image(bg, image, mask, config))


def segment_with(bg, image, mode):
    from voxelmocap.measure.silhouette import segment

    return segment(image, bg, SilhouetteConfig(plate_unknown=mode))


def test_the_cover_reaches_down_to_the_floor_under_a_person_whose_legs_were_not_carved():
    """Legs the first plate absorbed are in no view's silhouette and not carved; with
    ``support`` the voxels under the carved torso are covered in every view all the same."""
    from voxelmocap.grid import VoxelGrid
    from voxelmocap.measure.background import _cover
    from voxelmocap.measure.carving import Carver

    cams = _ring_rig()
    grid = VoxelGrid((-600, -600, 0), 40.0, (30, 30, 45))
    body = _body(grid)
    z = grid.centres().reshape(*grid.shape, 3)[..., 2]
    torso, legs = body & (z > 900), body & (z < 860)       # one voxel layer apart
    masks = _project_masks(cams, torso, grid)             # the views saw the torso only
    carver = Carver(cams, grid)
    for c, cam in enumerate(cams):
        uv = np.round(cam.project(grid.centres()[legs.reshape(-1)])).astype(int)
        inside = (uv[:, 0] >= 0) & (uv[:, 0] < cam.size[0]) & (uv[:, 1] >= 0) \
            & (uv[:, 1] < cam.size[1])
        uv = uv[inside]
        with_support = _cover(torso, carver, c, masks[c], support=torso)
        without = _cover(torso, carver, c, masks[c])
        assert with_support[uv[:, 1], uv[:, 0]].all()
        assert without[uv[:, 1], uv[:, 0]].mean() < 0.5
        assert (with_support >= without).all()
        # nothing beside the person and the column under it: the whole body's projection,
        # grown by the cover's own dilation and closing, bounds it
        import cv2
        whole = cv2.dilate(_project_masks([cam], body, grid)[0].astype(np.uint8),
                           np.ones((31, 31), np.uint8)).astype(bool)
        assert not (with_support & ~whole).any()


def test_the_observation_carries_the_plates_never_seen_pixels():
    """``observation.known``: per camera the pixels whose background the learnt plate saw; None
    for a camera whose plate saw them all, and None overall when no camera has any unseen."""
    from voxelmocap.grid import VoxelGrid
    from voxelmocap.measure.stage import MeasurementStage

    cams = _ring_rig()
    grid = VoxelGrid((-600, -600, 0), 40.0, (30, 30, 45))
    masks = _project_masks(cams, _body(grid), grid)
    images = {c.name: np.where(m, 200, 0).astype(np.uint8)
              for c, m in zip(cams, masks, strict=True)}
    unseen = np.ones((240, 320), bool)
    unseen[50:90, 100:140] = False
    plates = {c.name: PlateBackground(np.zeros((240, 320)), 2.0,
                                      known=unseen if c.name == "C2" else None) for c in cams}
    obs = MeasurementStage(cams, grid, plates, holes=1).measure(images)
    assert obs.known[0] is None and obs.known[2] is None and obs.known[3] is None
    np.testing.assert_array_equal(obs.known[1], unseen)
    plates["C2"] = PlateBackground(np.zeros((240, 320)), 2.0)
    assert MeasurementStage(cams, grid, plates, holes=1).measure(images).known is None


def test_only_grey_cameras_abstain_where_their_plate_never_saw_the_background():
    from voxelmocap.grid import VoxelGrid
    from voxelmocap.measure.stage import MeasurementStage

    cams = _ring_rig()
    grid = VoxelGrid((-600, -600, 0), 40.0, (30, 30, 45))
    unseen = np.ones((240, 320), bool)
    unseen[50:90, 100:140] = False
    plates = {c.name: PlateBackground(np.zeros((240, 320, 1 if c.name in ("C2", "C3") else 3)),
                                      2.0, known=unseen if c.name != "C3" else None)
              for c in cams}
    stage = MeasurementStage(cams, grid, plates, holes=1)
    # C1 and C4 have colour (GrabCut tells the person by it), C3 saw everything
    assert stage.abstain[0] is None and stage.abstain[2] is None and stage.abstain[3] is None
    np.testing.assert_array_equal(stage.abstain[1], ~unseen)
    colour = {n: PlateBackground(np.zeros((240, 320, 3)), 2.0, known=unseen) for n in plates}
    assert MeasurementStage(cams, grid, colour, holes=1).abstain is None
