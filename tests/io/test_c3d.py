"""The C3D writer on its own: invalid points, screen axes, read back by ``c3d`` and ``ezc3d``."""

import warnings

import numpy as np
import pytest

from voxelmocap.io.c3d import write_c3d

c3d = pytest.importorskip("c3d")


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
