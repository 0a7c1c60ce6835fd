import math

import numpy as np
import pytest

from voxelmocap.body import BodyDimensions, BodyModel, frustum_volume
from voxelmocap.errors import InputError


def test_scaled_and_average():
    a = BodyModel.scaled(1780.0 / 2)
    b = BodyModel()
    for pa, pb in zip(a.parts, b.parts, strict=True):
        assert pa.L == pytest.approx(pb.L / 2) and pa.H == pytest.approx(pb.H / 2)
        assert pa.R == pytest.approx(pb.R)
    with pytest.raises(InputError):
        BodyModel.scaled(-3.0)


def test_from_landmarks_measures_the_skeleton():
    # hip offsets are measured against the torso axis: exact with a straight waist
    rng = np.random.default_rng(3)
    truth = BodyDimensions.average(1700.0).replace(upper_arm=(280.0, 300.0), thigh=(420.0, 430.0),
                                                   hip_drop=(50.0, 70.0))
    model = BodyModel(truth)
    moving = (np.arange(27) > 2) & ((np.arange(27) < 6) | (np.arange(27) > 8))
    states = model.clip(model.default_state() + rng.normal(0, 0.3, (20, 27)) * moving)
    lm = model.landmarks(states)
    lm[4] = np.nan  # a frame with a missing landmark is ignored
    got = BodyDimensions.from_landmarks(lm)
    for key in ("torso", "head", "upper_arm", "forearm", "thigh", "shin", "shoulder_offset",
                "shoulder_drop", "hip_offset", "hip_drop"):
        np.testing.assert_allclose(getattr(got, key), getattr(truth, key), atol=1e-6)
    assert got.height == pytest.approx((250 + 520 + 60 + 425 + 430) * 1700 / 1780 / 0.955, rel=0.03)
    with pytest.raises(InputError):
        BodyDimensions.from_landmarks(np.full((2, 15, 3), np.nan))


def test_frustum_volume_closed_form():
    # R = 1: elliptic cylinder; R = 0: elliptic cone
    assert frustum_volume(2.0, 3.0, 5.0, 1.0) == pytest.approx(math.pi * 2 * 3 * 5)
    assert frustum_volume(2.0, 3.0, 5.0, 0.0) == pytest.approx(math.pi * 2 * 3 * 5 / 3)
