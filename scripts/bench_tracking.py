"""Tracking speed at the paper's working point: 7 cameras, 20 mm voxels, 6 layers × 600 particles.

Renders a procedural walk once (cached in --data), then tracks it and reports, per frame, the
median seconds of the measurement stage (decode excluded: subtract, carve, surface, smooth), the
likelihood evaluations (6 × 600 per frame) and the rest of the filter, plus frames per second.
The first frame (JIT compilation, tables) is reported separately.

Usage: ``python scripts/bench_tracking.py [--frames 30] [--layers 6] [--particles 600]``
"""

from __future__ import annotations

import argparse
import platform
import time
from pathlib import Path

import numpy as np

from voxelmocap.config import TrackConfig, with_overrides
from voxelmocap.io.humaneva import Dataset
from voxelmocap.pipeline import MeasurementRunner, body_model_for
from voxelmocap.synth import generate
from voxelmocap.tracker import BodyTracker, ground_truth_landmarks


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", default="/tmp/voxelmocap_bench_walk", help="data cache folder")
    parser.add_argument("--frames", type=int, default=30)
    parser.add_argument("--layers", type=int, default=6)
    parser.add_argument("--particles", type=int, default=600)
    parser.add_argument("--voxel-size", type=float, default=20.0)
    args = parser.parse_args()

    data = Path(args.data)
    if not (data / "S1" / "Mocap_Data" / "Walking_1.xml").exists():
        generate(data, motion="walk", frames=args.frames, progress=True)
    seq = Dataset(data).sequence("S1", "Walking_1")
    gt = seq.ground_truth()
    config = with_overrides(TrackConfig(), **{"filter.layers": args.layers,
                                              "filter.particles": args.particles,
                                              "measurement.voxel_size": args.voxel_size})
    model, _ = body_model_for(seq, gt)
    t0 = time.perf_counter()
    runner = MeasurementRunner(seq, config, log=None)
    setup = time.perf_counter() - t0
    tracker = BodyTracker(model, config, seed=0)
    frames = seq.frame_numbers[: args.frames]
    t_meas, t_ll, t_total = [], [], []
    for frame_number, images in seq.frames(frames):
        t0 = time.perf_counter()
        measurement = runner.measure(images)
        t1 = time.perf_counter()
        if not tracker.initialised:
            tracker.initialise(measurement, ground_truth_landmarks(gt, frame_number),
                               frame=frame_number)
        record = tracker.step(measurement, frame=frame_number)
        t2 = time.perf_counter()
        t_meas.append(t1 - t0)
        t_ll.append(record.likelihood_seconds)
        t_total.append(t2 - t0)
    t_meas, t_ll, t_total = (np.array(v) for v in (t_meas, t_ll, t_total))
    rest = t_total - t_meas - t_ll
    evals = args.layers * args.particles
    print(f"machine: {platform.machine()}, {platform.processor() or 'cpu'}; "
          f"{len(seq.camera_names)} cameras, grid {runner.grid.shape} at {args.voxel_size:g} mm, "
          f"{args.layers} layers × {args.particles} particles, {len(frames)} frames")
    print(f"set-up (background models, grid, carving tables): {setup:.2f} s")
    print(f"first frame (JIT compilation included):           {t_total[0]:.2f} s")
    print("per frame, median over frames 2..N:")
    print(f"  measurement (subtract, carve, surface, smooth):  {np.median(t_meas[1:]) * 1e3:8.1f} ms")
    print(f"  likelihood ({evals} evaluations):               {np.median(t_ll[1:]) * 1e3:8.1f} ms"
          f"  ({np.median(t_ll[1:]) / evals * 1e6:.1f} µs per particle)")
    print(f"  filter (propagation, resampling, β search):      {np.median(rest[1:]) * 1e3:8.1f} ms")
    print(f"  total:                                           {np.median(t_total[1:]) * 1e3:8.1f} ms"
          f"  = {1.0 / np.median(t_total[1:]):.2f} frames/s")


if __name__ == "__main__":
    main()
