import numpy as np
import pytest

from voxelmocap.body import STATE_INDEX, BodyModel
from voxelmocap.errors import InputError
from voxelmocap.grid import VoxelGrid
from voxelmocap.score.likelihood import (
    QMAX,
    Measurement,
    log_likelihood,
    log_likelihood_from_scores,
    part_counts,
    part_counts_reference,
    part_scores,
    part_scores_reference,
    rasterise,
    rasterise_reference,
)

DEG = np.pi / 180
GRID = VoxelGrid((-1200.0, -1200.0, 0.0), 20.0, (120, 120, 100))


def standing(model, **angles):
    x = model.default_state()
    for name, value in angles.items():
        x[STATE_INDEX[name]] = value
    return x


def random_legal(model, rng, n, *, xy=1000.0):
    x = rng.uniform(model.low, model.high, (n, 27))
    x[:, 0:2] = rng.uniform(-xy, xy, (n, 2))
    x[:, 2] = rng.uniform(300.0, 1400.0, n)
    return x


def test_part_voxel_counts_match_frustum_volume():
    rng = np.random.default_rng(21)
    model = BodyModel()
    vs = 5.0
    grid = VoxelGrid((-100.0, -100.0, 0.0), vs, (8, 8, 8))   # counts do not need the grid
    meas = Measurement(np.zeros(grid.shape, bool), grid)
    x = model.clip(random_legal(model, rng, 4) + rng.uniform(0, 1, (4, 27)) * 1e-3)
    counts = part_counts(meas, model, x)
    volumes = np.array([p.volume for p in model.parts]) / vs ** 3
    np.testing.assert_allclose(counts[..., 0], np.broadcast_to(volumes, counts.shape[:2]),
                               rtol=0.02)


def make_measurement(model, rng, grid, *, scene=True):
    occ = rasterise(model, standing(model, l_elbow=60 * DEG, r_hip_flex=30 * DEG), grid) > 0
    occ ^= rng.random(grid.shape) < 0.03
    mask = None
    if scene:
        mask = np.ones(grid.shape, bool)
        mask[:, :4] = False
        mask[-3:] = False
    return Measurement(occ, grid, sigma=1.5, scene=mask)


@pytest.mark.parametrize("seed, voxel", [(31, 30.0), (32, 40.0), (33, 23.7)])
def test_fast_counts_equal_reference_on_random_poses(seed, voxel):
    rng = np.random.default_rng(seed)
    model = BodyModel()
    shape = tuple(int(v) for v in np.ceil(np.array([1800.0, 1700.0, 1900.0]) / voxel))
    grid = VoxelGrid((-900.0 + rng.uniform(-5, 5), -850.0, -10.0), voxel, shape)
    meas = make_measurement(model, rng, grid)
    x = random_legal(model, rng, 100)
    fast = part_counts(meas, model, x)
    ref = part_counts_reference(meas, model, x)
    np.testing.assert_array_equal(fast, ref)
    np.testing.assert_array_equal(part_scores(meas, model, x), part_scores_reference(meas, model, x))
    # the poses exercise every case: parts leaving the grid, overlapping parts, occupied voxels
    assert (fast[..., 1] > 0).any() and (fast[..., 1] == 0).any()
    assert (fast[..., 2] > 0).any() and (fast[..., 3] > 0).any()


@pytest.mark.parametrize("scene", [False, True])
def test_fast_equals_reference_beyond_the_prefix_columns(scene):
    """A compact person on a wide grid: the prefix table holds its columns only, and particles
    reaching far outside them (and outside the grid) are counted as the reference counts them,
    with and without a scene mask (whose excluded columns the table must then hold too)."""
    rng = np.random.default_rng(35)
    model = BodyModel()
    grid = VoxelGrid((-2000.0, -1800.0, -10.0), 25.0, (160, 150, 80))
    occ = rasterise(model, standing(model, l_elbow=60 * DEG, r_hip_flex=30 * DEG), grid) > 0
    mask = None
    if scene:
        mask = np.ones(grid.shape, bool)
        mask[10:20, 100:110, :30] = False  # away from the person
    meas = Measurement(occ, grid, sigma=1.5, scene=mask)
    ni, nj = meas.prefix.shape[:2]
    assert ni * nj < 0.25 * grid.shape[0] * grid.shape[1]
    x = random_legal(model, rng, 60)
    x[:, :2] = rng.uniform(-2200.0, 2200.0, (60, 2))  # some inside the table, most outside
    fast = part_counts(meas, model, x)
    np.testing.assert_array_equal(fast, part_counts_reference(meas, model, x))
    assert (fast[..., 3] > 0).any() and (fast[..., 1] > 0).any()
    if scene:
        # parts inside the grid but outside the scene box are counted Out
        assert meas.prefix_lattice[3] <= 10 and meas.prefix_lattice[4] <= 100


