"""``run.bodies``: which body a run tracks with, and the body a result on disk tracked.

The bodies are checked against where they come from (a body file, the lengths of the body whose
landmarks the ground truth holds, the average adult scaled), the voxels' height against columns
of known extent, and the tracked body against results written here with seeded states.
"""

import types

import h5py
import numpy as np
import pytest

from voxelmocap.body import BodyModel
from voxelmocap.body.shapes import BodyDimensions
from voxelmocap.errors import InputError
from voxelmocap.grid import VoxelGrid
from voxelmocap.io.results import TrackResult, write_result
from voxelmocap.run.bodies import (
    HEIGHT_RANGE_MM,
    body_model_for,
    dimensions_json,
    model_from_attrs,
    sized_model,
    tracked_body,
    tracked_in_memory,
    voxel_height,
)
from voxelmocap.score.likelihood import Measurement

LENGTHS = ("torso", "head", "upper_arm", "forearm", "thigh", "shin", "shoulder_offset")


def _sequence(**kw):
    """A stand-in for a sequence: what the bodies read of it."""
    base = dict(subject="S1", name="Walking_1", action="Walking", trial=1, body_file=None,
                frame_numbers=np.arange(1, 9))
    return types.SimpleNamespace(**{**base, **kw})


def _truth_of(model, n=5, seed=0, disabled=()):
    """Ground truth (``endpoints``, ``enabled``) of ``n`` random legal poses of ``model``; the
    rows ``disabled`` hold nonsense with their endpoints disabled."""
    rng = np.random.default_rng(seed)
    states = model.clip(model.default_state() + rng.normal(size=(n, 27)) * np.r_[
        np.full(3, 100.0), np.full(24, 0.3)])
    endpoints = model.endpoints(states)
    enabled = np.ones((n, 20), bool)
    for row in disabled:
        endpoints[row] = rng.normal(size=(20, 3)) * 5000.0
        enabled[row, 3] = False
    return types.SimpleNamespace(endpoints=endpoints, enabled=enabled)


def _same_lengths(a, b, rtol=1e-9):
    for key in LENGTHS:
        np.testing.assert_allclose(getattr(a.dimensions, key), getattr(b.dimensions, key),
                                   rtol=rtol, err_msg=key)


# ---------------------------------------------------------------------- where a body comes from
def test_the_body_file_wins_then_the_ground_truth_then_the_average_adult(tmp_path):
    from voxelmocap.io.body_file import write_body_file

    tall = BodyModel(BodyDimensions.average(1930.0))
    truth = _truth_of(tall, disabled=(1, 3))
    # the ground truth: the lengths of the body it shows, measured on the frames fully enabled
    model, why = body_model_for(_sequence(), truth)
    assert why == "limb lengths measured from the ground truth"
    _same_lengths(model, tall)
    # no frame fully enabled, or none at all: the average adult
    none = types.SimpleNamespace(endpoints=truth.endpoints, enabled=truth.enabled & False)
    for gt in (none, None):
        model, why = body_model_for(_sequence(), gt)
        assert why == "average adult (no body file or ground truth)"
        assert model.dimensions == BodyDimensions.average()
    # a body file wins over the ground truth
    short = BodyDimensions.average(1550.0)
    path = tmp_path / "S1_body.toml"
    write_body_file(path, short, "S1")
    model, why = body_model_for(_sequence(body_file=path), truth)
    assert why == "subject body file S1_body.toml"
    _same_lengths(model, BodyModel(short))


def test_the_sized_body_is_the_average_adult_scaled():
    model, why = sized_model(1712.4, 5)
    assert model.dimensions == BodyDimensions.average(1712.4)
    assert why == "average adult scaled to 1712 mm, the height of the voxels of frame 5"
    assert sized_model(1712.4, None)[1] == "average adult scaled to 1712 mm, the height of the voxels"


@pytest.mark.parametrize("voxels, expected", [(83, 83 * 20.0), (40, HEIGHT_RANGE_MM[0]),
                                              (120, HEIGHT_RANGE_MM[1])])
def test_the_voxels_height_is_their_extent_within_a_standing_range(voxels, expected):
    """A column of ``voxels`` voxels of 20 mm standing on the floor is that many × 20 mm high;
    outside the plausible standing heights the range's end is taken."""
    grid = VoxelGrid((-400.0, -400.0, 0.0), 20.0, (40, 40, 140))
    occupancy = np.zeros(grid.shape, bool)
    occupancy[15:25, 15:25, 2:2 + voxels] = True
    assert voxel_height(Measurement(occupancy, grid), 3) == expected
    with pytest.raises(InputError, match="frame 7: no occupied voxel"):
        voxel_height(Measurement(np.zeros(grid.shape, bool), grid), 7)


