"""Benchmark of the voxel likelihood: fast per-column kernel vs the per-voxel reference.

A walking subject (a sinusoidal gait in joint angles, built here, no generator needed) is
rasterised at 20 mm voxels on a HumanEva-sized grid (3 m × 3 m × 2.2 m); its occupancy is the
measurement. For each of a few gait phases, 600 particles are drawn around the true pose (Gaussian
noise, clipped into the legal ranges), and ``log_likelihood`` is timed with numba on 1 thread and
on all threads, the reference (``part_counts_reference``, numpy) on a subset of the particles.
The kernel is warmed before timing (first-call time, including numba's cache load or compile, is
printed separately). Times are medians over repeats; the ratio is measured side by side in one run.

    python scripts/bench_likelihood.py [--particles 600] [--repeats 5] [--reference 20]
    python scripts/bench_likelihood.py --validate 3000   # fast == reference on random poses

``--validate N`` instead compares the integer counts of the fast kernel and the reference on N
random legal poses (batches of 100 at voxel sizes of 10–50 mm, random grid offsets, a third of the
batches with cylinder upper arms (R = 1), 30 % of the angles snapped to multiples of 45°).

Feeds docs/benchmarks.md, "Likelihood" (speed and exactness of the voxel likelihood).
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import numba
import numpy as np

from voxelmocap.body import STATE_INDEX, BodyModel
from voxelmocap.grid import VoxelGrid
from voxelmocap.score.likelihood import (
    Measurement,
    log_likelihood,
    part_counts,
    part_counts_reference,
    rasterise,
)

DEG = np.pi / 180


def walking_state(model: BodyModel, phase: float) -> np.ndarray:
    """(27,) state of a sinusoidal walk at gait phase ``phase`` (rad), moving along +Y."""
    x = model.default_state()
    s = np.sin(phase)
    x[STATE_INDEX["root_y"]] = -600.0 + 600.0 * phase / np.pi      # ~1.2 m per gait cycle
    x[STATE_INDEX["root_z"]] -= 20.0 * (1 - np.cos(2 * phase)) / 2
    x[STATE_INDEX["root_yaw"]] = 0.1 * s
    x[STATE_INDEX["waist_twist"]] = -0.1 * s
    for side, sign in (("l", 1.0), ("r", -1.0)):
        x[STATE_INDEX[f"{side}_hip_flex"]] = sign * 25 * DEG * s
        x[STATE_INDEX[f"{side}_knee"]] = 30 * DEG * (1 + np.sin(phase * sign + 0.5 * np.pi)) / 2
        x[STATE_INDEX[f"{side}_shoulder_flex"]] = -sign * 20 * DEG * s
        x[STATE_INDEX[f"{side}_shoulder_abd"]] = 8 * DEG
        x[STATE_INDEX[f"{side}_elbow"]] = 20 * DEG + 10 * DEG * (1 - sign * s)
    return model.clip(x)[0]


def median_time(fn, repeats: int) -> tuple[float, float]:
    """Median wall-clock and process CPU time (s) of ``fn()``; CPU time sums all threads, so
    it is the cost per core even when other processes share the machine."""
    wall, cpu = [], []
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        fn()
        wall.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    return float(np.median(wall)), float(np.median(cpu))


def validate(n_poses: int, seed: int = 123) -> int:
    """Compare fast and reference counts on random poses; return the number of differing poses."""
    from voxelmocap.body import BodyDimensions

    rng = np.random.default_rng(seed)
    bad = total = 0
    for batch in range(max(1, n_poses // 100)):
        vs = float(rng.choice([10.0, 15.0, 20.0, 25.0, 33.3, 40.0, 50.0]))
        dims = BodyDimensions.average(rng.uniform(1500, 1950))
        if batch % 3 == 0:
            dims = dims.replace(w_forearm=dims.w_upper_arm)
        model = BodyModel(dims)
        shape = tuple(int(v) for v in np.ceil(np.full(3, 2000.0) / vs))
        grid = VoxelGrid((-1000.0 + rng.choice([0.0, rng.uniform(-vs, vs)]), -1000.0, 0.0), vs,
                         shape)
        meas = Measurement(rng.random(grid.shape) < 0.3, grid)
        x = rng.uniform(model.low, model.high, (100, 27))
        x[:, :2] = rng.uniform(-900, 900, (100, 2))
        snap = rng.random(x.shape) < 0.3
        snap[:, :3] = False
        cols = np.nonzero(snap)[1]
        x[snap] = np.clip(np.round(x[snap] / (np.pi / 4)) * (np.pi / 4), model.low[cols],
                          model.high[cols])
        diff = part_counts(meas, model, x) != part_counts_reference(meas, model, x)
        bad += int(diff.any(axis=(1, 2)).sum())
        total += len(x)
    print(f"validate: {bad} of {total} random poses differ between fast and reference counts")
    return bad


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--particles", type=int, default=600)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--reference", type=int, default=20, help="particles timed with the reference")
    ap.add_argument("--phases", type=int, default=3)
    ap.add_argument("--voxel", type=float, default=20.0)
    ap.add_argument("--validate", type=int, default=0, metavar="N",
                    help="compare fast and reference on N random poses instead of timing")
    args = ap.parse_args(argv)
    if args.validate:
        return 1 if validate(args.validate) else 0

    model = BodyModel()
    grid = VoxelGrid.from_bounds((-1500.0, -1500.0, 0.0), (1500.0, 1500.0, 2200.0), args.voxel)
    rng = np.random.default_rng(0)
    noise = np.r_[np.full(3, 30.0), np.full(3, 0.05), np.full(21, 0.12)]

    t0 = time.perf_counter()
    x0 = walking_state(model, 0.0)
    m0 = Measurement(rasterise(model, x0, grid) > 0, grid)
    log_likelihood(m0, model, x0[None])
    first_call = time.perf_counter() - t0

    n_threads = numba.get_num_threads()
    rows = []
    for phase in np.linspace(0.0, 2 * np.pi, args.phases, endpoint=False):
        truth = walking_state(model, phase)
        meas = Measurement(rasterise(model, truth, grid) > 0, grid, sigma=1.0)
        states = model.clip(truth + rng.normal(size=(args.particles, 27)) * noise)
        sub = states[: args.reference]
        exact = bool(np.array_equal(part_counts(meas, model, sub),
                                    part_counts_reference(meas, model, sub)))
        geo_t = median_time(lambda s=states: model.geometry(s), args.repeats)
        numba.set_num_threads(1)
        fast1 = median_time(lambda m=meas, s=states: log_likelihood(m, model, s), args.repeats)
        numba.set_num_threads(n_threads)
        fastn = median_time(lambda m=meas, s=states: log_likelihood(m, model, s), args.repeats)
        ref = median_time(lambda m=meas, s=sub: part_counts_reference(m, model, s),
                          max(1, args.repeats // 2))
        n, k = len(states), len(sub)
        rows.append((phase, fast1[1] / n, fastn[0] / n, fastn[1] / n, ref[1] / k,
                     geo_t[1] / n, fast1[0] / n, exact))

    us = 1e6
    print(f"# bench_likelihood  {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}  "
          f"{platform.machine()}, {os.cpu_count()} CPUs, numba {numba.__version__}, "
          f"{n_threads} threads")
    print(f"# grid {grid.shape} at {args.voxel:g} mm, {args.particles} particles/phase, "
          f"reference on {args.reference}; first call (cache load/compile + 1 particle) "
          f"{first_call:.2f} s")
    print("# µs per particle; cpu = process CPU time (all threads), wall = elapsed")
    print("phase  fast_1thr_cpu  fast_1thr_wall  fast_all_wall  fast_all_cpu  reference_cpu  "
          "ref/fast  FK_cpu  exact")
    for phase, f1, fw, fc, r, g, w1, exact in rows:
        print(f"{phase:5.2f}  {f1 * us:13.1f}  {w1 * us:14.1f}  {fw * us:13.1f}  {fc * us:12.1f}  "
              f"{r * us:13.0f}  {r / f1:8.0f}  {g * us:6.1f}  {exact}")
    med = np.median(np.array([r[1:7] for r in rows]), axis=0)
    f1, fw, fc, rf, g, _ = med
    print(f"median µs/particle: fast 1 thread {f1 * us:.1f} cpu (FK {g * us:.1f} of it), "
          f"{n_threads} threads {fw * us:.1f} wall / {fc * us:.1f} cpu, reference {rf * us:.0f} "
          f"cpu; reference/fast = {rf / f1:.0f}x; 6 x 600 evaluations = {fw * 3600 * 1e3:.0f} ms "
          f"wall")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