def test_fast_equals_reference_at_fine_voxels_and_axis_aligned_poses():
    # axis-aligned cones on a lattice through the cone edges: the exact-tie cases
    rng = np.random.default_rng(34)
    model = BodyModel()
    grid = VoxelGrid((-400.0, -300.0, 0.0), 10.0, (80, 60, 190))
    meas = make_measurement(model, rng, grid, scene=False)
    x = np.stack([standing(model), standing(model, l_shoulder_abd=90 * DEG, r_hip_flex=90 * DEG),
                  standing(model, root_yaw=90 * DEG, l_elbow=90 * DEG)])
    np.testing.assert_array_equal(part_counts(meas, model, x), part_counts_reference(meas, model, x))


def test_rasterise_equals_reference_and_counts():
    rng = np.random.default_rng(41)
    model = BodyModel()
    x = random_legal(model, rng, 3, xy=300.0)
    meas = Measurement(np.zeros(GRID.shape, bool), GRID)
    for state in x:
        vol = rasterise(model, state, GRID)
        assert vol.dtype == np.uint8 and vol.shape == GRID.shape
        np.testing.assert_array_equal(vol, rasterise_reference(model, state, GRID))
        counts = part_counts(meas, model, state[None])[0]
        # every part voxel inside the grid adds one
        assert vol.sum() == (counts[:, 0] - counts[:, 1]).sum()


def test_own_rasterisation_is_fully_occupied_and_best():
    rng = np.random.default_rng(51)
    model = BodyModel()
    # every joint bent a little, so that every dimension moves some voxels (the twist of a straight
    # limb about its round axis would not)
    x = standing(model, l_elbow=40 * DEG, r_elbow=30 * DEG, r_shoulder_flex=30 * DEG,
                 l_hip_flex=20 * DEG, r_knee=30 * DEG, l_knee=20 * DEG, root_yaw=0.3)
    meas = Measurement(rasterise(model, x, GRID) > 0, GRID, sigma=1.0)
    scores = part_scores(meas, model, x[None])[0]
    assert np.all(scores[:, 2] == 0.0)             # ρ_Empty = 0
    assert np.all(scores[:, 0] == 0.0)             # nothing leaves the grid
    best = log_likelihood(meas, model, x[None])[0]
    perturbed = []
    for d in range(27):
        for sign in (-1.0, 1.0):
            y = x.copy()
            y[d] += sign * (60.0 if d < 3 else 0.25)
            if model.low[d] <= y[d] <= model.high[d]:
                perturbed.append(y)
    y = model.clip(x + rng.normal(0, 0.15, (40, 27)) * np.r_[np.full(3, 200.0), np.ones(24)])
    perturbed = np.concatenate([np.array(perturbed), y])
    ll = log_likelihood(meas, model, perturbed)
    assert np.all(ll < best)


def test_forearm_crossing_torso_has_more_double_occupancy():
    model = BodyModel()
    meas = Measurement(np.zeros(GRID.shape, bool), GRID)
    hanging = standing(model)
    crossing = standing(model, r_elbow=90 * DEG, r_shoulder_rot=70 * DEG)  # hand on the belly
    s = part_scores(meas, model, np.stack([hanging, crossing]))
    r_forearm = model.part_names.index("r_forearm")
    assert s[1, r_forearm, 1] > s[0, r_forearm, 1] + 0.5
    # in the neutral pose, overlap stays at the joints (documented in likelihood's docstring)
    neutral_do = dict(zip(model.part_names, s[0, :, 1], strict=True))
    assert neutral_do["l_upper_arm"] < 0.3 and neutral_do["torso"] < 0.05
    assert max(v for k, v in neutral_do.items() if "upper_arm" not in k) < 0.1


