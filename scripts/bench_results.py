"""Cost of writing one frame to a streamed result file, early and late in a long sequence.

Appends ``--frames`` synthetic frames (the shapes of a 6 × 600 particle run: state 27, 10 parts,
6 layers, a 600 × 27 particle checkpoint) with :class:`voxelmocap.io.results.ResultWriter`, the
way ``track`` does, and times every append. Prints, per run and as the median over ``--runs``
runs, the median time of frames 6–15 ("frame 10") and of the last ten frames ("frame N"), the
medians of the first and last 200 frames (steadier on a busy machine) and the least-squares slope
of the cost over the whole run: a streamed writer's cost must not grow with the sequence (the
earlier writer rewrote the whole file after every frame).

Usage: ``python scripts/bench_results.py [--frames 3000] [--runs 5] [--dir /tmp]``
"""

from __future__ import annotations

import argparse
import platform
import tempfile
import time
from pathlib import Path

import numpy as np

from voxelmocap.io.results import ResultWriter


class Row:
    """A frame record with the shapes ``track`` writes."""

    def __init__(self, k: int, rng: np.random.Generator):
        self.frame = k
        self.state, self.map_state = rng.normal(size=27), rng.normal(size=27)
        self.landmarks, self.endpoints = rng.normal(size=(15, 3)), rng.normal(size=(20, 3))
        self.part_scores = rng.random((10, 4))
        self.ess, self.betas = rng.random(6), rng.random(6)
        self.seconds, self.log_likelihood = float(rng.random()), float(rng.normal())


def one_run(folder: Path, n_frames: int, seed: int) -> np.ndarray:
    """Seconds of each append, ``(n_frames,)``."""
    rng = np.random.default_rng(seed)
    rows = [Row(k + 1, rng) for k in range(min(n_frames, 50))]  # reused: time the writer only
    checkpoint = {"particles": rng.normal(size=(600, 27)), "log_weights": rng.normal(size=600),
                  "history": rng.normal(size=(2, 27)), "rng": {"state": 1}, "frame": 0}
    path = folder / f"bench_{seed}.h5"
    seconds = np.empty(n_frames)
    with ResultWriter(path) as out:
        out.start(rows[0], attrs={"frame_rate": 60.0, "config": ""},
                  state_names=[f"s{i}" for i in range(27)],
                  part_names=[f"p{i}" for i in range(10)], replace=True)
        for k in range(n_frames):
            row = rows[k % len(rows)]
            row.frame = k + 1
            checkpoint["frame"] = k + 1
            t0 = time.perf_counter()
            out.append(row, checkpoint, complete=k == n_frames - 1)
            seconds[k] = time.perf_counter() - t0
    path.unlink()
    return seconds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--frames", type=int, default=3000)
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--dir", default=None, help="folder for the files (default: a temp dir)")
    args = parser.parse_args()
    early, late, first, last, slopes = [], [], [], [], []
    n = args.frames
    with tempfile.TemporaryDirectory(dir=args.dir) as tmp:
        for run in range(args.runs):
            s = one_run(Path(tmp), n, run)
            early.append(np.median(s[5:15]))
            late.append(np.median(s[-10:]))
            first.append(np.median(s[:200]))
            last.append(np.median(s[-200:]))
            slopes.append(np.polyfit(np.arange(n), s, 1)[0] * 1000)  # s per 1000 frames
            print(f"run {run + 1}: frame 10 {early[-1] * 1e3:6.2f} ms, frame {n} "
                  f"{late[-1] * 1e3:6.2f} ms; first/last 200 frames {first[-1] * 1e3:6.2f} / "
                  f"{last[-1] * 1e3:6.2f} ms; slope {slopes[-1] * 1e3:+.3f} ms per 1000 frames")
    print(f"machine: {platform.machine()}, {platform.processor() or 'cpu'}; "
          f"{args.runs} runs of {n} frames (checkpoint 600 × 27 particles)")
    print(f"write cost per frame, median over runs: frame 10 {np.median(early) * 1e3:.2f} ms, "
          f"frame {n} {np.median(late) * 1e3:.2f} ms; first 200 frames "
          f"{np.median(first) * 1e3:.2f} ms, last 200 {np.median(last) * 1e3:.2f} ms; "
          f"slope {np.median(slopes) * 1e3:+.3f} ms per 1000 frames")


if __name__ == "__main__":
    main()
