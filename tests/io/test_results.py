"""Result files: round trip, self-description, streaming, commits, locks and damaged files."""

import datetime
import os
import subprocess
import sys
import textwrap

import h5py
import numpy as np
import pytest

from voxelmocap import __version__
from voxelmocap.errors import InputError
from voxelmocap.io.results import (
    FORMAT,
    PER_FRAME,
    ResultWriter,
    TrackResult,
    read_result,
    write_result,
)
from voxelmocap.joints import ENDPOINT_NAMES, LANDMARK_NAMES


def make_result(n=4, seed=0):
    rng = np.random.default_rng(seed)
    return TrackResult(
        frames=np.arange(6, 6 + n), state=rng.normal(size=(n, 27)),
        landmarks=rng.normal(size=(n, 15, 3)), endpoints=rng.normal(size=(n, 20, 3)),
        part_scores=rng.random((n, 10, 4)), ess=rng.random((n, 6)), betas=rng.random((n, 6)),
        seconds=rng.random(n), log_likelihood=rng.normal(size=n),
        map_state=rng.normal(size=(n, 27)), state_names=[f"s{i}" for i in range(27)],
        part_names=[f"p{i}" for i in range(9)] + ["tête"],
        attrs={"config": "[filter]\nlayers = 6\n", "seed": 3, "complete": False,
               "frame_rate": 30.0, "init_method": "the ground truth of frame 6"},
        checkpoint={"particles": rng.normal(size=(5, 27)), "frame": 4, "estimate": None,
                    "rng": np.random.default_rng(1).bit_generator.state, "strategy": "apf"},
    )


class Row:
    """A frame record: attributes named like the per-frame datasets (``frame`` for frames)."""

    def __init__(self, result, i):
        for name in PER_FRAME:
            setattr(self, "frame" if name == "frames" else name, getattr(result, name)[i])


def test_round_trip(tmp_path):
    res = make_result()
    path = tmp_path / "S1" / "Walking_1.h5"
    write_result(path, res)
    back = read_result(path)
    for name in PER_FRAME:
        np.testing.assert_array_equal(getattr(back, name), getattr(res, name))
    assert back.state_names == res.state_names and back.part_names == res.part_names
    assert back.attrs["seed"] == 3 and back.attrs["complete"] is False
    assert back.checkpoint["rng"] == res.checkpoint["rng"]
    np.testing.assert_array_equal(back.checkpoint["particles"], res.checkpoint["particles"])
    assert back.checkpoint["estimate"] is None and back.checkpoint["frame"] == 4
    assert sorted(p.name for p in path.parent.iterdir()) == ["Walking_1.h5"]  # nothing else


def test_the_file_describes_itself(tmp_path):
    path = tmp_path / "r.h5"
    before = datetime.datetime.now(datetime.timezone.utc).replace(microsecond=0)
    write_result(path, make_result())
    with h5py.File(path, "r") as f:  # a plain reader, no voxelmocap involved
        a = f.attrs
        assert a["format"] == FORMAT and a["voxelmocap_version"] == __version__
        assert a["length_unit"] == "mm" and a["angle_unit"] == "rad"
        assert "Z up" in a["coordinate_frame"] and "floor at Z = 0" in a["coordinate_frame"]
        assert a["frame_rate"] == 30.0
        assert list(a["landmark_names"]) == list(LANDMARK_NAMES)
        assert list(a["endpoint_names"]) == list(ENDPOINT_NAMES)
        assert list(a["state_names"]) == [f"s{i}" for i in range(27)]
        assert a["init_method"] == "the ground truth of frame 6"
        created = datetime.datetime.fromisoformat(a["created"].replace("Z", "+00:00"))
        assert before <= created <= datetime.datetime.now(datetime.timezone.utc)
        # UTF-8 variable-length strings, not fixed-length bytes
        assert h5py.check_string_dtype(f["part_names"].dtype).encoding == "utf-8"
        assert h5py.check_string_dtype(f["part_names"].dtype).length is None
        assert f["part_names"].asstr()[9] == "tête"
        assert f["landmarks"].attrs["units"] == "mm" and "seconds" in f
        assert f["seconds"].attrs["units"] == "s"