def test_out_is_positive_exactly_for_parts_leaving_the_grid():
    model = BodyModel()
    grid = VoxelGrid((-600.0, -400.0, 0.0), 20.0, (60, 40, 95))   # top at 1900 mm
    meas = Measurement(np.zeros(grid.shape, bool), grid)
    x = standing(model)
    x[0] = -600.0 + 185.0 + 20.0    # left arm's outer half beyond x = −600
    scores = part_scores(meas, model, x[None])[0]
    out = dict(zip(model.part_names, scores[:, 0], strict=True))
    assert out["l_upper_arm"] > 0 and out["l_forearm"] > 0
    assert all(out[k] == 0 for k in model.part_names if not k.startswith("l_") or "arm" not in k)
    # lift the body so that the head goes through the ceiling
    y = x.copy()
    y[2] += 300.0
    out2 = dict(zip(model.part_names, part_scores(meas, model, y[None])[0, :, 0], strict=True))
    assert out2["head"] > 0 and out2["r_shin"] == 0
    # a scene mask excluding the lower half makes the legs Out inside the grid
    scene = np.ones(grid.shape, bool)
    scene[:, :, :25] = False
    s3 = part_scores(Measurement(np.zeros(grid.shape, bool), grid, scene=scene), model, x[None])[0]
    assert s3[model.part_names.index("r_shin"), 0] > 0.5


def test_surf_is_mean_of_one_minus_smoothed_surface():
    model = BodyModel()
    grid = VoxelGrid((-600.0, -400.0, 0.0), 25.0, (48, 32, 76))
    x = standing(model)
    meas_empty = Measurement(np.zeros(grid.shape, bool), grid)
    assert np.all(part_scores(meas_empty, model, x[None])[0, :, 3] == 1.0)
    occ = np.ones(grid.shape, bool)     # surface only at the grid boundary
    meas_full = Measurement(occ, grid)
    s = part_scores(meas_full, model, x[None])[0]
    assert np.all(s[:, 2] == 0.0) and np.all(s[:, 3] > 0.99)
    assert meas_full.smoothed_q.max() == QMAX


def test_log_likelihood_formula_and_variances():
    rng = np.random.default_rng(61)
    model = BodyModel()
    meas = make_measurement(model, rng, GRID)
    x = random_legal(model, rng, 6, xy=200.0)
    s = part_scores(meas, model, x)
    var = np.array([0.01, 0.01, 0.1, 0.1])
    expected = -0.5 * (s ** 2 / var).sum(axis=(1, 2))
    np.testing.assert_allclose(log_likelihood(meas, model, x), expected, rtol=1e-12)
    np.testing.assert_allclose(log_likelihood(meas, model, x, variances=(1, 1, 1, 1)),
                               -0.5 * (s ** 2).sum(axis=(1, 2)), rtol=1e-12)
    with pytest.raises(InputError, match="variances"):
        log_likelihood_from_scores(s, variances=(0.01, 0.0, 0.1, 0.1))


def test_bad_input():
    model = BodyModel()
    meas = Measurement(np.zeros(GRID.shape, bool), GRID)
    x = standing(model)
    nan = x.copy()
    nan[20] = np.nan
    with pytest.raises(InputError, match="l_hip_abd"):
        log_likelihood(meas, model, nan[None])
    with pytest.raises(InputError, match="l_hip_abd"):
        log_likelihood(meas, model, nan[None], clip=True)
    bent = x.copy()
    bent[STATE_INDEX["r_knee"]] = -0.2
    with pytest.raises(InputError, match="r_knee"):
        part_scores(meas, model, bent[None])
    np.testing.assert_array_equal(part_scores(meas, model, bent[None], clip=True),
                                  part_scores(meas, model, x[None]))
    with pytest.raises(InputError, match="does not match the grid"):
        Measurement(np.zeros((10, 10, 10), bool), GRID)
    with pytest.raises(InputError, match="scene"):
        Measurement(np.zeros(GRID.shape, bool), GRID, scene=np.ones((3, 3, 3), bool))
    with pytest.raises(InputError, match="sigma"):
        Measurement(np.zeros(GRID.shape, bool), GRID, sigma=0.0)
    with pytest.raises(InputError, match="grid"):
        Measurement(np.zeros(GRID.shape, bool), "grid")
    with pytest.raises(InputError, match="expected shape"):
        part_scores(meas, model, np.zeros((2, 26)))
    with pytest.raises(InputError, match="one state"):
        rasterise(model, np.stack([x, x]), GRID)


