import numpy as np
import pytest

from voxelmocap.body import BodyModel, fit_to_landmarks
from voxelmocap.body.shapes import ANKLE_HEIGHT_SHARE, BodyDimensions
from voxelmocap.body.state import STATE_INDEX
from voxelmocap.config import TrackConfig, with_overrides
from voxelmocap.errors import InputError
from voxelmocap.grid import VoxelGrid
from voxelmocap.pose.body_size import (
    FITTED_KEYS,
    compass_combined,
    dimensions_from_factors,
    dimensions_from_json,
    dimensions_to_json,
    fit_body_dimensions,
    pick_frames,
    posed_height_share,
    rescaled,
    standing_height,
    standing_height_from_poses,
)
from voxelmocap.score.likelihood import VoxelObservation, rasterise

DEG = np.pi / 180.0


def test_factors_scale_lengths_and_keep_the_height_when_asked():
    base = BodyDimensions.average(1700.0)
    same = dimensions_from_factors(base, np.ones(len(FITTED_KEYS)))
    for key in FITTED_KEYS:
        assert np.allclose(getattr(same, key), getattr(base, key))
    # the average adult's chain gives its height to 0.1 mm
    assert same.height == pytest.approx(base.height, abs=0.5)
    f = np.ones(len(FITTED_KEYS))
    f[FITTED_KEYS.index("thigh")] = 1.2
    f[FITTED_KEYS.index("forearm")] = 0.8
    free = dimensions_from_factors(base, f)
    assert free.thigh == pytest.approx((1.2 * base.thigh[0],) * 2)
    assert free.forearm == pytest.approx((0.8 * base.forearm[0],) * 2)
    assert free.height == pytest.approx(same.height + 0.2 * base.thigh[0] / (1 - 0.045))
    kept = dimensions_from_factors(base, f, keep_height=True)
    assert kept.height == pytest.approx(base.height)
    assert standing_height(kept) == pytest.approx(base.height)
    # the chain's proportions are the factors', its sum the base's height
    assert kept.thigh[0] / kept.shin[0] == pytest.approx(1.2 * base.thigh[0] / base.shin[0])
    assert kept.forearm == free.forearm  # not in the standing chain
    assert kept.w_thigh == base.w_thigh
    with pytest.raises(ValueError):
        dimensions_from_factors(base, np.ones(3))


def test_dimensions_json_round_trip_and_bad_text():
    dims = dimensions_from_factors(BodyDimensions.average(1650.0),
                                   np.linspace(0.8, 1.2, len(FITTED_KEYS)))
    assert dimensions_from_json(dimensions_to_json(dims)) == dims
    with pytest.raises(InputError, match="body_dimensions"):
        dimensions_from_json("{not json")
    with pytest.raises(InputError):
        dimensions_from_json('{"height": 1.0}')


def test_pick_frames_spreads_and_keeps_all_when_few():
    assert list(pick_frames(3, 5)) == [0, 1, 2]
    assert list(pick_frames(10, 5)) == [0, 2, 4, 7, 9]
    assert list(pick_frames(10, 2)) == [0, 9]


def test_compass_combined_reaches_a_bounded_quadratic_optimum():
    # Closed form: a separable quadratic with its optimum inside the bounds in 4 coordinates and
    # beyond the upper bound in the fifth (the constrained optimum is the bound), one held fixed.
    target = np.array([0.3, -0.2, 0.7, -0.5, 2.0, 0.4])
    weights = np.array([1.0, 3.0, 0.5, 2.0, 1.0, 1.0])

    def ll(x):
        return -np.sum(weights * (x - target) ** 2, axis=1)

    low, high = -np.ones(6), np.ones(6)
    steps = np.array([0.25, 0.25, 0.25, 0.25, 0.25, 0.0])
    x, f, n = compass_combined(ll, np.zeros(6), steps, low=low, high=high,
                               max_evaluations=400, min_step=1 / 256)
    assert np.allclose(x[:4], target[:4], atol=0.01)
    assert x[4] == pytest.approx(1.0)
    assert x[5] == 0.0
    assert f == pytest.approx(float(ll(x[None])[0]))
    assert n <= 400
    # every coordinate moves in the same iteration: on a small budget it gets much nearer than
    # the one-coordinate compass search of the tracker's refinement
    from voxelmocap.tracking.refine import pattern_search

    _, f_c, _ = compass_combined(ll, np.zeros(6), steps, low=low, high=high,
                                   max_evaluations=50)
    _, f_p, _ = pattern_search(ll, np.zeros(6), np.arange(5), steps[:5], low=low, high=high,
                                 max_evaluations=50)
    assert f_c > f_p + 0.1


