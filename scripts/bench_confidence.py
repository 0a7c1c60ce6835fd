"""Does the per-landmark confidence rank the errors? Tracked benchmark clips against ground truth.

For every result (``RUN/<Subject>/<Action>_<Trial>.h5`` written with result format 3, e.g. by
``bench_no_answer.py``) the landmark errors against the data set's ground truth are pooled with
the stored ``confidence`` and ``landmark_spread``. Printed: Spearman's rank correlation of each
with the error (the confidence should correlate negatively, the spread positively), and the mean
error and the share within 100 mm per confidence quartile.

Usage::

    python scripts/bench_confidence.py --data /work/bench/data --runs /tmp/noanswer/auto/seed0

Feeds docs/benchmarks.md, "Outputs", "The landmark confidence".
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from scipy import stats

from voxelmocap.evaluation import landmark_errors
from voxelmocap.io.body_pose_xml import read_body_pose_xml
from voxelmocap.io.results import read_result
from voxelmocap.joints import LANDMARK_NAMES, endpoints_to_landmarks


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", required=True)
    parser.add_argument("--runs", nargs="+", required=True)
    args = parser.parse_args()
    err, conf, spread = [], [], []
    print("| clip | run | Spearman ρ(confidence, error) | ρ(spread, error) | μ (mm) |")
    print("|---|---|---|---|---|")
    for run in args.runs:
        for path in sorted(Path(run).glob("*/*.h5")):
            res = read_result(path)
            gt = read_body_pose_xml(Path(args.data) / path.parent.name / "Mocap_Data"
                                    / f"{path.stem}.xml")
            rows = gt.index_of(res.frames)
            keep = (rows >= 0) & gt.enabled[np.maximum(rows, 0)].all(axis=1)
            e = landmark_errors(res.landmarks[keep],
                                endpoints_to_landmarks(gt.endpoints[rows[keep]]))
            c, s = res.confidence[keep], res.landmark_spread[keep]
            if np.isnan(c).all():
                raise SystemExit(f"{path}: no confidence stored (result format < 3)")
            err.append(e.ravel())
            conf.append(c.ravel())
            spread.append(s.ravel())
            print(f"| {path.stem} | {Path(run).name} | "
                  f"{stats.spearmanr(c.ravel(), e.ravel()).statistic:+.2f} | "
                  f"{stats.spearmanr(s.ravel(), e.ravel()).statistic:+.2f} | {e.mean():.1f} |")
    e, c, s = (np.concatenate(v) for v in (err, conf, spread))
    print(f"| **pooled** | | **{stats.spearmanr(c, e).statistic:+.2f}** | "
          f"**{stats.spearmanr(s, e).statistic:+.2f}** | **{e.mean():.1f}** |")
    # The same ranking within one landmark (a wrist against wrists), and of whole frames
    # (a frame's mean confidence against its mean error).
    e2, c2, s2 = (v.reshape(-1, len(LANDMARK_NAMES)) for v in (e, c, s))
    print()
    print("| landmark | mean error (mm) | mean confidence | ρ(confidence, error) | "
          "ρ(spread, error) |")
    print("|---|---|---|---|---|")
    within = []
    for j, name in enumerate(LANDMARK_NAMES):
        rc = stats.spearmanr(c2[:, j], e2[:, j]).statistic
        within.append(rc)
        print(f"| {name} | {e2[:, j].mean():.1f} | {c2[:, j].mean():.2f} | {rc:+.2f} | "
              f"{stats.spearmanr(s2[:, j], e2[:, j]).statistic:+.2f} |")
    print(f"| **median over landmarks** | | | **{np.median(within):+.2f}** | |")
    print(f"| **frames** (mean over landmarks) | | | "
          f"**{stats.spearmanr(c2.mean(axis=1), e2.mean(axis=1)).statistic:+.2f}** | "
          f"**{stats.spearmanr(s2.mean(axis=1), e2.mean(axis=1)).statistic:+.2f}** |")
    print()
    print("| confidence quartile | range | landmarks | mean error (mm) | within 100 mm (%) |")
    print("|---|---|---|---|---|")
    edges = np.quantile(c, [0, 0.25, 0.5, 0.75, 1.0])
    bins = np.clip(np.searchsorted(edges, c, side="right") - 1, 0, 3)
    for q in range(4):
        sel = bins == q
        print(f"| {q + 1} | {edges[q]:.2f}–{edges[q + 1]:.2f} | {sel.sum()} | "
              f"{e[sel].mean():.1f} | {100.0 * np.mean(e[sel] < 100.0):.1f} |")


if __name__ == "__main__":
    main()
