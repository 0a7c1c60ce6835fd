import numpy as np
import pytest

from voxelmocap.body import (
    STATE_HIGH,
    STATE_LOW,
    STATE_NAMES,
    BodyModel,
    check_states,
    wrap_heading,
)
from voxelmocap.errors import InputError


def test_layout_matches_the_contract():
    assert len(STATE_NAMES) == 27 and len(set(STATE_NAMES)) == 27
    assert STATE_NAMES[:3] == ("root_x", "root_y", "root_z")
    groups = [n.split("_")[0] if not n.startswith(("l_", "r_")) else n.rsplit("_", 1)[0]
              for n in STATE_NAMES]
    # root 6, waist 3, neck 2, shoulders 3+3, elbows 1+1, hips 3+3, knees 1+1
    expected = (["root"] * 6 + ["waist"] * 3 + ["neck"] * 2 + ["l_shoulder"] * 3
                + ["r_shoulder"] * 3 + ["l", "r"] + ["l_hip"] * 3 + ["r_hip"] * 3 + ["l", "r"])
    assert groups == expected
    assert np.all(STATE_LOW < STATE_HIGH)
    model = BodyModel()
    assert model.n_dims == 27 and model.state_names == STATE_NAMES
    assert model.low.shape == model.high.shape == (27,)


def test_published_ranges_in_degrees():
    deg = dict(zip(STATE_NAMES, np.degrees(STATE_HIGH), strict=True))
    low = dict(zip(STATE_NAMES, np.degrees(STATE_LOW), strict=True))
    assert deg["l_elbow"] == pytest.approx(150) and low["l_elbow"] == 0
    assert deg["r_knee"] == pytest.approx(135) and low["r_knee"] == 0
    assert deg["l_hip_flex"] == pytest.approx(120) and low["l_hip_flex"] == pytest.approx(-30)
    assert deg["r_shoulder_flex"] == pytest.approx(180)
    assert STATE_HIGH[0] == 3000 and STATE_LOW[1] == -3000
    assert 150 <= STATE_LOW[2] < 500 and 1200 < STATE_HIGH[2] <= 2000


def test_default_state_is_legal_and_feet_on_floor():
    model = BodyModel()
    x = model.default_state()
    assert np.all((x >= model.low) & (x <= model.high))
    lm = model.landmarks(x[None])[0]
    assert lm[:, 2].min() == pytest.approx(0.045 * model.dimensions.height)


def test_check_states_rejects_nan_and_out_of_range():
    model = BodyModel()
    x = np.tile(model.default_state(), (3, 1))
    assert check_states(x).shape == (3, 27)
    bad = x.copy()
    bad[1, 17] = np.nan
    with pytest.raises(InputError, match="particle 1: l_elbow"):
        check_states(bad)
    with pytest.raises(InputError, match="not finite"):
        check_states(bad, legal=False)
    with pytest.raises(InputError, match="not finite"):
        check_states(bad, clip=True)
    out = x.copy()
    out[2, 25] = -0.1
    with pytest.raises(InputError, match="l_knee"):
        check_states(out)
    clipped = check_states(out, clip=True)
    assert clipped[2, 25] == 0.0 and out[2, 25] == -0.1
    assert check_states(out, legal=False)[2, 25] == -0.1
    with pytest.raises(InputError, match="expected shape"):
        check_states(np.zeros((3, 26)))


def test_wrap_heading_keeps_the_pose():
    model = BodyModel()
    x = model.default_state()
    x[3] = 3.5 * np.pi
    w = wrap_heading(x)
    assert -np.pi <= w[3] < np.pi
    np.testing.assert_allclose(model.landmarks(w[None]), model.landmarks(x[None]), atol=1e-9)