def test_fast_equals_reference_on_exact_ties():
    # cylinder upper arms (R = 1) standing vertical, columns exactly tangent to them (x = 135 and
    # 235 mm, y = 0) and voxel centres exactly on the joints' end planes: the degenerate cases
    from voxelmocap.body import BodyDimensions

    dims = BodyDimensions.average().replace(w_forearm=(50.0, 50.0))
    model = BodyModel(dims)
    assert model.parts[2].R == 1.0
    grid = VoxelGrid((-1000.0, -1005.0, -5.0), 10.0, (200, 201, 200))
    meas = Measurement(np.zeros(grid.shape, bool), grid)
    x = standing(model)
    x[2] = 1000.0
    states = [x.copy()]
    for name, value in (("root_yaw", 90 * DEG), ("l_shoulder_abd", 90 * DEG),
                        ("r_elbow", 90 * DEG), ("l_hip_flex", 90 * DEG)):
        y = x.copy()
        y[STATE_INDEX[name]] = value
        states.append(y)
    states = np.array(states)
    np.testing.assert_array_equal(part_counts(meas, model, states),
                                  part_counts_reference(meas, model, states))


def test_coverage_term_against_the_rasterised_body():
    """u = 1 − (Σ_parts Occ − ½ Σ_parts DO) / |V^R|, recomputed voxel by voxel from the
    reference rasterisation (n_v parts containing voxel v): Σ_{v occupied} n_v − ½ Σ_{n_v ≥ 2} n_v;
    the term is added to log_likelihood and is 0 at weight 0."""
    from voxelmocap.score.likelihood import coverage_log_likelihood

    rng = np.random.default_rng(61)
    model = BodyModel()
    truth = standing(model, l_elbow=40 * DEG, r_shoulder_abd=60 * DEG, r_elbow=90 * DEG)
    occ = rasterise(model, truth, GRID) > 0
    occ ^= rng.random(GRID.shape) < 0.01          # some voxels no body explains
    meas = Measurement(occ, GRID, sigma=1.0)
    states = np.stack([truth, standing(model, r_elbow=150 * DEG, r_shoulder_abd=60 * DEG),
                       *random_legal(model, rng, 3, xy=200.0)])
    counts = part_counts(meas, model, states)
    expect = []
    for x in states:
        n = rasterise_reference(model, x, GRID).astype(np.int64)
        covered = n[occ].sum() - 0.5 * n[n >= 2].sum()
        u = min(max(1.0 - covered / occ.sum(), 0.0), 1.0)
        expect.append(-0.5 * 300.0 * u * u / 0.1)
    np.testing.assert_allclose(coverage_log_likelihood(meas, counts, 300.0), expect, rtol=1e-12)
    plain = log_likelihood(meas, model, states)
    np.testing.assert_allclose(log_likelihood(meas, model, states, coverage=300.0),
                               plain + np.array(expect), rtol=1e-12)
    assert np.all(coverage_log_likelihood(meas, counts, 0.0) == 0.0)
    # the folded forearm leaves the true forearm's voxels uncovered: it pays for them
    assert expect[1] < expect[0]


def test_score_kernels_equal_the_numpy_expressions():
    """Counts → scores and the coverage term, bit for bit as the NumPy expressions compute them
    (empty parts included, and a leading batch shape for the scores)."""
    from voxelmocap.score.likelihood import QMAX, coverage_log_likelihood, scores_from_counts

    rng = np.random.default_rng(36)
    counts = rng.integers(0, 900, (300, 10, 6))
    counts[rng.random((300, 10)) < 0.1, 0] = 0  # parts without a voxel
    counts[rng.random((300, 10)) < 0.1, 4] = 0  # and without a surface voxel
    n = counts[..., 0]
    nsafe = np.maximum(n, 1).astype(float)
    want = np.empty(counts.shape[:-1] + (4,))
    want[..., 0] = counts[..., 1] / nsafe
    want[..., 1] = counts[..., 2] / nsafe
    want[..., 2] = (n - counts[..., 3]) / nsafe
    want[..., 3] = counts[..., 5] / (np.maximum(counts[..., 4], 1).astype(float) * QMAX)
    want[n == 0] = (0.0, 0.0, 1.0, 1.0)
    np.testing.assert_array_equal(scores_from_counts(counts), want)
    np.testing.assert_array_equal(scores_from_counts(counts.reshape(3, 100, 10, 6)),
                                  want.reshape(3, 100, 10, 4))

    class Seen:
        n_occupied = 2300

    covered = counts[..., 3].sum(axis=1) - 0.5 * counts[..., 2].sum(axis=1)
    u = np.clip(1.0 - covered / Seen.n_occupied, 0.0, 1.0)
    assert (u == 0).any() and ((u > 0) & (u < 1)).any()
    np.testing.assert_array_equal(coverage_log_likelihood(Seen(), counts, 750.0),
                                  -0.5 * 750.0 * u * u / 0.1)
    np.testing.assert_array_equal(coverage_log_likelihood(Seen(), counts, 0.0), np.zeros(300))
