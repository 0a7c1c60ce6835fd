"""The frame loop's body sizing: the median voxel height of the kept start's first frames."""

from __future__ import annotations

import types

import numpy as np
import pytest

from voxelmocap.body.shapes import BodyDimensions
from voxelmocap.config import TrackConfig, with_overrides
from voxelmocap.grid import VoxelGrid
from voxelmocap.run.bodies import sized_model
from voxelmocap.run.frame_loop import PassRun
from voxelmocap.score.likelihood import Measurement

GRID = VoxelGrid((-400.0, -400.0, 0.0), 20.0, (40, 40, 140))


def _column(voxels):
    """A column of ``voxels`` 20 mm voxels on the floor (its height ``20 × voxels`` mm, as
    ``tests/run/test_bodies.py`` checks); ``0`` gives a frame without voxels."""
    occupancy = np.zeros(GRID.shape, bool)
    occupancy[15:25, 15:25, 0:voxels] = True
    return Measurement(occupancy, GRID)


def _loop(columns, n, first_height=None):
    """A frame loop reduced to what sizing the body reads: its config, the kept start's
    observations and records, the body scaled to the first frame's height and its phrase."""
    height = 20.0 * columns[0] if first_height is None else first_height
    model, phrase = sized_model(height, 1)
    config = with_overrides(TrackConfig(), **{"init.body_height_frames": n})
    loop = types.SimpleNamespace(config=config, model=model, meta={"body_model": phrase},
                                 start_observations=[_column(v) for v in columns])
    records = [types.SimpleNamespace(frame=k + 1) for k in range(len(columns))]
    return loop, records


def test_the_body_is_scaled_to_the_median_height_of_the_first_frames():
    # frame 1 lost its head (1440 mm), frames 2-5 did not: the median of five is 1720 mm
    loop, records = _loop([72, 86, 86, 87, 85, 60], n=5)
    model = PassRun._median_height_body(loop, records)
    assert model.dimensions == BodyDimensions.average(1720.0)
    assert loop.meta["body_height_mm"] == 1720.0
    assert loop.meta["body_model"] == ("average adult scaled to 1720 mm, the median height of "
                                       "the voxels of frames 1–5 (the first: 1440 mm)")
    # an even count: the mean of the middle two
    loop, records = _loop([72, 86, 80, 60], n=4)
    assert PassRun._median_height_body(loop, records).dimensions.height == pytest.approx(
        1520.0)


def test_one_frame_the_same_median_or_another_body_leave_the_body_as_it_is():
    loop, records = _loop([72, 86, 86], n=1)                    # the default: frame 1 alone
    assert PassRun._median_height_body(loop, records) is None
    loop, records = _loop([86, 72, 86, 90], n=4)                # the median is frame 1's
    assert PassRun._median_height_body(loop, records) is None
    assert "body_height_mm" not in loop.meta
    loop, records = _loop([72, 86, 86], n=3)
    loop.meta["body_model"] = "the body of RUN/pass1/X.h5"      # a previous pass's body
    assert PassRun._median_height_body(loop, records) is None


def test_frames_without_voxels_are_left_out_and_more_frames_than_tracked_is_all():
    loop, records = _loop([72, 0, 86, 0, 86], n=10)
    assert PassRun._median_height_body(loop, records).dimensions.height == 1720.0
    loop, records = _loop([72, 0, 0], n=3, first_height=1440.0)
    assert PassRun._median_height_body(loop, records) is None   # only frame 1 measured
