import math

import numpy as np
import pytest
import tomli_w

from voxelmocap.body import BodyDimensions, BodyModel, frustum_volume
from voxelmocap.errors import InputError

EXAMPLE = """
format = "voxelmocap-body-1"

[subject]
name = "S1"
height_mm = 1780.0

[lengths_mm]
torso = 520.0
head = 250.0
shoulder_offset = [185.0, 180.0]
shoulder_drop = [30.0, 0.0]
hip_offset = [95.0, 95.0]
hip_drop = [60.0, 60.0]
upper_arm = [290.0, 295.0]
forearm = [255.0, 255.0]
thigh = [440.0, 445.0]
shin = [430.0, 430.0]

[widths_mm]
torso = [160.0, 105.0]
chest = [170.0, 110.0]
head = [80.0, 95.0]
upper_arm = [50.0, 50.0]
forearm = [42.0, 42.0]
thigh = [80.0, 80.0]
shin = [55.0, 55.0]
"""


def write(tmp_path, text):
    path = tmp_path / "S1_body.toml"
    path.write_text(text)
    return path


def test_reads_the_contract_example(tmp_path):
    model = BodyModel.from_file(write(tmp_path, EXAMPLE))
    d = model.dimensions
    assert d.height == 1780.0 and d.upper_arm == (290.0, 295.0) and d.shoulder_drop == (30.0, 0.0)
    parts = {p.name: p for p in model.parts}
    assert parts["torso"].H == 160 and parts["torso"].W == 105 and parts["torso"].L == 520
    assert parts["torso"].R == pytest.approx(0.5 * (170 / 160 + 110 / 105))
    assert parts["r_upper_arm"].L == 295 and parts["l_upper_arm"].R == pytest.approx(42 / 50)
    assert parts["r_thigh"].L == 445 and parts["l_shin"].H == 55
    # the bones of the model have the file's lengths
    lm = model.landmarks(model.default_state()[None])[0]
    assert np.linalg.norm(lm[6] - lm[5]) == pytest.approx(295.0)  # r shoulder → r elbow
    assert np.linalg.norm(lm[13] - lm[12]) == pytest.approx(430.0)
    assert lm[5, 0] - lm[0, 0] == pytest.approx(180.0) and lm[5, 2] == pytest.approx(lm[0, 2])


def test_widths_optional_defaults_scale_with_height(tmp_path):
    text = EXAMPLE.split("[widths_mm]")[0].replace("1780.0", "1602.0")
    d = BodyDimensions.from_file(write(tmp_path, text))
    assert d.w_thigh == pytest.approx((72.0, 72.0))  # 80 · 0.9
    assert d.w_torso == pytest.approx((144.0, 94.5))


@pytest.mark.parametrize("old, new, match", [
    ("torso = 520.0", "", "lengths_mm.torso"),
    ("head = 250.0", "head = -250.0", "lengths_mm.head"),
    ("head = 250.0", "head = 0.0", "lengths_mm.head"),
    ("head = 250.0", "head = nan", "lengths_mm.head"),
    ("head = 250.0", "head = inf", "lengths_mm.head"),
    ("head = 250.0", 'head = "250"', "lengths_mm.head must be a number"),
    ("head = 250.0", "head = true", "lengths_mm.head must be a number"),
    ("thigh = [440.0, 445.0]", "thigh = [440.0]", "lengths_mm.thigh"),
    ("thigh = [440.0, 445.0]", "thigh = [440.0, -1.0]", r"lengths_mm.thigh\[1\]"),
    ("shoulder_drop = [30.0, 0.0]", "shoulder_drop = [-3.0, 0.0]", "shoulder_drop"),
    ("shin = [430.0, 430.0]", "shin = [430.0, 430.0]\nneck = 100.0", "lengths_mm.neck"),
    ("[widths_mm]", "[widths_mm]\nfoot = [1.0, 1.0]", "widths_mm.foot"),
    ("chest = [170.0, 110.0]", "chest = [0.0, 110.0]", "widths_mm.chest"),
    ('format = "voxelmocap-body-1"', 'format = "other"', "format"),
    ("height_mm = 1780.0", "", "subject.height_mm"),
    ("height_mm = 1780.0", "height_mm = 1780.0\nweight = 70", "subject.weight"),
    ("[subject]", "[extra]\na = 1\n[subject]", "unknown key 'extra'"),
])
def test_bad_files_name_file_and_key(tmp_path, old, new, match):
    assert old in EXAMPLE
    path = write(tmp_path, EXAMPLE.replace(old, new, 1))
    with pytest.raises(InputError, match=match) as info:
        BodyModel.from_file(path)
    assert str(info.value).startswith(str(path))


def test_unreadable_and_invalid_toml(tmp_path):
    with pytest.raises(InputError, match="file not found"):
        BodyModel.from_file(tmp_path / "missing.toml")
    with pytest.raises(InputError, match="invalid TOML"):
        BodyModel.from_file(write(tmp_path, "torso = = 1"))


def test_to_dict_round_trip(tmp_path):
    d = BodyDimensions.average(1650.0).replace(upper_arm=(270.0, 280.0))
    path = tmp_path / "x_body.toml"
    path.write_text(tomli_w.dumps(d.to_dict("X")))
    assert BodyDimensions.from_file(path) == d


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
