"""Cost of writing one frame to a streamed result file, early and late in a long sequence.

Appends ``--frames`` synthetic frames (the shapes of a 6 × 600 particle run: state 27, 10 parts,
6 layers, a 600 × 27 particle checkpoint) with :class:`voxelmocap.io.results.ResultWriter`, the
way ``track`` does, and times every append. Prints, per run and as the median over ``--runs``
runs, the median time of frames 6–15 ("frame 10") and of the last ten frames ("frame N"), the
medians of the first and last 200 frames (steadier on a busy machine) and the least-squares slope
of the cost over the whole run: a streamed writer's cost must not grow with the sequence (the
earlier writer rewrote the whole file after every frame). The earlier strategy — replace the
whole file after every frame (``write_result`` with the frames so far) — is timed in the same
run, alternating with the streamed writer run by run, and the ratio is printed.

Usage: ``python scripts/bench_results.py [--frames 3000] [--runs 5] [--dir /tmp]``

Feeds docs/benchmarks.md, "Outputs", "Result writing".
"""

from __future__ import annotations

import argparse
import platform
import tempfile
import time
from pathlib import Path

import numpy as np

from voxelmocap.io.results import PER_FRAME, ResultWriter, TrackResult, write_result


class Row:
    """A frame record with the shapes ``track`` writes."""

    def __init__(self, k: int, rng: np.random.Generator):
        self.frame = k
        self.state, self.map_state = rng.normal(size=27), rng.normal(size=27)
        self.landmarks, self.endpoints = rng.normal(size=(15, 3)), rng.normal(size=(20, 3))
        self.part_scores = rng.random((10, 4))
        self.ess, self.betas = rng.random(6), rng.random(6)
        self.seconds, self.log_likelihood = float(rng.random()), float(rng.normal())
        self.landmark_spread, self.confidence = rng.random(15) * 50.0, rng.random(15)
        self.observed = True


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


def one_run_rewrite(folder: Path, n_frames: int, seed: int) -> np.ndarray:
    """Seconds of each whole-file rewrite after frame k = 1..n (the earlier strategy)."""
    rng = np.random.default_rng(seed)
    rows = [Row(k + 1, rng) for k in range(min(n_frames, 50))]
    checkpoint = {"particles": rng.normal(size=(600, 27)), "log_weights": rng.normal(size=600),
                  "history": rng.normal(size=(2, 27)), "rng": {"state": 1}, "frame": 0}
    stacked = {}
    for name in PER_FRAME:
        attr = "frame" if name == "frames" else name
        one = np.array([getattr(rows[k % len(rows)], attr) for k in range(n_frames)])
        stacked[name] = np.arange(1, n_frames + 1) if name == "frames" else one
    path = folder / f"rewrite_{seed}.h5"
    seconds = np.empty(n_frames)
    for k in range(1, n_frames + 1):
        result = TrackResult(**{name: v[:k] for name, v in stacked.items()},
                             state_names=[f"s{i}" for i in range(27)],
                             part_names=[f"p{i}" for i in range(10)],
                             attrs={"frame_rate": 60.0, "config": "", "complete": k == n_frames},
                             checkpoint=dict(checkpoint, frame=k))
        t0 = time.perf_counter()
        write_result(path, result)
        seconds[k - 1] = time.perf_counter() - t0
    path.unlink()
    return seconds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--frames", type=int, default=3000)
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--dir", default=None, help="folder for the files (default: a temp dir)")
    args = parser.parse_args()
    n = args.frames
    stats = {"streamed": ([], []), "rewrite": ([], [])}  # (frame 10, frame N) per run
    first, last, slopes = [], [], []
    with tempfile.TemporaryDirectory(dir=args.dir) as tmp:
        for run in range(args.runs):
            for kind, fn in (("streamed", one_run), ("rewrite", one_run_rewrite)):
                s = fn(Path(tmp), n, run)
                stats[kind][0].append(np.median(s[5:15]))
                stats[kind][1].append(np.median(s[-10:]))
                if kind == "streamed":
                    first.append(np.median(s[:200]))
                    last.append(np.median(s[-200:]))
                    slopes.append(np.polyfit(np.arange(n), s, 1)[0] * 1000)  # s per 1000 frames
                print(f"run {run + 1} {kind:8s}: frame 10 {stats[kind][0][-1] * 1e3:6.2f} ms, "
                      f"frame {n} {stats[kind][1][-1] * 1e3:6.2f} ms", flush=True)
    print(f"machine: {platform.machine()}, {platform.processor() or 'cpu'}; "
          f"{args.runs} runs of {n} frames (checkpoint 600 × 27 particles)")
    for kind, (early, late) in stats.items():
        print(f"{kind:8s} write cost per frame, median over runs: frame 10 "
              f"{np.median(early) * 1e3:.2f} ms, frame {n} {np.median(late) * 1e3:.2f} ms")
    ratio = np.array(stats["rewrite"][1]) / np.array(stats["streamed"][1])
    print(f"streamed: first 200 frames {np.median(first) * 1e3:.2f} ms, last 200 "
          f"{np.median(last) * 1e3:.2f} ms; slope {np.median(slopes) * 1e3:+.3f} ms per 1000 "
          f"frames; rewrite / streamed at frame {n}: ×{np.median(ratio):.1f} "
          f"(median of per-run ratios)")


if __name__ == "__main__":
    main()
