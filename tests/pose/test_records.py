"""``pose.records``: the observer that collects record fields, and the record of a frame without a
person.

The absent frame's record is checked against the model's own landmarks and endpoints, the
per-voxel reference count of the part scores (``score.likelihood.part_scores_reference``) and
the likelihood's closed form ``−½ Σ_parts Σ_terms ρ² / σ²``.
"""

import dataclasses

import numpy as np
import pytest

from voxelmocap.body import BodyModel
from voxelmocap.grid import VoxelGrid
from voxelmocap.pose.records import Collector, FrameRecord, absent_record
from voxelmocap.score.likelihood import Measurement, part_scores_reference, rasterise

MODEL = BodyModel()


def _record(frame, rng):
    return FrameRecord(frame=frame, state=rng.normal(size=27), map_state=rng.normal(size=27),
                       landmarks=rng.normal(size=(15, 3)), endpoints=rng.normal(size=(20, 3)),
                       part_scores=rng.random((10, 4)), ess=rng.random(3), betas=rng.random(3),
                       seconds=float(rng.random()), log_likelihood=float(rng.normal()),
                       observed=bool(frame % 2))


def test_the_collector_stacks_the_chosen_fields_of_every_record():
    rng = np.random.default_rng(4)
    records = [_record(f, rng) for f in (3, 4, 9)]
    chosen = Collector("frame", "landmarks", "observed")
    every = Collector()
    for r in records:
        chosen(r, tracker=None)
        every(r, None)
    out = chosen.stacked()
    assert list(out) == ["frame", "landmarks", "observed"]
    np.testing.assert_array_equal(out["frame"], [3, 4, 9])
    assert out["landmarks"].shape == (3, 15, 3)
    np.testing.assert_array_equal(out["landmarks"], np.stack([r.landmarks for r in records]))
    np.testing.assert_array_equal(out["observed"], [True, False, True])
    everything = every.stacked()
    assert list(everything) == [f.name for f in dataclasses.fields(FrameRecord)]
    np.testing.assert_array_equal(everything["part_scores"],
                                  np.stack([r.part_scores for r in records]))
    assert everything["note"].tolist() == ["", "", ""]
    assert Collector("seconds").stacked()["seconds"].shape == (0,)


def test_a_collector_of_an_unknown_field_is_refused():
    with pytest.raises(ValueError, match="Collector: FrameRecord has no field 'nope'"):
        Collector("frame", "nope", "also_not")


@pytest.mark.parametrize("occupied", [True, False])
def test_an_absent_frame_repeats_the_state_and_scores_it(occupied):
    """The record of a frame without a person: the state repeated (a copy), the pose it draws,
    its part scores against the frame's voxels (none, or a body elsewhere), NaN ESS and β per
    layer, not observed, and why."""
    grid = VoxelGrid((-1000.0, -1000.0, 0.0), 40.0, (50, 50, 50))
    rng = np.random.default_rng(8)
    state = MODEL.clip(MODEL.default_state() + rng.normal(size=(1, 27)) * np.r_[
        np.full(3, 80.0), np.full(24, 0.25)])[0]
    elsewhere = MODEL.default_state()
    elsewhere[0] += 300.0
    occupancy = (rasterise(MODEL, elsewhere[None], grid) > 0) if occupied \
        else np.zeros(grid.shape, bool)
    observation = Measurement(occupancy, grid)
    variances = np.array([0.5, 0.25, 2.0, 4.0])
    record = absent_record(MODEL, observation, state, frame=np.int64(12), n_layers=5,
                           variances=variances, seconds=0.25)
    assert record.frame == 12 and type(record.frame) is int
    np.testing.assert_array_equal(record.state, state)
    np.testing.assert_array_equal(record.map_state, state)
    assert record.state is not state and record.map_state is not record.state
    np.testing.assert_allclose(record.landmarks, MODEL.landmarks(state[None])[0], atol=1e-9)
    np.testing.assert_allclose(record.endpoints, MODEL.endpoints(state[None])[0], atol=1e-9)
    scores = part_scores_reference(observation, MODEL, state[None])[0]
    np.testing.assert_allclose(record.part_scores, scores, rtol=0, atol=1e-12)
    if not occupied:          # no voxel anywhere: every part all Empty, nothing Out
        np.testing.assert_array_equal(record.part_scores[:, [0, 2]], np.tile([0.0, 1.0], (10, 1)))
    assert record.log_likelihood == pytest.approx(-0.5 * np.sum(scores ** 2 / variances),
                                                  rel=1e-12)
    assert record.ess.shape == record.betas.shape == (5,)
    assert np.isnan(record.ess).all() and np.isnan(record.betas).all()
    assert record.observed is False and record.note == "no person in view"
    assert record.seconds == 0.25
    assert np.isnan(record.landmark_spread).all() and np.isnan(record.confidence).all()
