"""The bodies a ``bench_no_answer.py`` run tracked with, against the subjects' body files.

For each clip's result file, the body it used (``body_dimensions`` when fitted, else the average
adult scaled to ``body_height_mm``) and, per length, its ratio to the body file's (mean of left
and right; the drops in mm, run / file); the last column is the standing height's ratio.

Usage::

    python scripts/body_size_table.py --data /work/bench/data RUN/seed0 [RUN2/seed0 …]

Feeds docs/benchmarks.md, "Body size" (the fitted lengths against the body files).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from bench_accuracy import SEQUENCES as CLIPS

from voxelmocap.body.shapes import MAY_BE_ZERO, BodyDimensions
from voxelmocap.io.body_file import read_body_file
from voxelmocap.io.results import read_result
from voxelmocap.pose.body_size import FITTED_KEYS, dimensions_from_json


def mean(dims, key) -> float:
    return float(np.mean(getattr(dims, key)))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("runs", nargs="+", type=Path)
    parser.add_argument("--data", default="/work/bench/data", type=Path)
    args = parser.parse_args()
    print("| run | clip | " + " | ".join(FITTED_KEYS) + " | height |")
    print("|---|---|" + "---:|" * (len(FITTED_KEYS) + 1))
    for run in args.runs:
        for subject, action in CLIPS.items():
            path = run / subject / f"{action}.h5"
            if not path.exists():
                continue
            attrs = read_result(path).attrs
            dims = (dimensions_from_json(attrs["body_dimensions"]) if "body_dimensions" in attrs
                    else BodyDimensions.average(float(attrs["body_height_mm"])))
            truth = read_body_file(args.data / subject / "Mocap_Data" / f"{subject}_body.toml")
            # the drops are near 0 in some body files: millimetres (run / file), not a ratio
            cells = [f"{mean(dims, k):.0f}/{mean(truth, k):.0f} mm" if k in MAY_BE_ZERO
                     else f"{mean(dims, k) / max(mean(truth, k), 1e-9):.2f}" for k in FITTED_KEYS]
            print(f"| {run} | {action} | " + " | ".join(cells)
                  + f" | {dims.height / truth.height:.2f} |")


if __name__ == "__main__":
    main()
