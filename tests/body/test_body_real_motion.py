"""The body model fitted to real motion capture (``../shared/mocap``; skipped when absent)."""

import numpy as np
import pytest

from voxelmocap.body import BodyModel, fit_to_landmarks
from voxelmocap.joints import endpoints_to_landmarks


@pytest.mark.parametrize("clip_name", ["05_01.bvh", "dataset-1_punch_normal_002.bvh"])
def test_fit_follows_real_motion(mocap_dir, clip_name):
    from voxelmocap.io.bvh import read_bvh
    from voxelmocap.synth.skeletons import bvh_canonical_points, endpoints_from_canonical

    clip = read_bvh(mocap_dir / clip_name)
    landmarks = endpoints_to_landmarks(endpoints_from_canonical(bvh_canonical_points(clip)))
    model = BodyModel.from_landmarks(landmarks)
    assert 1400 < model.dimensions.height < 2000
    errors, previous = [], None
    for frame in np.linspace(0, len(landmarks) - 1, 8).astype(int):
        x = fit_to_landmarks(model, landmarks[frame], initial=previous)
        assert np.all((x >= model.low) & (x <= model.high))
        errors.append(np.linalg.norm(model.landmarks(x[None])[0] - landmarks[frame], axis=1))
        previous = x
    errors = np.array(errors)
    # a rigid torso cannot follow shoulder shrugs exactly: a few mm on average, a few cm at most
    assert errors.mean() < 8.0
    assert errors.max() < 50.0
