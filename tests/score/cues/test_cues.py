"""The cues against hand-computed values; fusion is the weighted sum of the cues' logs."""

import dataclasses

import numpy as np
import pytest
from camera_fixture import look_at_camera

from voxelmocap.body import BodyModel
from voxelmocap.config import CuesConfig, TrackConfig, config_from_toml, config_to_toml
from voxelmocap.errors import InputError
from voxelmocap.grid import VoxelGrid
from voxelmocap.measure.observation import VoxelObservation
from voxelmocap.score.cues import CueSet, Views, bhattacharyya, image_bins, parse_cues
from voxelmocap.score.cues.frame import CueFrame
from voxelmocap.score.likelihood import log_likelihood, rasterise


def test_bhattacharyya_hand_computed():
    # p = (0.5, 0.5, 0), q = (0.25, 0.25, 0.5): BC = 2·sqrt(0.125) = 0.7071; D = sqrt(1 − BC)
    assert bhattacharyya([2, 2, 0], [1, 1, 2]) == pytest.approx(np.sqrt(1 - np.sqrt(0.5)))
    assert bhattacharyya([1, 0], [0, 3]) == pytest.approx(1.0)
    assert bhattacharyya([3, 1], [6, 2]) == pytest.approx(0.0, abs=1e-7)
    assert bhattacharyya([0, 0], [1, 1]) == pytest.approx(1.0)       # empty histogram
    cv2 = pytest.importorskip("cv2")
    h1 = np.array([5, 1, 0, 3], np.float32)
    h2 = np.array([1, 2, 4, 2], np.float32)
    assert bhattacharyya(h1, h2) == pytest.approx(
        cv2.compareHist(h1, h2, cv2.HISTCMP_BHATTACHARYYA), abs=1e-6)


def test_image_bins():
    img = np.array([[[0, 0, 0], [255, 255, 255], [64, 128, 200]]], np.uint8)
    bins, n = image_bins(img, 4)
    assert n == 64 and bins.tolist() == [[0, 63, (1 * 4 + 2) * 4 + 3]]
    grey, m = image_bins(np.array([[0, 15, 16, 255]], np.uint8), 4)
    assert m == 16 and grey.tolist() == [[0, 0, 1, 15]]


# ----------------------------------------------------------------------- a synthetic frame
def _camera(name="C", eye=(0.0, -4000.0, 1000.0), size=(640, 480)):
    """A camera at ``eye`` looking at (0, 0, 1000) mm, principal point at the image centre."""
    return look_at_camera(name, eye, size)


def _frame(model, state, cameras, *, grid=None):
    """Images of the model's quadrangles filled with a colour per part on a grey background."""
    import cv2

    geo = model.geometry(state[None])
    images = []
    from voxelmocap.score.cues import project_contours

    for cam in cameras:
        img = np.full((480, 640, 3), 90, np.uint8)
        seg, _valid, depth = project_contours(geo, cam)
        for part in np.argsort(-depth[0]):          # far to near
            quad = seg[0, part][[0, 0, 1, 1], [0, 1, 1, 0]]
            colour = (int(40 + 20 * part), int(200 - 15 * part), int(60 + 10 * part))
            cv2.fillConvexPoly(img, np.round(quad).astype(np.int32), colour)
        images.append(img)
    grid = grid or VoxelGrid((-1000.0, -1000.0, 0.0), 40.0, (50, 50, 50))
    occ = rasterise(model, state[None], grid) > 0
    return VoxelObservation(occ, grid, images=images, cameras=list(cameras))


def test_distance_cue_hand_computed():
    """D = mean distance-map value at the visible contour points; log p = −D²/(2σ_e²)."""
    model = BodyModel()
    x = model.default_state()
    cam = _camera()
    obs = _frame(model, x, [cam])
    cues = CueSet(model, CuesConfig(weights={"dt": 1.0}))
    frame = cues.prepare(obs)
    # replace the Canny distance map by a hand-made one: distance 3 everywhere → D = 3
    frame._distance[0] = np.full((480, 640), 3.0, np.float32)
    got = cues.log_likelihood(obs, x[None])
    assert got[0] == pytest.approx(-9.0 / (2 * 10.0 ** 2))
    # a map whose value is the column u: D = mean u of the visible contour points
    frame._distance[0] = np.tile(np.arange(640, dtype=np.float32), (480, 1))
    from voxelmocap.score.cues.reference import dt_sum_reference

    views = Views(model, frame, x[None])
    total, count = dt_sum_reference(views.seg[0], views.valid[0], views.depth[0],
                                    frame._distance[0])
    d = total[0] / count[0]
    assert 250 < d < 390
    assert cues.log_likelihood(obs, x[None])[0] == pytest.approx(-d * d / 200.0)