# ---------------------------------------------------------------------- the body a result records
def test_the_body_a_result_records_in_each_of_its_forms():
    seq = _sequence()
    truth_body = BodyModel(BodyDimensions.average(1930.0))
    truth = _truth_of(truth_body)
    fitted = BodyDimensions.average(1640.0)
    # every length recorded (a fitted body, a previous pass's) wins over everything else
    attrs = {"body_dimensions": dimensions_json(BodyModel(fitted)), "body_height_mm": 1800.0,
             "body_model": "average adult scaled to 1800 mm, the height of the voxels"}
    assert model_from_attrs(attrs, seq, truth).dimensions == fitted
    # the average adult scaled to the recorded height
    del attrs["body_dimensions"]
    assert model_from_attrs(attrs, seq, truth).dimensions == BodyDimensions.average(1800.0)
    # a height recorded for another kind of body, or nothing: where the run took it from
    for attrs in ({"body_height_mm": 1800.0, "body_model": "subject body file S1_body.toml"},
                  {"body_dimensions": ""}, {}):
        _same_lengths(model_from_attrs(attrs, seq, truth), truth_body)
        assert model_from_attrs(attrs, seq, None).dimensions == BodyDimensions.average()


def test_recorded_dimensions_that_are_not_a_body_are_refused():
    with pytest.raises(InputError, match=r"^R\.h5: not a body's dimensions"):
        model_from_attrs({"body_dimensions": '{"height": 1700}'}, _sequence(), source="R.h5")
    with pytest.raises(InputError, match="not a body's dimensions"):
        model_from_attrs({"body_dimensions": "[1, 2"}, _sequence())


# ---------------------------------------------------------------------- a previous run's body
def _result(frames, *, observed=None, n_dims=27, seed=0, **attrs):
    n = len(frames)
    rng = np.random.default_rng(seed)
    base = {"subject": "S1", "action": "Walking", "trial": 1, "config": "", "seed": 0}
    return TrackResult(
        frames=np.asarray(frames), state=rng.normal(size=(n, n_dims)),
        landmarks=rng.normal(size=(n, 15, 3)), endpoints=rng.normal(size=(n, 20, 3)),
        part_scores=rng.random((n, 10, 4)), ess=rng.random((n, 2)), betas=rng.random((n, 2)),
        seconds=rng.random(n), log_likelihood=rng.normal(size=n),
        map_state=rng.normal(size=(n, n_dims)), state_names=[f"s{i}" for i in range(n_dims)],
        part_names=[f"p{i}" for i in range(10)], attrs={**base, **attrs}, observed=observed)


def test_the_tracked_body_is_the_observed_frames_of_this_sequence_in_order(tmp_path):
    """Frames without the person and frames the sequence does not have are left out; the rest
    come sorted, with their states; the run folder, a pass folder or the file itself name it."""
    frames = np.array([5, 2, 7, 12, 3, 1])
    observed = np.array([True, True, False, True, True, True])
    result = _result(frames, observed=observed, body_dimensions=dimensions_json(BodyModel()))
    path = tmp_path / "RUN" / "S1" / "Walking_1.h5"
    write_result(path, result)
    seq = _sequence()
    body = tracked_body(tmp_path / "RUN", seq)
    keep = [5, 1, 4, 0]                              # frames 1, 2, 3, 5 (7 unseen, 12 beyond 8)
    np.testing.assert_array_equal(body.frames, frames[keep])
    np.testing.assert_array_equal(body.states, result.state[keep])
    assert body.source == str(path.resolve())
    assert tracked_body(path, seq).source == body.source                      # the file itself
    assert tracked_body(tmp_path / "RUN" / "S1", seq).source == body.source   # RUN/<trial>
    same = tracked_in_memory(body.model, frames, result.state, observed, seq, path)
    np.testing.assert_array_equal(same.frames, body.frames)
    np.testing.assert_array_equal(same.states, body.states)


def test_a_result_that_gives_no_body_is_refused_with_its_reason(tmp_path):
    seq = _sequence()
    with pytest.raises(InputError, match="no result of S1/Walking_1 here"):
        tracked_body(tmp_path, seq)
    cases = [
        ({"action": "Jog"}, {}, "a result of action 'Jog', not of this run's 'Walking'"),
        ({"subject": "S2"}, {}, "a result of subject 'S2', not of this run's 'S1'"),
        ({"trial": 2}, {}, "a result of trial 2, not of this run's 1"),
        ({"body_dimensions": "{}"}, {}, "body_dimensions: not a body's dimensions"),
        ({}, {"observed": np.array([True, False, False, False])},
         "1 frame(s) of this sequence with the person tracked: a plate needs at least 2"),
        ({}, {"frames": [1, 20, 30, 40]},
         "1 frame(s) of this sequence with the person tracked: a plate needs at least 2"),
        ({}, {"n_dims": 26}, "states of 26 parameters, the body model has 27"),
    ]
    for k, (attrs, kw, message) in enumerate(cases):
        path = tmp_path / f"r{k}.h5"
        write_result(path, _result(kw.pop("frames", [1, 2, 3, 4]), **kw, **attrs))
        with pytest.raises(InputError) as info:
            tracked_body(path, seq)
        assert info.value.problem.startswith(message) and str(info.value).startswith(str(path))


def test_a_result_without_dimensions_is_drawn_with_the_body_its_run_measured(tmp_path):
    """A run that measured its body on the ground truth recorded no dimensions: the body is the
    ground truth's again, not the average adult."""
    tall = BodyModel(BodyDimensions.average(1930.0))
    path = tmp_path / "r.h5"
    write_result(path, _result([1, 2, 3]))
    with h5py.File(path, "r") as f:
        assert "body_dimensions" not in f.attrs
    _same_lengths(tracked_body(path, _sequence(), _truth_of(tall)).model, tall)
    assert tracked_body(path, _sequence()).model.dimensions == BodyDimensions.average()
