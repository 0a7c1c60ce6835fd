"""Tracking speed at the paper's working point: 7 cameras, 20 mm voxels, 6 layers × 600 particles.

Renders a procedural walk once (cached in --data), measures every frame once and steps each
configuration (``--variants``: the joint search, the hierarchical search with and without
refinement) on the same measurement, in turn. Reports the median seconds of the measurement stage
(decode excluded: subtract, carve, surface, smooth) and, per variant, the likelihood evaluations
per frame, their time, the rest of the filter, frames per second (measurement + step) of the
median frame and the speed ratio to the first variant, and the mean frame's time and frames per
second (which count the periodic limb sweep, ``filter.limb_sweep_every``). The first frame (JIT
compilation, tables) is left out. Every variant has ``TrackConfig``'s defaults but what it names.

Usage: ``python scripts/bench_tracking.py [--frames 30] [--layers 6] [--particles 600]
[--variants joint,hierarchical]``

Feeds docs/benchmarks.md, "Speed" (run N times as a whole process, the medians quoted) and the
frames per second of the ablation in "Accuracy on rendered clips".
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from pathlib import Path

from voxelmocap import cpu_paths

# Before NumPy loads: the NumPy loops and OpenBLAS kernels `voxelmocap track` runs with, so that
# these runs are the command's on any CPU (voxelmocap.cpu_paths).
cpu_paths.pin()

import numpy as np  # noqa: E402

from voxelmocap.config import TrackConfig, with_overrides  # noqa: E402
from voxelmocap.io.humaneva import Dataset  # noqa: E402
from voxelmocap.pose.starts import ground_truth_landmarks  # noqa: E402
from voxelmocap.pose.tracker import BodyTracker  # noqa: E402
from voxelmocap.run.bodies import body_model_for  # noqa: E402
from voxelmocap.run.measurement import MeasurementRunner  # noqa: E402
from voxelmocap.synth import generate  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", default="/tmp/voxelmocap_bench_walk", help="data cache folder")
    parser.add_argument("--frames", type=int, default=30)
    parser.add_argument("--layers", type=int, default=6)
    parser.add_argument("--particles", type=int, default=600)
    parser.add_argument("--voxel-size", type=float, default=20.0)
    parser.add_argument("--variants", default="joint,hierarchical,hierarchical+refine",
                        help="configurations tracked side by side on the same measurements")
    args = parser.parse_args()
    args.load = " ".join(f"{v:.2f}" for v in os.getloadavg())

    data = Path(args.data)
    if not (data / "S1" / "Mocap_Data" / "Walking_1.xml").exists():
        generate(data, motion="walk", frames=args.frames, progress=True)
    seq = Dataset(data).sequence("S1", "Walking_1")
    gt = seq.ground_truth()
    base = with_overrides(TrackConfig(), **{"filter.layers": args.layers,
                                            "filter.particles": args.particles,
                                            "measurement.voxel_size": args.voxel_size})
    variants = {}
    for name in args.variants.split(","):
        if name not in VARIANTS:
            raise SystemExit(f"unknown variant {name!r}; choose from {', '.join(VARIANTS)}")
        variants[name] = with_overrides(base, **VARIANTS[name])
    model, _ = body_model_for(seq, gt)
    t0 = time.perf_counter()
    runner = MeasurementRunner(seq, base, log=None)
    setup = time.perf_counter() - t0
    trackers = {name: BodyTracker(model, cfg, seed=0) for name, cfg in variants.items()}
    frames = seq.frame_numbers[: args.frames]
    t_meas = []
    t_ll = {name: [] for name in trackers}
    t_step = {name: [] for name in trackers}
    evals = {name: [] for name in trackers}
    for frame_number, images in seq.frames(frames):
        t0 = time.perf_counter()
        measurement = runner.measure(images)
        t_meas.append(time.perf_counter() - t0)
        # the variants step on the same measurement one after the other, in turn each frame
        for name, tracker in trackers.items():
            t1 = time.perf_counter()
            if not tracker.initialised:
                tracker.initialise(measurement, ground_truth_landmarks(gt, frame_number),
                                   frame=frame_number)
            record = tracker.step(measurement, frame=frame_number)
            t_step[name].append(time.perf_counter() - t1)
            t_ll[name].append(record.likelihood_seconds)
            evals[name].append(tracker.filter.step_evaluations)
    t_meas = np.array(t_meas)
    print(f"machine: {platform.machine()}, {platform.processor() or 'cpu'}; "
          f"{len(seq.camera_names)} cameras, grid {runner.grid.shape} at {args.voxel_size:g} mm, "
          f"{len(frames)} frames; load average before: {args.load}")
    print(f"set-up (background models, grid, carving tables): {setup:.2f} s")
    print(f"measurement per frame (subtract, carve, surface, smooth), median over frames "
          f"2..N: {np.median(t_meas[1:]) * 1e3:.1f} ms")
    # frames/s from the median frame, and from the mean frame: a periodic step (the limb sweep
    # every ``filter.limb_sweep_every`` frames) does not move the median
    print(f"{'variant':<24s} {'evals/frame':>11s} {'likelihood ms':>13s} {'µs/eval':>8s} "
          f"{'filter ms':>9s} {'total ms':>9s} {'frames/s':>8s} {'ratio':>6s} "
          f"{'mean ms':>8s} {'mean f/s':>8s}")
    first = None
    for name in trackers:
        ll = np.median(t_ll[name][1:])
        step = np.median(t_step[name][1:])
        per_frame = t_meas[1:] + np.array(t_step[name][1:])
        total, mean = np.median(per_frame), np.mean(per_frame)
        ev = np.median(evals[name][1:])
        first = first or total
        print(f"{name:<24s} {ev:11.0f} {ll * 1e3:13.1f} {ll / ev * 1e6:8.1f} "
              f"{(step - ll) * 1e3:9.1f} {total * 1e3:9.1f} {1.0 / total:8.2f} "
              f"{first / total:6.2f} {mean * 1e3:8.1f} {1.0 / mean:8.2f}")


#: Named configurations compared side by side (``--variants``).
VARIANTS = {
    "joint": {"filter.search": "joint"},
    "hierarchical": {"filter.search": "hierarchical", "filter.refine_evaluations": 0},
    "hierarchical+refine": {"filter.search": "hierarchical", "filter.refine_evaluations": 40},
    "no-limb-sweep": {"filter.search": "hierarchical", "filter.refine_evaluations": 40,
                      "filter.limb_sweep_every": 0},
}


if __name__ == "__main__":
    main()
