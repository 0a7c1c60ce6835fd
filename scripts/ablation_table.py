"""A markdown table of ``bench_no_answer.py`` variants (one json per ``--tag``), side by side.

Usage::

    python scripts/ablation_table.py --out /tmp/noanswer joint hierarchical hierarchical_refine

Each row: the variant, its likelihood evaluations per frame (``--evals TAG=N``, from the
config: the joint search 6 × 600 = 3600), mean μ and MMTA over clips (each clip the mean of its
seeds), the worst clip, the per-clip μ, and frames per second (median over runs; the whole
pipeline, measurement included, under the load the run had).

Feeds docs/benchmarks.md, "Accuracy on rendered clips" (the "What each part is worth" table, from
``bench_no_answer.py --tag T`` runs).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", required=True, help="bench_no_answer.py --out folder")
    parser.add_argument("--evals", action="append", default=[], metavar="TAG=N")
    parser.add_argument("tags", nargs="+")
    args = parser.parse_args()
    evals = dict(item.split("=", 1) for item in args.evals)
    clips = None
    lines = []
    for tag in args.tags:
        rows = json.loads((Path(args.out) / f"{tag}.json").read_text())
        clips = clips or list(rows)
        per_clip = {c: np.mean(np.asarray(v)[:, :2], axis=0) for c, v in rows.items()}
        mus = np.array([per_clip[c][0] for c in rows])
        mmta = np.array([per_clip[c][1] for c in rows])
        fps = [r[2] for v in rows.values() for r in v if len(r) > 2]
        worst = max(per_clip, key=lambda c: per_clip[c][0])
        seeds = {len(v) for v in rows.values()}
        fps_text = f"{np.median(fps):.2f}" if fps else "–"
        lines.append(f"| {tag} | {evals.get(tag, '')} | {mus.mean():.1f} | {mmta.mean():.1f} | "
                     f"{worst} {per_clip[worst][0]:.1f} | "
                     + " / ".join(f"{per_clip[c][0]:.0f}" for c in rows)
                     + f" | {fps_text} | {','.join(map(str, sorted(seeds)))} |")
    print("| variant | evals/frame | mean μ (mm) | MMTA (%) | worst clip | μ per clip ("
          + " / ".join(clips) + ") | frames/s | seeds |")
    print("|---|---:|---:|---:|---|---|---:|---:|")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