def test_canny_distance_map_of_a_square():
    model = BodyModel()
    obs = _frame(model, model.default_state(), [_camera()])
    img = np.full((480, 640, 3), 100, np.uint8)
    img[200:300, 300:400] = 200
    obs.images = [img]
    frame = CueFrame(obs)
    dt = frame.distance(0)
    # Canny marks the square's border; a pixel 30 px outside it is ≈ 30 px from the edge
    assert dt[250, 250] == pytest.approx(49.0, abs=2.0)
    assert dt[250, 350] == pytest.approx(49.0, abs=2.0)      # the centre: 50 px from every side
    assert dt[200, 350] <= 1.0


def test_roi_cue_zero_at_reference_and_worse_when_moved():
    model = BodyModel()
    x = model.default_state()
    obs = _frame(model, x, [_camera()])
    cues = CueSet(model, CuesConfig(weights={"roi": 1.0, "uniform": 1.0}))
    cues.learn(obs, x)
    moved = x.copy()
    moved[0] += 250.0
    parts = cues.evaluate(obs, np.stack([x, moved]))
    assert parts["roi"][0] == pytest.approx(0.0, abs=1e-9)
    assert parts["roi"][1] < -1.0
    # uniform colour: each part is filled with one colour, so at the true pose the spread is
    # nearly 0 (a few samples round onto a neighbour's border) and far larger when moved
    assert parts["uniform"][0] > -0.05
    assert parts["uniform"][1] < 10 * parts["uniform"][0]


def test_fusion_is_weighted_sum_of_logs():
    model = BodyModel()
    x = model.default_state()
    obs = _frame(model, x, [_camera(), _camera("D", eye=(3000.0, -3000.0, 1500.0))])
    weights = {"voxel": 1.0, "edges": 0.3, "dt": 2.0, "roi": 0.5, "blob3d": 1.5, "skin": 0.1,
               "uniform": 0.7}
    cues = CueSet(model, CuesConfig(weights=weights))
    cues.learn(obs, x)
    rng = np.random.default_rng(0)
    states = model.clip(x + rng.normal(size=(5, 27)) * np.r_[np.full(3, 40.0), np.full(24, 0.1)])
    parts = cues.evaluate(obs, states)
    total = cues.log_likelihood(obs, states)
    np.testing.assert_allclose(total, sum(w * parts[n] for n, w in weights.items()), rtol=1e-12)
    # the voxel term is the voxel likelihood itself
    np.testing.assert_allclose(parts["voxel"], log_likelihood(obs, model, states))
    # each term alone, as a CueSet of one, gives the same values
    for name in weights:
        alone = CueSet(model, CuesConfig(weights={name: 1.0}))
        if alone.cues[name].needs_reference:
            alone.learn(obs, x)
        np.testing.assert_allclose(alone.log_likelihood(obs, states), parts[name], rtol=1e-12)
    # the filter's callable
    ll = cues.frame(obs)
    np.testing.assert_allclose(ll(states), total, rtol=1e-12)


def test_voxel_only_is_the_voxel_likelihood():
    model = BodyModel()
    x = model.default_state()
    grid = VoxelGrid((-1000.0, -1000.0, 0.0), 40.0, (50, 50, 50))
    obs = VoxelObservation(rasterise(model, x[None], grid) > 0, grid)   # no images needed
    cues = CueSet(model, CuesConfig())
    assert cues.voxel_only
    np.testing.assert_array_equal(cues.frame(obs)(x[None]), log_likelihood(obs, model, x[None]))


def test_voxel_cue_refused_below_two_cameras():
    model = BodyModel()
    x = model.default_state()
    obs = _frame(model, x, [_camera()])
    for weights in ({"voxel": 1.0, "edges": 1.0}, {"blob3d": 1.0}):
        with pytest.raises(InputError, match="at least two cameras"):
            CueSet(model, CuesConfig(weights=weights)).frame(obs)
    CueSet(model, CuesConfig(weights={"edges": 1.0})).frame(obs)(x[None])   # image cues: fine