def _cone_frames(truth, n_frames=4, seed=0):
    """Occupancies made from the cone model itself in poses with bent elbows and knees."""
    model = BodyModel(truth)
    grid = VoxelGrid((-1000.0, -1000.0, 0.0), 20.0, (100, 100, 100))
    rng = np.random.default_rng(seed)
    poses = []
    for _ in range(n_frames):
        x = model.default_state()
        x[STATE_INDEX["root_yaw"]] = rng.uniform(-np.pi, np.pi)
        for name, lo, hi in [("l_elbow", 30, 100), ("r_elbow", 30, 100), ("l_knee", 20, 80),
                             ("r_knee", 10, 60), ("l_hip_flex", 10, 50), ("r_hip_flex", -20, 20),
                             ("l_shoulder_abd", 20, 70), ("r_shoulder_abd", 20, 70),
                             ("l_shoulder_flex", -30, 60), ("r_shoulder_flex", -30, 60),
                             ("waist_flex", 0, 20)]:
            x[STATE_INDEX[name]] = rng.uniform(lo, hi) * DEG
        poses.append(x)
    poses = np.array(poses)
    return [VoxelObservation(rasterise(model, x[None], grid) > 0, grid) for x in poses], poses


def _cone_case(factors):
    """A cone body with the given length factors of the average adult (the truth), the average
    adult of its height (the fit's start), the truth's rasterised frames, and the poses a tracker
    with the average body finds there (the average fitted to the true landmarks by IK)."""
    truth = dimensions_from_factors(BodyDimensions.average(1700.0), np.asarray(factors))
    base = BodyDimensions.average(truth.height)
    observations, true_poses = _cone_frames(truth)
    poses = np.array([fit_to_landmarks(BodyModel(base), lm)
                      for lm in BodyModel(truth).landmarks(true_poses)])
    return truth, base, observations, poses


def _length_errors(dims, truth) -> dict:
    """|fitted − true| (mm, mean of left and right) of every fitted length."""
    return {k: abs(np.mean(getattr(dims, k)) - np.mean(getattr(truth, k))) for k in FITTED_KEYS}


def test_posed_height_share_is_one_upright_and_follows_the_knees_in_closed_form():
    model = BodyModel.scaled(1700.0)
    up = model.default_state()
    bent = up.copy()
    bent[STATE_INDEX["l_knee"]] = bent[STATE_INDEX["r_knee"]] = 0.6   # thighs vertical
    one_bent = bent.copy()
    one_bent[STATE_INDEX["r_knee"]] = 0.0        # the straight leg's sole is the lower one
    share = posed_height_share(model, np.stack([up, bent, one_bent]))
    shin = np.mean(model.dimensions.shin)
    # the default pose's chain is the height's to 1e-4 (measured 6e-5)
    assert share[0] == pytest.approx(1.0, abs=1e-4)
    assert share[1] == pytest.approx(1.0 - shin * (1.0 - np.cos(0.6)) / 1700.0, abs=1e-4)
    assert share[2] == pytest.approx(share[0], abs=1e-9)
    # the share does not depend on the size the pose is drawn with
    small = BodyModel.scaled(1500.0)
    assert posed_height_share(small, bent[None])[0] == pytest.approx(share[1], abs=1e-9)


def _column(height_mm, grid):
    """A column of voxels 100 mm in radius from the floor to ``height_mm`` (a head-sized
    section at its top), as :func:`voxelmocap.measure.detect.find_extremities` measures it."""
    c = grid.centres().reshape(*grid.shape, 3)
    occ = (np.hypot(c[..., 0], c[..., 1]) <= 100.0) & (c[..., 2] < height_mm)
    return VoxelObservation(occ, grid)


def test_standing_height_is_the_tightest_voxel_height_over_the_pose_share():
    grid = VoxelGrid((-300.0, -300.0, 0.0), 20.0, (30, 30, 110))
    model = BodyModel.scaled(1500.0)     # the size the poses were tracked with: irrelevant
    up = model.default_state()
    crouch = up.copy()
    crouch[STATE_INDEX["l_knee"]] = crouch[STATE_INDEX["r_knee"]] = 0.8
    share = posed_height_share(model, crouch[None])[0]
    # frame 1 crouches in 1400 mm of voxels; frame 2 stands upright in 1560 mm (a hand on the
    # head: the hull is an upper bound of the person) -> the crouch's 1400 / share
    obs = [_column(1400.0, grid), _column(1560.0, grid)]
    height = standing_height_from_poses(model, obs, np.stack([crouch, up]))
    assert height == pytest.approx(1400.0 / share, rel=1e-9)
    assert 1400.0 / share < 1560.0 / posed_height_share(model, up[None])[0]
    # a frame whose head did not carve (a head's length lower than the others) is left out
    headless = _column(1400.0 * 0.85, grid)
    assert standing_height_from_poses(model, obs + [headless], np.stack([crouch, up, crouch])) \
        == pytest.approx(1400.0 / share, rel=1e-9)
    # clipped into the plausible range; no voxels at all -> None
    assert standing_height_from_poses(model, obs[:1], crouch[None],
                                      height_range=(1400.0, 1450.0)) == 1450.0
    empty = VoxelObservation(np.zeros(grid.shape, bool), grid)
    assert standing_height_from_poses(model, [empty], up[None]) is None


