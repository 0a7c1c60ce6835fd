"""The body's height from the voxels, against the head top of the ground truth.

For each render of ``bench_facing.py`` (``OUT/renders/<clip>_h<deg>_n<k>_f<frames>``: ``data``
with ground truth, ``stripped`` without), the chosen frames are measured as a run without the
answer measures them, and three heights are printed (mm above the lowest voxel's floor): the
highest voxel within 150 mm of the trunk's vertical (the rule before b62ae79, computed here by
brute force), ``find_extremities(...).axis_top`` (today's rule: the head's top, a hand held above
it left out) and the ground truth's head top (``headDistal``). The body of a run without a body
file is the average adult scaled to frame 1's height.

Usage::

    python scripts/voxel_height_check.py OUT/renders/*_f40 [--frames 1,12,23] [--changed]

Feeds docs/benchmarks.md, "Accuracy" and "The 80 runs" (which renders' body size b62ae79
changed).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from voxelmocap.config import TrackConfig
from voxelmocap.io.humaneva import Dataset
from voxelmocap.joints import ENDPOINT_NAMES
from voxelmocap.measure.detect import find_extremities
from voxelmocap.run.measurement import MeasurementRunner

#: the subjects of the five clips (scripts/bench_facing.py renders them as S1–S5)
SUBJECTS = {"Walking": "S1", "Jog": "S2", "Box": "S3", "Gestures": "S4", "Combo": "S5"}


def highest_on_axis(observation, centre, radius_mm: float = 150.0) -> float:
    """Top (mm) of the highest occupied voxel within ``radius_mm`` of the vertical through
    ``centre``."""
    grid = observation.grid
    points = grid.centre_of(np.argwhere(observation.occupancy))
    near = np.hypot(points[:, 0] - centre[0], points[:, 1] - centre[1]) <= radius_mm
    return float(points[near, 2].max() + grid.voxel_size / 2)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("renders", nargs="+", type=Path)
    parser.add_argument("--frames", default="1", help="comma-separated frames (default 1)")
    parser.add_argument("--changed", action="store_true", help="print only the frames whose "
                                                              "height the two rules disagree on")
    args = parser.parse_args()
    frames = [int(f) for f in args.frames.split(",")]
    head = ENDPOINT_NAMES.index("headDistal")
    print("| render | frame | highest on the axis | head top (today) | truth's head top |")
    print("|---|---:|---:|---:|---:|")
    for render in args.renders:
        action = render.name.split("_")[0]
        subject, name = SUBJECTS[action], f"{action}_1"
        seq = Dataset(render / "stripped").sequence(subject, name)
        truth = Dataset(render / "data").sequence(subject, name).ground_truth()
        runner = MeasurementRunner(seq, TrackConfig())
        for frame, observation in runner.observations(frames):
            ex = find_extremities(observation.occupancy, observation.grid, max_extremities=0)
            old = highest_on_axis(observation, ex.centre)
            if args.changed and old == ex.axis_top:
                continue
            top = truth.endpoints[truth.index_of(np.array([frame]))[0], head, 2]
            print(f"| {render.name} | {frame} | {old:.0f} | {ex.axis_top:.0f} | {top:.0f} |",
                  flush=True)


if __name__ == "__main__":
    main()
