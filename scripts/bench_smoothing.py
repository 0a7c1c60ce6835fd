"""Accuracy with and without the exports' zero-lag Butterworth filter, on tracked benchmark clips.

Reads tracking results (``RUN/<Subject>/<Action>_<Trial>.h5``, e.g. those of
``bench_no_answer.py``), filters their endpoints with :func:`voxelmocap.smoothing.butterworth` at
each cut-off (at the result's own frame rate), and scores raw and filtered estimates against the
data set's ground truth with :func:`voxelmocap.evaluation.evaluate_sequence` (μ, MMTA at 100 mm).
Filtering is post-processing, so results tracked earlier serve as well as fresh ones.

Usage::

    python scripts/bench_smoothing.py --data /work/bench/data \\
        --runs /work/bench/final/auto_voxels_4_multi10/seed0 [more runs] [--cutoffs 6,10]

Feeds docs/benchmarks.md, "Outputs", "Smoothing the exports".
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from voxelmocap.evaluation import evaluate_sequence
from voxelmocap.io.body_pose_xml import read_body_pose_xml
from voxelmocap.io.results import read_result
from voxelmocap.smoothing import butterworth


def score(endpoints, gt, rows):
    """(μ mm, MMTA %) of estimated endpoints against the ground-truth rows they match."""
    sc, _ = evaluate_sequence(endpoints, gt.endpoints[rows], gt.enabled[rows], delta=100.0)
    return sc.mu_mm, sc.mmta_pct


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", required=True, help="data set with the ground truth")
    parser.add_argument("--runs", nargs="+", required=True, help="run folders")
    parser.add_argument("--cutoffs", default="6,10", help="cut-offs in Hz (comma-separated)")
    parser.add_argument("--order", type=int, default=4, help="zero-lag order (default 4)")
    args = parser.parse_args()
    cutoffs = [float(c) for c in args.cutoffs.split(",")]
    head = " | ".join(f"μ {c:g} Hz | MMTA {c:g} Hz" for c in cutoffs)
    print(f"| clip | run | μ raw | MMTA raw | {head} |")
    print("|---|---|" + "---|---|" * (1 + len(cutoffs)))
    table = []
    for run in args.runs:
        for path in sorted(Path(run).glob("*/*.h5")):
            res = read_result(path)
            gt = read_body_pose_xml(Path(args.data) / path.parent.name / "Mocap_Data"
                                    / f"{path.stem}.xml")
            rows = gt.index_of(res.frames)
            keep = rows >= 0
            if not np.all(np.diff(res.frames) == 1):
                raise SystemExit(f"{path}: frames are not consecutive")
            fps = float(res.attrs["frame_rate"])
            values = [score(res.endpoints[keep], gt, rows[keep])]
            for c in cutoffs:
                smooth = butterworth(res.endpoints, fps, cutoff_hz=c, order=args.order)
                values.append(score(smooth[keep], gt, rows[keep]))
            table.append(values)
            cells = " | ".join(f"{m:.1f} | {a:.1f}" for m, a in values)
            print(f"| {path.stem} | {Path(run).name} | {cells} |", flush=True)
    mean = np.mean(np.array(table), axis=0)
    cells = " | ".join(f"**{m:.1f}** | **{a:.1f}**" for m, a in mean)
    print(f"| **mean of {len(table)}** | | {cells} |")


if __name__ == "__main__":
    main()
