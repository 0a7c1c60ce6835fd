"""A full disk: one line, exit 2, no crash, nothing half-written, and ``--resume`` completes the
run bit-identically once space is freed (issue 36).

The disk is a real small file system (a tmpfs mounted for the test; skipped where mounting is
not allowed), filled by the test at a chosen moment of the run. HDF5 meeting the full disk
itself (``ResultWriter``'s free-space check switched off) used to crash the process with a
segmentation fault: that case runs in a child process, so a crash fails the test instead of
ending the suite.
"""

from __future__ import annotations

import contextlib
import errno
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from voxelmocap.cli import main
from voxelmocap.errors import InputError
from voxelmocap.io.results import ResultWriter, read_result

RUN_ARGS = ["--frames", "1:4", "--layers", "1", "--particles", "30", "--seed", "2",
            "--no-progress"]
COMPARED = ("frames", "state", "map_state", "landmarks", "endpoints", "part_scores",
            "log_likelihood", "ess", "betas", "landmark_spread", "confidence", "observed")


@contextlib.contextmanager
def small_disk(folder, size: str):
    """A tmpfs of ``size`` mounted at ``folder`` (skips the test when mounting is refused)."""
    folder.mkdir(parents=True, exist_ok=True)
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(folder)],
                          capture_output=True, check=False)
    if done.returncode != 0:
        pytest.skip(f"cannot mount a small file system here ({done.stderr.decode().strip()})")
    try:
        yield folder
    finally:
        subprocess.run(["umount", "-l", str(folder)], check=False)


def fill(folder) -> os.PathLike:
    """Write a file into ``folder`` until its file system is full; returns the file."""
    filler = folder / "filler"
    block = np.random.default_rng(0).bytes(4096)
    with open(filler, "wb", buffering=0) as fh:
        try:
            while True:
                fh.write(block)
        except OSError as exc:
            assert exc.errno == errno.ENOSPC
    with contextlib.suppress(OSError), open(filler, "ab", buffering=0) as fh:
        while True:  # the last bytes of a partly filled page
            fh.write(b"x")
    return filler


@pytest.fixture(scope="module")
def uninterrupted(walk_dataset, tmp_path_factory):
    out = tmp_path_factory.mktemp("full")
    assert main(["track", str(walk_dataset), "--subject", "S1", "--sequence", "Walking_1",
                 "--out", str(out), *RUN_ARGS]) == 0
    return read_result(out / "S1" / "Walking_1.h5")


def _track(data, out, *extra):
    return main(["track", str(data), "--subject", "S1", "--sequence", "Walking_1", "--out",
                 str(out), *RUN_ARGS, *extra])


@pytest.mark.parametrize("check_space", [True, False], ids=["free-space check", "HDF5 fails"])
def test_disk_full_mid_run_resumes_bit_identically(walk_dataset, uninterrupted, tmp_path,
                                                   monkeypatch, capsys, check_space):
    import voxelmocap.io._result_writer as _result_writer

    # The free-space check refuses the third frame; HDF5 itself (check off) meets the full disk
    # only where the file grows: the first frame allocates the chunks the later ones fill.
    fill_at = 3 if check_space else 1
    if not check_space:
        monkeypatch.setattr(_result_writer, "_free_bytes", lambda folder: None)
    real_append = ResultWriter.append
    calls = {"n": 0, "filler": None}

    def append(self, *args, **kwargs):
        calls["n"] += 1
        if calls["n"] == fill_at:
            calls["filler"] = fill(disk)
        return real_append(self, *args, **kwargs)

    with small_disk(tmp_path / "disk", "3m") as disk:
        run = disk / "run"
        monkeypatch.setattr(ResultWriter, "append", append)
        capsys.readouterr()
        assert _track(walk_dataset, run) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1, err
        assert str(run / "S1" / "Walking_1.h5") in err[0]
        assert "--resume" in err[0] and f"{fill_at - 1} frame(s)" in err[0], err[0]
        assert "space" in err[0]
        files = sorted(p.name for p in (run / "S1").iterdir())
        assert files == ["Walking_1.h5"], files  # no .partial, no half-written export
        kept = read_result(run / "S1" / "Walking_1.h5")
        assert len(kept) == fill_at - 1 and not kept.attrs["complete"]
        np.testing.assert_array_equal(kept.state, uninterrupted.state[:fill_at - 1])

        os.unlink(calls["filler"])  # space is freed
        monkeypatch.setattr(ResultWriter, "append", real_append)
        assert _track(walk_dataset, run, "--resume") == 0
        resumed = read_result(run / "S1" / "Walking_1.h5")
        for name in COMPARED:
            np.testing.assert_array_equal(getattr(resumed, name), getattr(uninterrupted, name))
        assert resumed.attrs["complete"]
        assert sorted(p.name for p in (run / "S1").iterdir()) == \
            ["Walking_1.bvh", "Walking_1.csv", "Walking_1.h5", "Walking_1.trc", "Walking_1.xml"]


