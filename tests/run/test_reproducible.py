"""The same command and seed give the same result in another process and with another number of
threads (issue 34): nothing in the chain may depend on the thread count, the process or an
unseeded generator — GrabCut's k-means start draws from OpenCV's own generator, the likelihood
kernels run in parallel over chunks of particles."""

import os
import subprocess
import sys

import h5py
import numpy as np

#: every dataset of a result file that holds the track (timestamps and host live in attributes)
_TRACK = ("frames", "state", "map_state", "landmarks", "endpoints", "log_likelihood",
          "part_scores", "ess", "betas")


def _read(path) -> dict:
    with h5py.File(path, "r") as f:
        n = int(f["commit"][0]) if "commit" in f else None
        return {k: f[k][()] if n is None else f[k][:n] for k in _TRACK if k in f}


def _track(data, out, threads: int) -> None:
    env = dict(os.environ, NUMBA_NUM_THREADS=str(threads), OPENCV_FOR_THREADS_NUM=str(threads),
               OMP_NUM_THREADS=str(threads), OPENBLAS_NUM_THREADS=str(threads))
    proc = subprocess.run(
        [sys.executable, "-m", "voxelmocap.cli", "track", str(data), "--subject", "S1",
         "--sequence", "Walking_1", "--layers", "2", "--particles", "60", "--seed", "4",
         "--no-progress", "--out", str(out)],
        env=env, capture_output=True, text=True, timeout=1800)
    assert proc.returncode == 0, proc.stderr


def test_one_and_two_threads_in_two_processes_track_bit_identically(walk_dataset,
                                                                   link_without_answer, tmp_path):
    """Without background videos, ground truth or body file — the path with the most machinery
    (the plate learnt from the sequence, GrabCut on its never-seen pixels, the start searched
    from the voxels, the body fitted) — a run with one thread and a run with two, each its own
    process, write the same track bit for bit."""
    data = link_without_answer(walk_dataset, tmp_path / "data",
                               leave_out=("Mocap_Data", "Background"))
    _track(data, tmp_path / "one", 1)
    _track(data, tmp_path / "two", 2)
    log = (tmp_path / "one" / "voxelmocap.log").read_text()
    assert "plate" in log and "Background" not in str(list(data.rglob("*")))
    a = _read(tmp_path / "one" / "S1" / "Walking_1.h5")
    b = _read(tmp_path / "two" / "S1" / "Walking_1.h5")
    assert set(a) == set(b) and {"state", "log_likelihood"} <= set(a)
    for name in a:
        assert a[name].dtype == b[name].dtype and a[name].shape == b[name].shape, name
        assert a[name].tobytes() == b[name].tobytes(), (
            f"{name}: max |Δ| {np.nanmax(np.abs(a[name] - b[name]))}")
