"""The periodic limb sweep judged against the silhouettes (``[filter] limb_sweep_silhouette``):
a forearm lying in volume the cameras cannot carve away is found where the images show it.

The scene: the voxels hold the left arm twice — where it is (raised forward) and a phantom copy
raised sideways, as a visual hull keeps volume no camera separates from the body — and the
silhouettes, drawn by a brute-force reference (pixel centres inside each part's projected outline,
scipy's Delaunay), show the arm where it is. The track starts with the arm on the phantom.
"""

import numpy as np
import pytest
from camera_fixture import look_at_camera
from scipy.spatial import Delaunay

from voxelmocap.body import BodyModel
from voxelmocap.config import CuesConfig, TrackConfig, with_overrides
from voxelmocap.grid import VoxelGrid
from voxelmocap.measure.observation import VoxelObservation
from voxelmocap.pose.tracker import BodyTracker
from voxelmocap.score.cues import CueSet
from voxelmocap.score.cues.contours import project_outlines
from voxelmocap.score.likelihood import Measurement, rasterise

MODEL = BodyModel()
GRID = VoxelGrid((-1000.0, -1000.0, 0.0), 30.0, (67, 67, 67))
#: one-step settings as in test_tracker.py's lost-arm tests: a small filter that cannot reach the
#: arm by itself, the sweep every frame, the paper's likelihood alone (no coverage term: both
#: copies of the arm are occupied alike, so the voxels do not prefer either)
CONFIG = with_overrides(TrackConfig(), **{
    "filter.layers": 2, "filter.particles": 40, "filter.limb_sweep_every": 1,
    "filter.joint_std_rad": 0.01, "likelihood.variances": (0.01, 0.01, 0.1, 0.1),
    "likelihood.coverage": 0.0})
L_WRIST = 4


def _camera(name, eye):
    return look_at_camera(name, eye, (320, 240), focal=250.0)


CAMERAS = [_camera("A", (0.0, -4000.0, 1000.0)), _camera("B", (3000.0, -3000.0, 1500.0)),
           _camera("C", (-3500.0, 1500.0, 1200.0))]


def _drawn(state, cam):
    """Brute force: the pixel centres inside the convex hull of any part's projected outline."""
    outline, valid = project_outlines(MODEL.geometry(state[None]), cam)
    w, h = cam.size
    yy, xx = np.mgrid[0:h, 0:w]
    centres = np.stack([xx.ravel(), yy.ravel()], axis=1).astype(float)
    drawn = np.zeros(h * w, bool)
    for q in range(outline.shape[1]):
        if valid[0, q]:
            drawn |= Delaunay(outline[0, q]).find_simplex(centres) >= 0
    return drawn.reshape(h, w)


@pytest.fixture(scope="module")
def scene():
    truth = MODEL.default_state()
    truth[[11, 17]] = (1.4, 0.6)                   # left shoulder flexed: the arm forward
    phantom = MODEL.default_state()
    phantom[[12, 17]] = (1.4, 0.6)                 # left shoulder abducted: the arm sideways
    occupancy = (rasterise(MODEL, truth[None], GRID) > 0) | (rasterise(MODEL, phantom[None],
                                                                       GRID) > 0)
    masks = [_drawn(truth, cam) for cam in CAMERAS]
    images = [np.zeros((cam.size[1], cam.size[0]), np.uint8) for cam in CAMERAS]
    seen = VoxelObservation(occupancy, GRID, masks=masks, images=images, cameras=CAMERAS)
    return truth, phantom, seen


def _wrist_error_after_one_step(scene, **overrides):
    truth, phantom, seen = scene
    tracker = BodyTracker(MODEL, with_overrides(CONFIG, **overrides), seed=0)
    tracker.start("test", phantom)
    record = tracker.step(seen)
    return float(np.linalg.norm(record.landmarks[L_WRIST]
                                - MODEL.landmarks(truth[None])[0, L_WRIST]))


def test_the_silhouettes_move_the_arm_off_the_phantom(scene):
    """With the silhouette cue in the sweep the arm goes where the images show it; with the
    voxels alone it stays on the phantom (which they cannot tell from the arm)."""
    with_images = _wrist_error_after_one_step(scene)
    voxels_only = _wrist_error_after_one_step(scene, **{"filter.limb_sweep_silhouette": 0.0})
    assert with_images < 60.0 and voxels_only > 300.0, (with_images, voxels_only)


