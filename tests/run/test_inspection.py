"""inspection.result_body_model: overlays draw the body the run tracked with."""

import json
from dataclasses import asdict
from types import SimpleNamespace

import numpy as np
import pytest

from voxelmocap.body import BodyDimensions, BodyModel
from voxelmocap.errors import InputError
from voxelmocap.run.inspection import result_body_model

SEQ = SimpleNamespace(body_file=None)      # no body file, no ground truth: the average adult


def _dims(model):
    return asdict(model.dimensions)


def test_a_voxel_sized_run_is_drawn_at_its_recorded_height():
    result = SimpleNamespace(attrs={
        "body_height_mm": 1680.0,
        "body_model": "average adult scaled to 1680 mm, the height of the voxels of frame 1"})
    model = result_body_model(SEQ, result)
    assert model.dimensions.height == pytest.approx(1680.0)
    assert _dims(model) == _dims(BodyModel.scaled(1680.0))
    assert _dims(model) != _dims(BodyModel())           # not the unscaled average adult


def test_fitted_dimensions_are_read_back_exactly():
    dims = BodyDimensions.average(1733.0)
    fitted = {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(dims).items()}
    fitted["thigh"] = [455.5, 449.0]
    result = SimpleNamespace(attrs={"body_dimensions": json.dumps(fitted), "body_height_mm": 1733.0,
                                    "body_model": "average adult scaled to 1733 mm; fitted"})
    model = result_body_model(SEQ, result)
    assert model.dimensions.thigh == (455.5, 449.0)
    assert model.dimensions.height == pytest.approx(1733.0)
    bad = SimpleNamespace(attrs={"body_dimensions": json.dumps({"height": 1.0, "nose": 3})})
    with pytest.raises(InputError, match="body_dimensions"):
        result_body_model(SEQ, bad)


def test_without_a_recorded_size_it_is_the_runs_own_rule():
    model = result_body_model(SEQ, SimpleNamespace(attrs={"body_model": "average adult"}))
    assert _dims(model) == _dims(BodyModel())
    assert np.isfinite(model.dimensions.height)
