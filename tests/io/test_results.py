import numpy as np
import pytest

from voxelmocap.errors import InputError
from voxelmocap.io.results import TrackResult, read_result, write_result


def make_result(n=4, seed=0):
    rng = np.random.default_rng(seed)
    return TrackResult(
        frames=np.arange(6, 6 + n), state=rng.normal(size=(n, 27)),
        landmarks=rng.normal(size=(n, 15, 3)), endpoints=rng.normal(size=(n, 20, 3)),
        part_scores=rng.random((n, 10, 4)), ess=rng.random((n, 6)), betas=rng.random((n, 6)),
        seconds=rng.random(n), log_likelihood=rng.normal(size=n),
        map_state=rng.normal(size=(n, 27)), state_names=[f"s{i}" for i in range(27)],
        part_names=[f"p{i}" for i in range(10)],
        attrs={"config": "[filter]\nlayers = 6\n", "seed": 3, "complete": False},
        checkpoint={"particles": rng.normal(size=(5, 27)), "frame": 4, "estimate": None,
                    "rng": np.random.default_rng(1).bit_generator.state, "strategy": "apf"},
    )


def test_round_trip(tmp_path):
    res = make_result()
    path = tmp_path / "S1" / "Walking_1.h5"
    write_result(path, res)
    back = read_result(path)
    for name in ("frames", "state", "landmarks", "endpoints", "part_scores", "ess", "seconds"):
        np.testing.assert_array_equal(getattr(back, name), getattr(res, name))
    assert back.state_names == res.state_names and back.part_names == res.part_names
    assert back.attrs["seed"] == 3 and back.attrs["complete"] is False
    assert back.checkpoint["rng"] == res.checkpoint["rng"]
    np.testing.assert_array_equal(back.checkpoint["particles"], res.checkpoint["particles"])
    assert back.checkpoint["estimate"] is None and back.checkpoint["frame"] == 4
    assert not list(path.parent.glob(".*partial*"))  # no temporary left behind


def test_corrupt_and_foreign_files(tmp_path):
    bad = tmp_path / "bad.h5"
    bad.write_bytes(b"\x89HDF\r\n\x1a\n but truncated")
    with pytest.raises(InputError, match="cannot read HDF5"):
        read_result(bad)
    import h5py

    other = tmp_path / "other.h5"
    with h5py.File(other, "w") as f:
        f["x"] = [1, 2]
    with pytest.raises(InputError, match="not a voxelmocap result"):
        read_result(other)
    with pytest.raises(InputError, match="not found"):
        read_result(tmp_path / "none.h5")


def test_damaged_result_files(tmp_path):
    import h5py

    good = tmp_path / "good.h5"
    write_result(good, make_result())
    for name, edit, message in [
        ("no_names.h5", lambda f: f.__delitem__("state_names"), "no 'state_names'"),
        ("bad_shape.h5", lambda f: (f.__delitem__("endpoints"),
                                    f.create_dataset("endpoints", data=np.zeros((4, 19, 3)))),
         "'endpoints' has shape"),
        ("bad_ckpt.h5", lambda f: f["checkpoint"].attrs.__delitem__("scalars"),
         "damaged checkpoint"),
    ]:
        path = tmp_path / name
        path.write_bytes(good.read_bytes())
        with h5py.File(path, "r+") as f:
            edit(f)
        with pytest.raises(InputError, match=message):
            read_result(path)


def test_output_paths(tmp_path):
    with pytest.raises(InputError, match="is a folder"):
        write_result(tmp_path, make_result())
    blocker = tmp_path / "file"
    blocker.write_text("x")
    with pytest.raises(InputError, match="not a folder"):
        write_result(blocker / "r.h5", make_result())