def test_disk_too_full_to_start_leaves_nothing(walk_dataset, tmp_path, capsys):
    with small_disk(tmp_path / "disk", "300k") as disk:
        capsys.readouterr()
        assert _track(walk_dataset, disk / "run") == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "not enough free space" in err[0], err
        assert list(disk.iterdir()) == []


_CHILD = textwrap.dedent("""
    import sys
    import numpy as np
    import voxelmocap.io._result_writer as _result_writer
    import voxelmocap.io.results as results
    from voxelmocap.errors import InputError
    from test_results import make_result

    _result_writer._free_bytes = lambda folder: None   # HDF5 meets the full disk itself
    src = make_result()
    path = sys.argv[1]
    n = 0
    try:
        with results.ResultWriter(path) as out:
            out.start(attrs={"frame_rate": 60.0}, state_names=src.state_names,
                      part_names=src.part_names, previous=results.TrackResult(
                          **{k: getattr(src, k)[:1] for k in results.PER_FRAME},
                          state_names=src.state_names, part_names=src.part_names))
            big = {"pad": np.random.default_rng(0).random(40_000)}
            while True:
                row = type("R", (), {k: getattr(src, k)[0] for k in results.PER_FRAME})()
                row.frame = n + 2
                out.append(row, big)
                n += 1
    except InputError as exc:
        print("REFUSED", n, exc)
""")


def test_hdf5_write_failure_does_not_crash(tmp_path):
    """The writer meets ENOSPC inside HDF5 (no free-space check): one InputError, no crash,
    and the file reads with every frame committed before the failure."""
    script = tmp_path / "child.py"
    script.write_text(_CHILD)
    with small_disk(tmp_path / "disk", "1m") as disk:
        path = disk / "r.h5"
        env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
        done = subprocess.run([sys.executable, str(script), str(path)], capture_output=True,
                              text=True, env=env, check=False)
        assert done.returncode == 0, (done.returncode, done.stderr[-2000:])
        assert done.stderr == "", done.stderr[-2000:]
        words = done.stdout.split()
        assert words[0] == "REFUSED", done.stdout
        committed = int(words[1])
        assert "No space left on device" in done.stdout
        result = read_result(path)
        assert len(result) == committed + 1  # the one carried over and every one appended
        assert list(disk.iterdir()) == [path]


