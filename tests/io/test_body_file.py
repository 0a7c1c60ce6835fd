"""The body file <Subject>_body.toml: contract example, one-line errors, writer ↔ reader."""

import json

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from voxelmocap.body import BodyDimensions, BodyModel
from voxelmocap.errors import InputError
from voxelmocap.io.body_file import read_body_file, write_body_file
from voxelmocap.io.toml import read_toml

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
    model = BodyModel(read_body_file(write(tmp_path, EXAMPLE)))
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
    d = read_body_file(write(tmp_path, text))
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
        read_body_file(path)
    assert str(info.value).startswith(str(path))


def test_unreadable_and_invalid_toml(tmp_path):
    with pytest.raises(InputError, match="file not found"):
        read_body_file(tmp_path / "missing.toml")
    with pytest.raises(InputError, match="invalid TOML"):
        read_body_file(write(tmp_path, "torso = = 1"))


def test_write_read_round_trip(tmp_path):
    d = BodyDimensions.average(1650.0).replace(upper_arm=(270.0, 280.0), shoulder_drop=(0.0, 12.5),
                                               w_head=(81.25, 96.0))
    path = tmp_path / "x_body.toml"
    write_body_file(path, d, "X")
    assert read_body_file(path) == d
    assert read_toml(path)["subject"] == {"name": "X", "height_mm": 1650.0}
    assert [p.name for p in tmp_path.iterdir()] == ["x_body.toml"]  # no temporary file left


def test_the_written_file_is_the_contract_example(tmp_path):
    # the writer writes the documented layout: same tables, keys, order and values
    d = read_body_file(write(tmp_path, EXAMPLE))
    write_body_file(tmp_path / "back.toml", d, "S1")
    back, example = read_toml(tmp_path / "back.toml"), read_toml(tmp_path / "S1_body.toml")
    assert json.dumps(back) == json.dumps(example)


def test_body_file_that_is_not_utf8(tmp_path):
    path = tmp_path / "S1_body.toml"
    path.write_bytes(("# Körper\n" + EXAMPLE).encode("latin-1"))
    with pytest.raises(InputError, match="not UTF-8") as info:
        read_body_file(path)
    assert str(info.value).startswith(str(path))


@settings(max_examples=200, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(cut=st.integers(0, len(EXAMPLE)), junk=st.binary(max_size=6))
def test_mutated_body_files_parse_or_raise_input_error(tmp_path, cut, junk):
    data = EXAMPLE.encode()
    path = tmp_path / "S1_body.toml"
    path.write_bytes(data[:cut] + junk + data[cut + len(junk):])
    try:
        d = read_body_file(path)
    except InputError as exc:
        assert str(exc).startswith(str(path)) and "\n" not in str(exc)
        return
    assert d.height > 0 and min(d.upper_arm) > 0