def test_rescaled_keeps_the_angles_and_the_soles_on_the_floor():
    dims = BodyDimensions.average(1600.0)
    model = BodyModel(dims)
    x = model.default_state()
    x[STATE_INDEX["l_knee"]] = 0.5
    x[[0, 1]] = (120.0, -40.0)
    big, states = rescaled(dims, x[None], 1760.0)
    assert big.height == pytest.approx(1760.0)
    np.testing.assert_array_equal(states[0, 3:], x[3:])
    before = model.landmarks(x[None])[0]
    after = BodyModel(big).landmarks(states)[0]
    # every landmark's height scales by 1.1 about the floor (z = 0)
    np.testing.assert_allclose(after[:, 2], before[:, 2] * 1.1, rtol=1e-9)
    assert x[2] == model.default_state()[2]      # the input is not modified


def _crouched_frames(truth, grid, knees):
    """A cone body crouched on the floor (one frame per knee angle, hips flexed half as much),
    with a block of voxels under each ankle for the feet the cones lack."""
    from voxelmocap.joints import LANDMARK_NAMES

    model = BodyModel(truth)
    ankles = [LANDMARK_NAMES.index("l_ankle"), LANDMARK_NAMES.index("r_ankle")]
    sole = ANKLE_HEIGHT_SHARE * truth.height
    c = grid.centres().reshape(*grid.shape, 3)
    frames, poses = [], []
    for knee in knees:
        x = model.default_state()
        for side in "lr":
            x[STATE_INDEX[f"{side}_knee"]] = knee
            x[STATE_INDEX[f"{side}_hip_flex"]] = knee / 2
        x[2] -= model.landmarks(x[None])[0, ankles, 2].min() - sole
        occ = rasterise(model, x[None], grid) > 0
        for a in model.landmarks(x[None])[0, ankles]:
            occ |= (np.hypot(c[..., 0] - a[0], c[..., 1] - a[1]) < 50.0) & (c[..., 2] < a[2])
        frames.append(VoxelObservation(occ, grid))
        poses.append(x)
    return frames, np.array(poses)


def test_refit_start_keeps_the_height_the_crouched_poses_imply():
    """A person of 1700 mm crouched in every start frame: frame 1's voxels stand 1600 mm.
    Posed with the average adult of that height (inverse kinematics to the true landmarks: a
    shorter body straightens its legs, so the share reads high) and fitted at both heights, the
    one the voxels over the poses' share imply wins (measured: 1668 mm, summed log-likelihood
    −1.5 against −3.8)."""
    from types import SimpleNamespace

    from voxelmocap.measure.detect import find_extremities
    from voxelmocap.pose.body_size import refit_start
    from voxelmocap.pose.tracker import BodyTracker

    truth = BodyDimensions.average(1700.0)
    grid = VoxelGrid((-700.0, -700.0, 0.0), 20.0, (70, 70, 95))
    observations, true_poses = _crouched_frames(truth, grid, [1.0, 1.1, 1.2])
    low = find_extremities(observations[0].occupancy, grid, max_extremities=0).height_mm
    assert 1450.0 < low < 1650.0
    start = BodyModel(BodyDimensions.average(low))
    poses = [fit_to_landmarks(start, lm) for lm in BodyModel(truth).landmarks(true_poses)]
    records = [SimpleNamespace(state=x, frame=i + 1) for i, x in enumerate(poses)]
    config = with_overrides(TrackConfig(), **{"filter.layers": 2, "filter.particles": 60})
    tracker = BodyTracker(start, config, seed=0)
    _, out, _, fit = refit_start(tracker, observations, records, config, seed=0)
    assert fit.other is not None
    assert fit.other.dimensions.height == pytest.approx(low)
    assert fit.log_likelihood > fit.other.log_likelihood
    assert abs(fit.dimensions.height - 1700.0) < 0.5 * abs(low - 1700.0), (fit.dimensions.height, low)
    assert len(out) == 3