def test_streamed_frames_and_commits(tmp_path):
    res = make_result(n=5)
    path = tmp_path / "run" / "S1" / "Walking_1.h5"
    with ResultWriter(path) as out:
        assert not path.exists()
        out.start(Row(res, 0), attrs=res.attrs, state_names=res.state_names,
                  part_names=res.part_names)
        assert len(read_result(path)) == 0 and read_result(path).checkpoint is None
        for i in range(5):
            ckpt = {"particles": np.full((3, 2), float(i)), "frame": i,
                    "history": np.zeros((min(i, 2), 2))}  # shapes change between frames
            out.append(Row(res, i), ckpt, complete=i == 4)
            now = read_result(path)  # readable while the writer holds it
            assert len(now) == i + 1 and now.attrs["complete"] is (i == 4)
            assert now.checkpoint["frame"] == i and now.checkpoint["history"].shape == (min(i, 2), 2)
            np.testing.assert_array_equal(now.state, res.state[: i + 1])
    back = read_result(path)
    np.testing.assert_array_equal(back.frames, res.frames)
    assert back.attrs["complete"]


def test_a_frame_without_state_drops_the_older_checkpoint(tmp_path):
    """A checkpoint must match the committed frames: an older one would resume wrongly."""
    res = make_result(n=2)
    path = tmp_path / "r.h5"
    with ResultWriter(path) as out:
        out.start(Row(res, 0), attrs=res.attrs, state_names=res.state_names,
                  part_names=res.part_names)
        out.append(Row(res, 0), {"frame": 0})
        assert read_result(path).checkpoint == {"frame": 0}
        out.append(Row(res, 1), None)
    assert len(read_result(path)) == 2 and read_result(path).checkpoint is None


def test_uncommitted_rows_are_not_results(tmp_path):
    path = tmp_path / "r.h5"
    write_result(path, make_result(n=4))
    with h5py.File(path, "r+") as f:  # as a run killed after writing rows, before the commit
        f["commit"][0] = 2
    back = read_result(path)
    assert len(back) == 2
    np.testing.assert_array_equal(back.frames, [6, 7])


def test_a_second_writer_is_refused_while_the_first_runs(tmp_path):
    res = make_result(n=2)
    path = tmp_path / "r.h5"
    with ResultWriter(path) as out:
        out.start(Row(res, 0), attrs=res.attrs, state_names=res.state_names,
                  part_names=res.part_names)
        out.append(Row(res, 0), None)
        with pytest.raises(InputError, match="another track run is writing"):
            ResultWriter(path)
        # the lock is on the file: another process is refused too
        code = textwrap.dedent(f"""
            from voxelmocap.errors import InputError
            from voxelmocap.io.results import ResultWriter
            try:
                ResultWriter({str(path)!r})
            except InputError as exc:
                print(exc)
        """)
        env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
        run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                             env=env, check=True)
        assert "another track run is writing" in run.stdout
    ResultWriter(path).close()  # free again once the first is closed


def test_an_existing_result_is_not_replaced_unasked(tmp_path):
    res = make_result(n=2)
    path = tmp_path / "r.h5"
    write_result(path, res)
    with ResultWriter(path) as out, pytest.raises(InputError, match="result exists"):
        out.start(Row(res, 0), attrs=res.attrs, state_names=res.state_names,
                  part_names=res.part_names)
    assert len(read_result(path)) == 2
    # a stale temporary file from a killed creation is removed by the next writer
    stale = tmp_path / ".r.h5.partial"
    stale.write_bytes(b"half an HDF5 file")
    write_result(path, make_result(n=3))
    assert len(read_result(path)) == 3 and not stale.exists()


