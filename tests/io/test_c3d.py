"""``io.c3d.write_c3d`` read back by two C3D readers: ``ezc3d`` (C++, independent of the writer)
and the ``c3d`` package's reader (the residual byte, which ezc3d misreads in float files:
pyomeca/ezc3d#386): invalid points, screen axes, seeded points with gaps and residual edge cases.
The exports of a tracked run are in ``test_exports.py``.
"""

import warnings

import numpy as np
import pytest

from voxelmocap.io.c3d import RESIDUAL_RANGE_MM, write_c3d

c3d = pytest.importorskip("c3d")
ezc3d = pytest.importorskip("ezc3d")


def _read_c3d(path):
    """(frame numbers, (F, M, 5) points as stored, POINT:X_SCREEN/Y_SCREEN) with ``c3d``."""
    with open(path, "rb") as handle, warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # "No analog data found in file."
        reader = c3d.Reader(handle)
        # check_nan=False: the coordinates exactly as the file holds them
        frames = [(i, p.copy()) for i, p, _ in reader.read_frames(check_nan=False)]
        screen = reader.get_screen_axis()
    return [i for i, _ in frames], np.array([p for _, p in frames]), screen


def _walk(rng, n=6, m=4):
    return 1000.0 + 300.0 * rng.standard_normal((n, m, 3))