def _arm_states(phantom, n=6, seed=3):
    """The phantom pose with its left arm's angles drawn at random, and the arm's scorer."""
    from voxelmocap.pose.hierarchy import LIMBS
    from voxelmocap.score.partial import PartialScorer

    rng = np.random.default_rng(seed)
    states = np.repeat(phantom[None], n, axis=0)
    states[:, [11, 12, 17]] = rng.uniform(0.0, 1.4, (n, 3))
    dims, parts = LIMBS["l_arm"]
    return states, lambda seen: PartialScorer(seen, MODEL, phantom, parts, dims)


def test_the_sweep_score_is_the_tracking_score_plus_the_weighted_cue(scene):
    """The sweep's score of poses moving one arm: the limb search's (voxel) score plus w × the
    silhouette cue evaluated on its own (weight 1, on whole states)."""
    _, phantom, seen = scene
    w = 7.0
    tracker = BodyTracker(MODEL, with_overrides(CONFIG, **{"filter.limb_sweep_silhouette": w}))
    states, scorer = _arm_states(phantom)
    sweep, plain = tracker.sweep_scoring(seen), tracker.limb_scoring(seen)
    assert plain.others is None and plain.partial is None
    cue = CueSet(MODEL, CuesConfig(weights={"silhouette": 1.0})).log_likelihood(seen, states)
    assert np.ptp(cue) > 1.0
    s = scorer(seen)
    np.testing.assert_allclose(sweep(s, states), plain(s, states) + w * cue, rtol=1e-12)


def test_the_cue_is_added_to_the_other_tracked_cues(scene):
    """With another image cue tracked beside the voxels (the edges at 0.5), the sweep's score is
    the limb search's (voxels and edges) plus w × the silhouette cue."""
    _, phantom, seen = scene
    w = 3.0
    tracker = BodyTracker(MODEL, with_overrides(CONFIG, **{
        "cues.weights": {"voxel": 1.0, "edges": 0.5}, "filter.limb_sweep_silhouette": w}))
    states, scorer = _arm_states(phantom, n=4, seed=4)
    plain = tracker.limb_scoring(seen)
    assert plain.others is not None
    cue = CueSet(MODEL, CuesConfig(weights={"silhouette": 1.0})).log_likelihood(seen, states)
    s = scorer(seen)
    np.testing.assert_allclose(tracker.sweep_scoring(seen)(s, states),
                               plain(s, states) + w * cue, rtol=1e-12)


@pytest.mark.parametrize("why", ["weight 0", "silhouette cue tracked", "no silhouettes"])
def test_nothing_is_added_when_there_is_nothing_to_add(scene, why):
    """Weight 0, the tracking cues holding the silhouette cue already (its own weight stands),
    or a frame without silhouettes (voxels given directly): the sweep scores as the limb
    searches do."""
    _, _, seen = scene
    overrides = {"weight 0": {"filter.limb_sweep_silhouette": 0.0},
                 "silhouette cue tracked": {"cues.weights": {"voxel": 1.0, "silhouette": 2.0}},
                 "no silhouettes": {}}[why]
    if why == "no silhouettes":
        seen = Measurement(seen.occupancy, GRID)
    tracker = BodyTracker(MODEL, with_overrides(CONFIG, **overrides))
    sweep, plain = tracker.sweep_scoring(seen), tracker.limb_scoring(seen)
    assert (sweep.variances, sweep.coverage, sweep.voxel_weight, sweep.partial) == \
        (plain.variances, plain.coverage, plain.voxel_weight, None)
    if plain.others is None:
        assert sweep.others is None
    else:
        states = np.repeat(MODEL.default_state()[None], 3, axis=0)
        states[:, 11] = (0.0, 0.7, 1.4)
        np.testing.assert_array_equal(sweep.others(states), plain.others(states))


def test_ignored_silhouette_pixels_take_the_whole_states_cue(scene):
    """With ``[cues] silhouette_unseen = "ignore"`` the partial re-scoring (which counts every
    pixel) is not used: the cue is added on whole states, with the same value."""
    _, phantom, seen = scene
    w = 5.0
    tracker = BodyTracker(MODEL, with_overrides(CONFIG, **{
        "cues.silhouette_unseen": "ignore", "filter.limb_sweep_silhouette": w}))
    sweep, plain = tracker.sweep_scoring(seen), tracker.limb_scoring(seen)
    assert sweep.partial is None and sweep.others is not None
    states, scorer = _arm_states(phantom, n=4, seed=5)
    cue = CueSet(MODEL, CuesConfig(weights={"silhouette": 1.0}, silhouette_unseen="ignore")
                 ).log_likelihood(seen, states)
    s = scorer(seen)
    np.testing.assert_allclose(sweep(s, states), plain(s, states) + w * cue, rtol=1e-12)
