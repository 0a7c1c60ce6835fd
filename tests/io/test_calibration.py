"""Calibration files: .cal, calibration folders with sizes.toml, anipose / Pose2Sim TOML."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from voxelmocap.camera import Camera
from voxelmocap.errors import InputError
from voxelmocap.io.calibration import (
    read_cal,
    read_calibration_toml,
    read_rig,
    read_sizes,
    write_cal,
    write_calibration_toml,
    write_rig,
)

RIG_DIR = __import__("pathlib").Path(__file__).resolve().parents[2] / "calib" / "humaneva_i_like"


def skewed_camera(rng, alpha=0.013):
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q *= np.sign(np.diag(r))
    if np.linalg.det(q) < 0:
        q[:, 0] *= -1
    return Camera("X", fc=(812.3, 790.1), cc=(322.4, 236.9), alpha_c=alpha,
                  kc=(-0.21, 0.093, 1.3e-3, -8.0e-4, -0.027), R=q, T=(120.0, -80.0, 4200.0))


def test_cal_round_trip(tmp_path):
    rng = np.random.default_rng(6)
    cam = skewed_camera(rng)
    cam = Camera("C2", cam.fc, cam.cc, cam.R, (100.0, 900.0, 4000.0), cam.alpha_c, cam.kc)
    path = tmp_path / "C2.cal"
    write_cal(cam, path)
    assert len(path.read_text().split()) == 22
    back = read_cal(path, check_facing=None)
    assert back.name == "C2"
    for attr in ("fc", "cc", "kc", "R", "T"):
        np.testing.assert_allclose(getattr(back, attr), getattr(cam, attr), rtol=1e-9)
    assert back.alpha_c == pytest.approx(cam.alpha_c)


def test_calibration_toml_round_trip_and_metres(tmp_path):
    rig = read_rig(RIG_DIR)
    path = tmp_path / "calibration.toml"
    write_calibration_toml(rig, path)
    back = read_calibration_toml(path)
    assert back.names == rig.names
    X = np.array([[0.0, 0.0, 1000.0], [300.0, -200.0, 1500.0]])
    for a, b in zip(rig, back, strict=True):
        np.testing.assert_allclose(b.project(X), a.project(X), atol=1e-6)
        assert b.size == a.size
    # Pose2Sim stores metres
    write_calibration_toml(rig, path, translation_scale=1000.0)
    back_m = read_calibration_toml(path, translation_scale=1000.0)
    np.testing.assert_allclose(back_m["C1"].T, rig["C1"].T, atol=1e-6)


def test_rig_folder_order_and_sizes():
    rig = read_rig(RIG_DIR)
    assert rig.names == ["C1", "C2", "C3", "BW1", "BW2", "BW3", "BW4"]
    assert all(cam.size == (640, 480) for cam in rig)
    assert rig.select(["bw2", "C1"]).names == ["BW2", "C1"]
    with pytest.raises(InputError, match="unknown camera"):
        rig.select(["C9"])


GOOD_CAL = RIG_DIR / "C1.cal"


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda v: v[:-1], "expected 22 numbers"),
        (lambda v: [*v, "1.0"], "expected 22 numbers"),
        (lambda v: ["abc", *v[1:]], "not a number"),
        (lambda v: [*v[:3], "nan", *v[4:]], "NaN or infinite"),
        (lambda v: [*v[:5], "inf", *v[6:]], "NaN or infinite"),
        (lambda v: [*v[:10], "2.0", *v[11:]], "not a rotation"),
        (lambda v: [*v[:19], "0", "0", "-5000"], "behind the camera"),
    ],
)
def test_bad_cal_files_name_the_file_and_problem(tmp_path, edit, message):
    values = GOOD_CAL.read_text().split()
    path = tmp_path / "C1.cal"
    path.write_text("\n".join(edit(values)))
    with pytest.raises(InputError, match=message) as info:
        read_cal(path)
    assert str(info.value).startswith(str(path))


def test_missing_cal_file(tmp_path):
    with pytest.raises(InputError, match="not found"):
        read_cal(tmp_path / "nope.cal")


@settings(max_examples=150, deadline=None)
@given(st.text(max_size=400))
def test_cal_parser_fuzz_never_crashes_otherwise(tmp_path_factory, text):
    path = tmp_path_factory.mktemp("fuzz") / "X.cal"
    path.write_text(text, encoding="utf-8")
    try:
        cam = read_cal(path, check_facing=None)
    except InputError:
        return
    assert np.all(np.isfinite(cam.R))


@settings(max_examples=100, deadline=None)
@given(st.lists(st.floats(allow_nan=True, allow_infinity=True, width=32), min_size=20,
                max_size=24))
def test_cal_parser_fuzz_on_numbers(tmp_path_factory, values):
    path = tmp_path_factory.mktemp("fuzz") / "X.cal"
    path.write_text("\n".join(repr(v) for v in values))
    try:
        cam = read_cal(path)
    except InputError as exc:
        assert str(exc).startswith(str(path))
        return
    # accepted: exactly 22 finite numbers, a rotation, and the capture centre in front
    assert len(values) == 22 and np.all(np.isfinite(values))
    np.testing.assert_allclose(cam.R @ cam.R.T, np.eye(3), atol=1e-3)
    assert cam.looks_at()


def test_rig_folder_round_trip_with_sizes_and_no_temporary_files(tmp_path):
    rig = read_rig(RIG_DIR)
    rig = type(rig)([rig["C1"].with_size((800, 600)), *list(rig)[1:]])
    write_rig(rig, tmp_path / "cal")
    assert sorted(p.name for p in (tmp_path / "cal").iterdir()) == sorted(
        [f"{n}.cal" for n in rig.names] + ["sizes.toml"])
    back = read_rig(tmp_path / "cal")
    assert back.names == rig.names
    assert back["C1"].size == (800, 600) and back["C2"].size == (640, 480)
    X = np.array([[0.0, 0.0, 1000.0], [300.0, -200.0, 1500.0]])
    for a, b in zip(rig, back, strict=True):
        np.testing.assert_allclose(b.project(X), a.project(X), atol=1e-6)
    assert read_rig(tmp_path / "cal", names=["bw2", "C1"]).names == ["BW2", "C1"]
    with pytest.raises(InputError, match="no calibration for camera 'C9'"):
        read_rig(tmp_path / "cal", names=["C9"])


@pytest.mark.parametrize("text, message", [
    ("C1 = [640]\n", "size of 'C1' must be"),
    ("C1 = [640.5, 480]\n", "size of 'C1' must be"),
    ("C1 = [0, 480]\n", "size of 'C1' must be"),
    ("C1 = '640x480'\n", "size of 'C1' must be"),
    ("C1 = [640, 480\n", "invalid TOML"),
])
def test_bad_sizes_toml(tmp_path, text, message):
    path = tmp_path / "sizes.toml"
    path.write_text(text)
    with pytest.raises(InputError, match=message) as info:
        read_sizes(path)
    assert str(info.value).startswith(str(path))


def test_sizes_toml_that_is_not_utf8(tmp_path):
    folder = tmp_path / "cal"
    write_rig(read_rig(RIG_DIR, names=["C1"]), folder)
    (folder / "sizes.toml").write_bytes("# caméra\nC1 = [640, 480]\n".encode("latin-1"))
    with pytest.raises(InputError, match="not UTF-8") as info:
        read_rig(folder)
    assert str(info.value).startswith(str(folder / "sizes.toml"))


def test_missing_or_empty_calibration_folder(tmp_path):
    with pytest.raises(InputError, match="calibration folder not found"):
        read_rig(tmp_path / "none")
    with pytest.raises(InputError, match=r"no \.cal camera files"):
        read_rig(tmp_path)


@pytest.mark.parametrize("edit, message", [
    (lambda t: t.replace("fisheye = false", "fisheye = true", 1), "fisheye"),
    (lambda t: t.replace("matrix = ", "matrx = ", 1), "no camera tables"),
    (lambda t: t.replace("rotation = ", "rotation_ = ", 1), "lacks 'rotation'"),
    (lambda t: t.replace("size = [", "size = [1e400, ", 1), "malformed"),
    (lambda t: t.replace("size = [", 'size = ["wide", ', 1), "malformed"),
])
def test_bad_calibration_toml(tmp_path, edit, message):
    path = tmp_path / "calibration.toml"
    write_calibration_toml(read_rig(RIG_DIR, names=["C1"]), path)
    path.write_text(edit(path.read_text()))
    with pytest.raises(InputError, match=message) as info:
        read_calibration_toml(path)
    assert str(info.value).startswith(str(path))