def test_image_cue_without_images_is_refused():
    model = BodyModel()
    grid = VoxelGrid((-1000.0, -1000.0, 0.0), 40.0, (50, 50, 50))
    obs = VoxelObservation(np.zeros(grid.shape, bool), grid)
    with pytest.raises(InputError, match="camera images"):
        CueSet(model, CuesConfig(weights={"edges": 1.0})).frame(obs)


def test_parse_and_config_round_trip():
    assert parse_cues("voxel, edges=0.5") == {"voxel": 1.0, "edges": 0.5}
    assert parse_cues("fused") == {"voxel": 1.0, "roi": 4.0, "edges": 0.1}
    for bad in ("voxel,nope", "edges=x", ""):
        with pytest.raises(InputError):
            parse_cues(bad)
    cfg = dataclasses.replace(TrackConfig(), cues=CuesConfig(weights={"voxel": 1.0, "roi": 0.5}))
    back = config_from_toml(config_to_toml(cfg))
    assert back.cues.weights == {"voxel": 1.0, "roi": 0.5}
    assert back == cfg
    with pytest.raises(InputError, match="unknown cue"):
        config_from_toml("[cues]\nweights = {voxels = 1.0}\n", "f.toml")
    with pytest.raises(InputError, match="positive weight"):
        config_from_toml("[cues]\nweights = {voxel = 0.0}\n", "f.toml")
    with pytest.raises(InputError, match="edge_search"):
        config_from_toml("[cues]\nedge_search = 0\n", "f.toml")


def test_tracker_with_image_cues_follows_the_pose():
    """The body tracker with fused cues steps on image observations and stays on the pose."""
    from voxelmocap.config import with_overrides
    from voxelmocap.pose.tracker import BodyTracker

    model = BodyModel()
    x = model.default_state()
    cams = [_camera(), _camera("D", eye=(3000.0, -3000.0, 1500.0))]
    config = with_overrides(TrackConfig(), **{"filter.layers": 2, "filter.particles": 40})
    config = dataclasses.replace(config, cues=CuesConfig(weights={"voxel": 1.0, "edges": 0.1,
                                                                  "roi": 1.0}))
    tracker = BodyTracker(model, config, seed=1)
    obs = _frame(model, x, cams)
    tracker.initialise(obs, model.landmarks(x[None])[0], frame=1)
    record = tracker.step(obs, frame=1)
    assert tracker.cues.cues["roi"].learnt
    with tracker._paper_likelihood():          # recorded without the coverage term
        expected = tracker.cues.log_likelihood(obs, record.state[None])[0]
    assert record.log_likelihood == pytest.approx(expected)
    err = np.linalg.norm(record.landmarks - model.landmarks(x[None])[0], axis=1).mean()
    assert err < 60.0


def test_checkpoint_keeps_learnt_references(tmp_path):
    """A tracker restored from a checkpoint (through the result file's packing) steps on exactly
    as the uninterrupted one: the ROI, skin and uniform references travel with the state."""
    from voxelmocap.config import with_overrides
    from voxelmocap.io._result_format import _pack_checkpoint, _unpack_checkpoint
    from voxelmocap.pose.tracker import BodyTracker

    model = BodyModel()
    x = model.default_state()
    cams = [_camera(), _camera("D", eye=(3000.0, -3000.0, 1500.0))]
    config = with_overrides(TrackConfig(), **{"filter.layers": 2, "filter.particles": 30})
    config = dataclasses.replace(config, cues=CuesConfig(weights={
        "voxel": 1.0, "roi": 4.0, "skin": 0.1, "uniform": 0.5}))
    obs = _frame(model, x, cams)
    moved = x.copy()
    moved[0] += 30.0
    obs2 = _frame(model, moved, cams)
    one = BodyTracker(model, config, seed=3)
    one.initialise(obs, model.landmarks(x[None])[0], frame=1)
    one.step(obs, frame=1)
    state = _unpack_checkpoint(_pack_checkpoint(one.get_state()))
    assert any(k.startswith("cue_roi_ref_") for k in state)
    two = BodyTracker(model, config, seed=99)
    two.set_state(state)
    a = one.step(obs2, frame=2)
    b = two.step(obs2, frame=2)
    np.testing.assert_array_equal(a.state, b.state)
    assert a.log_likelihood == b.log_likelihood