def test_atomic_writes_turn_enospc_into_one_line(tmp_path, monkeypatch):
    """Every atomic writer (TRC, CSV, XML, TOML …): a failing write is an InputError naming the
    target, and neither the target nor a temporary is left."""
    from voxelmocap.io._atomic import atomic_write_text

    def full(self, *args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr("pathlib.Path.write_text", full)
    with pytest.raises(InputError) as info:
        atomic_write_text(tmp_path / "a.trc", "x")
    assert str(info.value) == f"{tmp_path / 'a.trc'}: cannot write (No space left on device)"
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("command", ["export", "evaluate --json", "import"])
def test_commands_on_a_full_disk_answer_one_line(command, tmp_path, capsys):
    """export, evaluate --json and import writing to a full disk: exit 2, one line naming the
    file, and nothing of theirs left on the disk."""
    from bad_input_cases import _mapping, _project, _reference, _result
    from humaneva_fixture import make_tiny_dataset

    result = _result(tmp_path)
    with small_disk(tmp_path / "disk", "1m") as disk:
        if command == "export":
            argv = ["export", str(result), "--out", str(disk / "out")]
            (disk / "out").mkdir()
        elif command == "evaluate --json":
            argv = ["evaluate", str(result), "--reference", str(_reference(tmp_path)),
                    "--mapping", str(_mapping(tmp_path)), "--json", str(disk / "r.json")]
        else:
            data = make_tiny_dataset(tmp_path / "data", n_frames=3)
            argv = ["import", str(_project(data, tmp_path)), "--out", str(disk / "he"),
                    "--no-progress"]
        filler = fill(disk)
        before = sorted(disk.rglob("*"))
        capsys.readouterr()
        assert main(argv) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1, err
        assert str(disk) in err[0] and ("space" in err[0] or "full" in err[0]), err[0]
        assert sorted(disk.rglob("*")) == before  # nothing new, not even a folder
        os.unlink(filler)


_DUMP_CHILD = textwrap.dedent("""
    import sys
    import numpy as np
    from voxelmocap.errors import InputError
    from voxelmocap.grid import VoxelGrid
    from voxelmocap.io.voxels import VoxelDumpWriter

    grid = VoxelGrid(origin=(0.0, 0.0, 0.0), voxel_size=10.0, shape=(64, 64, 64))
    rng = np.random.default_rng(0)
    n = 0
    try:
        with VoxelDumpWriter(sys.argv[1], grid) as out:
            while True:  # incompressible volumes, until the disk is full
                out.write(n + 1, rng.random(grid.shape) > 0.5, smoothed=rng.random(grid.shape))
                n += 1
    except InputError as exc:
        print("REFUSED", n, exc)
""")


def test_voxel_dump_on_a_full_disk(tmp_path):
    """``dump``'s HDF5 writer meeting a full disk: one InputError, no crash, nothing left."""
    script = tmp_path / "child.py"
    script.write_text(_DUMP_CHILD)
    with small_disk(tmp_path / "disk", "2m") as disk:
        env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
        done = subprocess.run([sys.executable, str(script), str(disk / "v.h5")],
                              capture_output=True, text=True, env=env, check=False)
        assert done.returncode == 0, (done.returncode, done.stderr[-2000:])
        assert done.stderr == "", done.stderr[-2000:]
        assert done.stdout.startswith("REFUSED") and "No space left on device" in done.stdout
        assert str(disk / "v.h5") in done.stdout
        assert list(disk.iterdir()) == []


@pytest.mark.parametrize("suffix", [".mp4", ".avi"])
def test_video_on_a_full_disk_is_one_line_and_no_file(tmp_path, suffix):
    """An overlay video (H.264 or Motion-JPEG through PyAV) meeting a full disk mid-way: one
    InputError naming the video, and neither it nor its temporary left on the disk."""
    from voxelmocap.io.video_writer import VideoWriter

    rng = np.random.default_rng(0)
    with small_disk(tmp_path / "disk", "1m") as disk:
        filler = fill(disk)
        os.truncate(filler, os.path.getsize(filler) - 20_000)  # room for a few frames only
        path = disk / f"overlay{suffix}"
        with pytest.raises(InputError) as info, VideoWriter(path, 30.0, (64, 48)) as video:
            for _ in range(40):  # noise: incompressible, ~2 kB per frame or more
                video.write(rng.integers(0, 256, (48, 64, 3), dtype=np.uint8))
        message = str(info.value)
        assert message.startswith(f"{path}: cannot write the video") and "\n" not in message
        assert "No space left on device" in message or "full" in message, message
        assert list(disk.iterdir()) == [filler]