def test_invalid_points_are_written_as_zeros(tmp_path):
    rng = np.random.default_rng(0)
    x = _walk(rng)
    invalid = np.zeros(x.shape[:2], bool)
    invalid[2, 1] = invalid[3, 1] = invalid[4, 0] = True  # after frames where they were valid
    invalid[5] = True  # a frame without a person
    x[invalid] = np.nan
    path = write_c3d(tmp_path / "a.c3d", x, ["a", "b", "c", "d"], frame_rate=60.0,
                     first_frame=3, residuals=np.full(x.shape[:2], 7.0))
    frames, points, _ = _read_c3d(path)
    assert frames == list(range(3, 9))
    # the C3D convention: an invalid point has residual −1 and zero coordinates, never the
    # coordinates of an earlier frame (readers that ignore the residual would draw those)
    np.testing.assert_array_equal(points[invalid][:, :3], 0.0)
    np.testing.assert_array_equal(points[..., 3], np.where(invalid, -1.0, 7.0))
    np.testing.assert_allclose(points[~invalid][:, :3], x[~invalid], rtol=0, atol=1e-3)

    ezc3d = pytest.importorskip("ezc3d")
    e = ezc3d.c3d(str(path))
    xyz = e["data"]["points"][:3].transpose(2, 1, 0)
    # ezc3d reports the invalid points as NaN (residual < 0) and the others as written
    np.testing.assert_array_equal(np.isnan(xyz).any(axis=2), invalid)
    np.testing.assert_allclose(xyz[~invalid], x[~invalid], rtol=0, atol=1e-3)
    assert np.all(e["data"]["meta_points"]["residuals"][0].T[invalid] == -1)
    # and its raw view of the file (no NaN conversion) holds zeros there too
    raw = np.frombuffer(path.read_bytes(), dtype="<f4")
    start = (int(e["parameters"]["POINT"]["DATA_START"]["value"][0]) - 1) * 128  # 512-byte blocks
    block = raw[start:start + x.size // 3 * 4].reshape(*x.shape[:2], 4)
    np.testing.assert_array_equal(block[invalid][:, :3], 0.0)


@pytest.mark.parametrize(("axes", "screen"), [("world", ("+X", "+Z")), ("y_up", ("+X", "+Y"))])
def test_screen_axes_say_which_axis_is_up(tmp_path, axes, screen):
    x = _walk(np.random.default_rng(1), n=2, m=1)
    path = write_c3d(tmp_path / "a.c3d", x, ["a"], frame_rate=50.0, axes=axes)
    assert _read_c3d(path)[2] == screen
    ezc3d = pytest.importorskip("ezc3d")
    point = ezc3d.c3d(str(path))["parameters"]["POINT"]
    assert (point["X_SCREEN"]["value"][0], point["Y_SCREEN"]["value"][0]) == screen
NAMES = ["head", "l wrist", "pelvis"]


def _points(seed=0, n=4):
    """(n, 3, 3) mm within 3 m of the origin, two points missing."""
    x = np.random.default_rng(seed).uniform(-3000.0, 3000.0, (n, 3, 3))
    x[1, 2] = np.nan
    x[3, 0, 1] = np.nan                     # one coordinate missing: the point is invalid
    return x


def _read_c3d_package(path):
    with open(path, "rb") as handle, warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # "No analog data found in file."
        reader = c3d.Reader(handle)
        frames = [(i, p.copy()) for i, p, _ in reader.read_frames()]
        labels = [s.strip() for s in reader.point_labels]
        units = reader.get("POINT:UNITS").string_value.strip()
        return reader.point_rate, labels, units, frames


def test_points_labels_rate_and_first_frame(tmp_path):
    x = _points()
    path = write_c3d(tmp_path / "walk.c3d", x, NAMES, frame_rate=120.0, first_frame=7)
    assert path == tmp_path / "walk.c3d" and [p.name for p in tmp_path.iterdir()] == ["walk.c3d"]
    assert path.stat().st_size % 512 == 0                  # C3D is written in 512-byte blocks

    e = ezc3d.c3d(str(path))
    assert e["parameters"]["POINT"]["LABELS"]["value"] == NAMES
    assert e["parameters"]["POINT"]["RATE"]["value"][0] == 120.0
    assert e["parameters"]["POINT"]["UNITS"]["value"][0].strip() == "mm"
    assert e["header"]["points"]["first_frame"] + 1 == 7           # ezc3d counts from 0
    xyz = e["data"]["points"][:3].transpose(2, 1, 0)
    invalid = np.isnan(x).any(axis=2)
    assert np.array_equal(np.isnan(xyz).all(axis=2), invalid)       # gaps read as gaps
    # 32-bit floats: below 0.001 mm within 8 m of the origin
    np.testing.assert_allclose(xyz[~invalid], x[~invalid], rtol=0, atol=1e-3)

    rate, labels, units, frames = _read_c3d_package(path)
    assert (rate, labels, units) == (120.0, NAMES, "mm")
    assert [i for i, _ in frames] == [7, 8, 9, 10]
    points = np.array([p for _, p in frames])
    np.testing.assert_allclose(points[:, :, :3][~invalid], x[~invalid], rtol=0, atol=1e-3)


def test_the_residual_is_the_spread_in_whole_mm_within_its_byte(tmp_path):
    """Rounded to whole mm and clipped to 1…255 (0 would mean "interpolated"); NaN (unknown) is
    the lower end; an invalid point is −1 whatever its spread."""
    x = _points(seed=1)
    spread = np.array([[0.2, 300.0, np.nan],
                       [17.4, 17.6, 5.0],          # (1, 2) is invalid
                       [1.0, 254.5, 3.0],
                       [4.0, 5.0, 6.0]])           # (3, 0) is invalid
    expected = np.array([[1, 255, 1], [17, 18, -1], [1, 254, 3], [-1, 5, 6]], float)
    assert RESIDUAL_RANGE_MM == (1.0, 255.0)
    path = write_c3d(tmp_path / "a.c3d", x, NAMES, frame_rate=50.0, residuals=spread)
    *_, frames = _read_c3d_package(path)
    np.testing.assert_array_equal(np.array([p for _, p in frames])[:, :, 3], expected)
    # no residuals given: every valid point at the lower end
    path = write_c3d(tmp_path / "b.c3d", x, NAMES, frame_rate=50.0)
    *_, frames = _read_c3d_package(path)
    np.testing.assert_array_equal(np.array([p for _, p in frames])[:, :, 3],
                                  np.where(np.isnan(x).any(axis=2), -1.0, 1.0))


@pytest.mark.parametrize("shape, names", [((0, 3, 3), NAMES), ((2, 3, 2), NAMES),
                                          ((2, 3, 3), NAMES[:2]), ((3, 3), NAMES)])
def test_positions_of_the_wrong_shape_are_refused_before_writing(tmp_path, shape, names):
    with pytest.raises(ValueError, match="write_c3d: positions must be"):
        write_c3d(tmp_path / "a.c3d", np.zeros(shape), names, frame_rate=50.0)
    assert list(tmp_path.iterdir()) == []
