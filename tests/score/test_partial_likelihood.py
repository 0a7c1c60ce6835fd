"""Partial re-scoring (a limb moving, the rest held) equals full scoring exactly."""

import numpy as np
import pytest

from voxelmocap.body import BodyModel
from voxelmocap.grid import VoxelGrid
from voxelmocap.pose.hierarchy import BODY_PARTITIONS
from voxelmocap.score.likelihood import Measurement, log_likelihood, part_counts, rasterise
from voxelmocap.score.partial import PartialScorer

DEG = np.pi / 180


def _observation(model, rng, grid):
    x = model.default_state()
    x[[11, 14, 17, 19]] = (40 * DEG, -30 * DEG, 70 * DEG, 30 * DEG)
    occ = rasterise(model, x[None], grid) > 0
    occ ^= rng.random(grid.shape) < 0.03      # noise: Empty and Surf are not all-or-nothing
    scene = np.ones(grid.shape, bool)
    scene[:, :5] = False                        # a scene mask: Out counts inside the grid too
    return Measurement(occ, grid, sigma=1.5, scene=scene)


def _reference(model, rng, grid):
    ref = model.default_state()
    ref[6:] = rng.uniform(model.low[6:], model.high[6:]) * 0.6
    ref[3] = rng.uniform(-np.pi, np.pi)
    # sometimes partly outside the grid, so that Out and the unbounded lattice take part
    ref[0] = rng.choice([0.0, grid.origin[0] + 100.0])
    return ref


@pytest.mark.parametrize("seed, voxel", [(1, 20.0), (2, 30.0), (3, 23.7)])
def test_limb_counts_equal_full_counts(seed, voxel):
    rng = np.random.default_rng(seed)
    model = BodyModel()
    grid = VoxelGrid((-1000.0, -1000.0, 0.0), voxel, tuple(int(2000 / voxel) for _ in range(3)))
    seen = _observation(model, rng, grid)
    for dims, parts in BODY_PARTITIONS[1:]:
        ref = _reference(model, rng, grid)
        scorer = PartialScorer(seen, model, ref, parts, dims)
        xs = np.repeat(ref[None], 150, axis=0)
        d = list(dims)
        xs[:, d] = rng.uniform(model.low[d], model.high[d], (150, len(d)))
        xs[0] = ref                                 # the reference itself
        np.testing.assert_array_equal(scorer.counts(xs), part_counts(seen, model, xs))
        np.testing.assert_array_equal(scorer.log_likelihood(xs),
                                      log_likelihood(seen, model, xs))
        np.testing.assert_array_equal(scorer.log_likelihood(xs, coverage=500.0),
                                      log_likelihood(seen, model, xs, coverage=500.0))


@pytest.mark.parametrize("seed", [7, 8])
def test_limbs_over_their_whole_ranges_equal_full_counts(seed):
    """Column-by-column DO against the full kernel where overlaps are many: references and limbs
    drawn over the whole legal ranges (legs crossing, arms inside the torso and each other),
    on a grid offset from the voxel lattice."""
    rng = np.random.default_rng(seed)
    model = BodyModel()
    grid = VoxelGrid((-1013.0, -987.0, 7.0), 25.0, (80, 80, 80))
    seen = _observation(model, rng, grid)
    for dims, parts in BODY_PARTITIONS[1:]:
        for _ in range(3):
            ref = model.default_state()
            ref[3:] = rng.uniform(model.low[3:], model.high[3:])
            scorer = PartialScorer(seen, model, ref, parts, dims)
            xs = np.repeat(ref[None], 100, axis=0)
            d = list(dims)
            xs[:, d] = rng.uniform(model.low[d], model.high[d], (100, len(d)))
            got = scorer.counts(xs)
            np.testing.assert_array_equal(got, part_counts(seen, model, xs))
            assert got[:, :, 2].any()  # the case is about double occupancy


def test_limb_crossing_the_torso_changes_the_torso_double_occupancy():
    # the torso's DO comes only from the moving arm here: it must follow the arm exactly
    model = BodyModel()
    grid = VoxelGrid((-1000.0, -1000.0, 0.0), 20.0, (100, 100, 100))
    seen = _observation(model, np.random.default_rng(5), grid)
    ref = model.default_state()
    dims, parts = BODY_PARTITIONS[2]                # left arm
    scorer = PartialScorer(seen, model, ref, parts, dims)
    xs = np.repeat(ref[None], 2, axis=0)
    xs[1, dims[0]] = 45 * DEG                      # flexed forward…
    xs[1, dims[1]] = -40 * DEG                     # …and adducted across the chest
    counts = scorer.counts(xs)
    assert counts[1, 0, 2] != counts[0, 0, 2]
    np.testing.assert_array_equal(counts, part_counts(seen, model, xs))


def test_states_that_leave_the_reference_are_refused():
    model = BodyModel()
    grid = VoxelGrid((-1000.0, -1000.0, 0.0), 40.0, (50, 50, 50))
    seen = Measurement(np.zeros(grid.shape, bool), grid)
    dims, parts = BODY_PARTITIONS[1]
    scorer = PartialScorer(seen, model, model.default_state(), parts, dims)
    x = model.default_state()[None].copy()
    x[0, 0] += 1.0                                 # the root moved: not this scorer's job
    with pytest.raises(ValueError, match="outside dims"):
        scorer.counts(x)


@pytest.mark.parametrize("n_states", [1, 5, 40])
def test_the_one_thread_kernel_gives_the_parallel_ones_counts(n_states, monkeypatch):
    """A batch of fewer than ``thread_waits.SERIAL_BELOW`` states (a compass search's) is counted
    by ``partial_counts_serial``: the full counts, and the parallel kernel's, to the bit."""
    from voxelmocap import thread_waits

    rng = np.random.default_rng(n_states)
    model = BodyModel()
    grid = VoxelGrid((-1000.0, -1000.0, 0.0), 25.0, (80, 80, 80))
    seen = _observation(model, rng, grid)
    dims, parts = BODY_PARTITIONS[1]
    ref = _reference(model, rng, grid)
    xs = np.repeat(ref[None], n_states, axis=0)
    d = list(dims)
    xs[:, d] = rng.uniform(model.low[d], model.high[d], (n_states, len(d)))
    got = []
    for below in (0, 10 ** 6):                 # every batch in parallel, every one on one thread
        monkeypatch.setattr(thread_waits, "SERIAL_BELOW", below)
        got.append(PartialScorer(seen, model, ref, parts, dims).counts(xs))
    np.testing.assert_array_equal(got[0], got[1])
    np.testing.assert_array_equal(got[1], part_counts(seen, model, xs))