def test_fit_recovers_the_lengths_of_a_rendered_cone_body():
    # Independent truth: a cone body with known proportions far from the average adult's,
    # rasterised in four poses; the fit starts from the average adult of the same height and
    # from the poses a tracker with that body finds (the average adult fitted to the true
    # landmarks by inverse kinematics), not from the true angles.
    truth, base, observations, poses = _cone_case([0.93, 1.15, 0.8, 1.6, 1.15, 0.3, 1.06, 0.86,
                                                   0.9, 1.06])

    fit = fit_body_dimensions(observations, poses, base, keys=FITTED_KEYS, coverage=10.0)
    held = fit_body_dimensions(observations, poses, base, keys=FITTED_KEYS, coverage=10.0,
                               retarget_poses=False)
    assert fit.log_likelihood > fit.start_log_likelihood
    err, before = _length_errors(fit.dimensions, truth), _length_errors(base, truth)
    # mm at 20 mm voxels (measured: max 29, sum 99; with the DO term in the fit: max 28, sum
    # 138; the poses held instead: max 50, sum 203; the average adult: max 78, sum 336)
    assert max(err.values()) < 35.0, err
    assert sum(err.values()) < sum(before.values()) / 2, (err, before)
    assert sum(err.values()) < sum(_length_errors(held.dimensions, truth).values()), err
    assert fit.dimensions.height == pytest.approx(base.height)
    assert fit.states.shape == poses.shape
    assert np.allclose(fit.factors[FITTED_KEYS.index("thigh")],
                       fit.dimensions.thigh[0] / base.thigh[0])


def test_fit_without_double_occupancy_finds_shoulders_inside_the_chest():
    """Narrow shoulders (0.62 of the average's offset: the joint well inside the chest cone, as
    motion-capture skeletons put it) overlap the chest in the rendered truth itself; the DO term
    then pushes the fitted shoulders outwards. Measured at 20 mm: shoulder error 0.5 mm without
    DO, 42 mm with; all lengths summed 128 vs 214 mm."""
    truth, base, observations, poses = _cone_case([0.98, 1.25, 0.62, 1.4, 0.92, 0.15, 0.97, 0.83,
                                                   0.84, 1.05])
    err = {}
    for do in (False, True):
        fit = fit_body_dimensions(observations, poses, base, keys=FITTED_KEYS, coverage=10.0,
                                  double_occupancy=do)
        err[do] = _length_errors(fit.dimensions, truth)
    assert err[False]["shoulder_offset"] < 10.0 < err[True]["shoulder_offset"], err
    assert sum(err[False].values()) < sum(err[True].values()), err


def test_fit_keeps_lengths_not_asked_for():
    truth = BodyDimensions.average(1700.0)
    observations, poses = _cone_frames(truth, n_frames=2, seed=1)
    fit = fit_body_dimensions(observations, poses, truth, rounds=1, length_evaluations=60,
                              pose_evaluations=60, keys=("thigh",))
    for key in FITTED_KEYS:
        if key not in ("thigh", "torso", "head", "hip_drop", "shin"):  # chain rescaled
            assert getattr(fit.dimensions, key) == getattr(truth, key)
    with pytest.raises(ValueError):
        fit_body_dimensions(observations, poses, truth, keys=("elbow",))


def test_track_with_a_fitted_body_records_it_and_resumes(walk_without_answer, tmp_path,
                                                         interrupted_then_resumed):
    from voxelmocap.io.results import read_result
    from voxelmocap.run.pipeline import track_sequence

    config = with_overrides(TrackConfig(), **{
        "filter.layers": 3, "filter.particles": 150, "init.multistart_frames": 3,
        "init.body": "fitted"})
    kwargs = dict(config=config, frames="1:6", seed=2, progress=False, log=lambda *_: None)
    full = track_sequence(walk_without_answer, "S1", "Walking_1", tmp_path / "full", **kwargs)
    result = read_result(full.result_path)
    assert "lengths fitted to 3 frames" in result.attrs["body_model"]
    dims = dimensions_from_json(result.attrs["body_dimensions"])
    assert dims.height == pytest.approx(result.attrs["body_height_mm"])
    # every frame comes from the fitted body: the landmarks are its forward kinematics
    np.testing.assert_allclose(BodyModel(dims).landmarks(result.state), result.landmarks,
                               atol=1e-6)
    assert len(result) == 6
    # Killed while writing the re-tracked first frames, then resumed: the same frames, the
    # same body (re-read from the file, not fitted again).
    resumed = interrupted_then_resumed(walk_without_answer, tmp_path / "part", **kwargs)
    assert resumed.resumed_from == 2
    b = read_result(resumed.result_path)
    np.testing.assert_array_equal(result.state, b.state)
    assert b.attrs["body_dimensions"] == result.attrs["body_dimensions"]