def test_corrupt_old_and_foreign_files(tmp_path):
    bad = tmp_path / "bad.h5"
    bad.write_bytes(b"\x89HDF\r\n\x1a\n but truncated")
    with pytest.raises(InputError, match="cannot read HDF5"):
        read_result(bad)
    other = tmp_path / "other.h5"
    with h5py.File(other, "w") as f:
        f["x"] = [1, 2]
    with pytest.raises(InputError, match="not a voxelmocap result"):
        read_result(other)
    old = tmp_path / "old.h5"  # the format before streamed results: no 'format' attribute
    with h5py.File(old, "w") as f:
        f["frames"] = [1, 2]
        f["state"] = np.zeros((2, 27))
        f.attrs["seed"] = 0
    with pytest.raises(InputError, match="older voxelmocap"):
        read_result(old)
    newer = tmp_path / "newer.h5"
    write_result(newer, make_result())
    with h5py.File(newer, "r+") as f:
        f.attrs["format_version"] = 99
    with pytest.raises(InputError, match="newer voxelmocap"):
        read_result(newer)
    with pytest.raises(InputError, match="not found"):
        read_result(tmp_path / "none.h5")


def test_damaged_result_files(tmp_path):
    good = tmp_path / "good.h5"
    write_result(good, make_result())
    for name, edit, message in [
        ("no_names.h5", lambda f: f.__delitem__("state_names"), "no 'state_names'"),
        ("bad_shape.h5", lambda f: (f.__delitem__("endpoints"),
                                    f.create_dataset("endpoints", data=np.zeros((4, 19, 3)))),
         "'endpoints' has shape"),
        ("short.h5", lambda f: f["state"].resize(3, axis=0), "commit says 4 frames"),
        ("bad_ckpt.h5", lambda f: f["checkpoint_0"].__setitem__(slice(0, 40), 7),
         "damaged checkpoint"),
        ("bad_slot.h5", lambda f: f["commit"].__setitem__(1, 5), "slot 5"),
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


#: A writer that never stops: it continues the file it finds (as --resume does: copy the committed
#: frames into a fresh file), appends 25 frames, closes, and starts over. Frame k's rows hold k.
_ENDLESS_WRITER = """
import sys
import numpy as np
from voxelmocap.io.results import ResultWriter, read_result

class Row:
    def __init__(self, k):
        self.frame = k
        self.state = self.map_state = np.full(27, float(k))
        self.landmarks = np.full((15, 3), float(k))
        self.endpoints = np.full((20, 3), float(k))
        self.part_scores = np.full((10, 4), float(k))
        self.ess = self.betas = np.full(3, float(k))
        self.seconds = self.log_likelihood = float(k)
        self.landmark_spread = self.confidence = np.full(15, float(k))

path = sys.argv[1]
attrs = {"frame_rate": 60.0, "config": "", "seed": 0}
names = dict(state_names=[f"s{i}" for i in range(27)], part_names=[f"p{i}" for i in range(10)])
print("ready", flush=True)
while True:
    with ResultWriter(path) as out:
        previous = out.read_existing()
        n = 0 if previous is None else len(previous)
        out.start(Row(n), attrs=attrs, previous=previous, replace=True, **names)
        for k in range(n, n + 25):
            out.append(Row(k), {"k": k, "particles": np.full((600, 27), float(k))})
"""


def _check_prefix(path):
    """The file reads, holds frames 0 … n−1 with their own values, and the checkpoint of n−1."""
    res = read_result(path)
    n = len(res)
    np.testing.assert_array_equal(res.frames, np.arange(n))
    assert res.observed.dtype == bool and res.observed.all()
    for name in set(PER_FRAME) - {"observed"}:
        values = getattr(res, name).reshape(n, int(np.prod(getattr(res, name).shape[1:])))
        np.testing.assert_array_equal(values, np.repeat(np.arange(n, dtype=float)[:, None],
                                                        values.shape[1], axis=1))
    if n:
        assert res.checkpoint["k"] == n - 1
        np.testing.assert_array_equal(res.checkpoint["particles"], np.full((600, 27), n - 1.0))
    return n


def test_kill_9_at_any_moment_leaves_every_committed_frame(tmp_path):
    """20 writers killed at seeded random moments (while creating, copying, appending)."""
    import signal
    import time

    rng = np.random.default_rng(2024)
    path = tmp_path / "S1" / "Walking_1.h5"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    counts = []
    for _ in range(20):
        proc = subprocess.Popen([sys.executable, "-c", _ENDLESS_WRITER, str(path)], env=env,
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        assert proc.stdout.readline() == b"ready\n"  # past the interpreter's start-up
        time.sleep(rng.uniform(0.0, 0.3))
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        assert proc.returncode == -signal.SIGKILL, proc.stderr.read().decode()
        proc.stdout.close()
        proc.stderr.close()
        counts.append(_check_prefix(path))
        leftovers = {p.name for p in path.parent.iterdir()} - {"Walking_1.h5"}
        assert leftovers <= {".Walking_1.h5.partial"}  # only a creation cut short, see below
    # every kill kept what was committed before it, and the runs went on from there
    assert counts == sorted(counts) and counts[-1] > counts[0]
    # the next writer removes a temporary file a killed creation left, and continues the file
    with ResultWriter(path) as out:
        previous = out.read_existing()
        out.start(attrs={"frame_rate": 60.0}, previous=previous, replace=True,
                  state_names=previous.state_names, part_names=previous.part_names)
    assert [p.name for p in path.parent.iterdir()] == ["Walking_1.h5"]
    assert _check_prefix(path) == counts[-1]


def test_readers_of_a_running_writer_see_one_commit(tmp_path):
    """Reads overlapping a writer's flushes and commits (which reuse the checkpoint slots) return
    a consistent prefix: rows and checkpoint of the same committed frame. Reading without
    re-checking the commit gave a mismatched or truncated file in ~15 % of such reads."""
    path = tmp_path / "S1" / "Walking_1.h5"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    proc = subprocess.Popen([sys.executable, "-c", _ENDLESS_WRITER, str(path)], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
    try:
        assert proc.stdout.readline() == b"ready\n"
        counts = []
        while len(counts) < 150:
            assert proc.poll() is None
            if path.exists():
                counts.append(_check_prefix(path))
    finally:
        proc.kill()
        proc.wait()
        proc.stdout.close()
    assert counts[-1] > counts[0]  # the writer moved on while it was read


def test_two_fresh_writers_race_for_one_result(tmp_path):
    res = make_result(n=2)
    path = tmp_path / "r.h5"
    first, second = ResultWriter(path), ResultWriter(path)  # neither sees a file yet
    args = dict(attrs=res.attrs, state_names=res.state_names, part_names=res.part_names)
    first.start(Row(res, 0), **args)
    with pytest.raises(InputError, match="another track run is writing"):
        second.start(Row(res, 0), **args)
    first.append(Row(res, 0), None, complete=True)
    first.close()
    with pytest.raises(InputError, match="created this result meanwhile"):
        second.start(Row(res, 0), **args)
    second.close()
    assert len(read_result(path)) == 1


def test_format_2_results_still_read(tmp_path):
    """A result written before format 3 (no confidence): unknown spread and confidence,
    every frame observed; resuming it writes format 3 with those rows carried over."""
    import h5py

    res = make_result()
    path = tmp_path / "S1" / "Walking_1.h5"
    write_result(path, res)
    with h5py.File(path, "r+") as f:  # make it what format 2 wrote
        for name in ("landmark_spread", "confidence", "observed"):
            del f[name]
        f.attrs["format_version"] = 2
    back = read_result(path)
    assert np.isnan(back.landmark_spread).all() and back.landmark_spread.shape == (4, 15)
    assert np.isnan(back.confidence).all() and back.observed.all()
    np.testing.assert_array_equal(back.landmarks, res.landmarks)
    write_result(tmp_path / "again.h5", back)
    again = read_result(tmp_path / "again.h5")
    assert again.attrs["format_version"] == 3 and np.isnan(again.confidence).all()


def test_format_3_without_its_datasets_is_damaged(tmp_path):
    import h5py

    path = tmp_path / "r.h5"
    write_result(path, make_result())
    with h5py.File(path, "r+") as f:
        del f["confidence"]
    with pytest.raises(InputError, match="no 'confidence' dataset"):
        read_result(path)
