"""Benchmark of the silhouette cue's cover kernel (``_silhouette_kernels.cover_counts``).

Four cameras 3.5 m around a standing subject (1088 × 1920 portrait images, as the Pose2Sim
demo's), the silhouette each sees of the true pose reduced to the cue's ``silhouette_size``
(320 px along the longer side), and 600 particles drawn around the pose (Gaussian noise on the
27 parameters, clipped into the legal ranges), as the filter scores them. ``cover_counts`` is
timed per call (all particles, one camera) after a warm-up call (numba's cache load or compile);
the outlines it consumes (``outline_pixels``) are timed too. Times are medians over the repeats.
No external data.

    python scripts/bench_silhouette_cue.py [--particles 600] [--repeats 200] [--seed 0]

For a before/after comparison run it from two checkouts side by side (the counts it prints must
be equal: the kernel's output does not depend on how it is computed).

Feeds docs/benchmarks.md, "Image cues" (the silhouette cue's cover kernel).
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from types import SimpleNamespace

import numba
import numpy as np

from voxelmocap.body import BodyModel
from voxelmocap.camera import Camera
from voxelmocap.measure import _silhouette_kernels as sk
from voxelmocap.score.cues.contours import body_mask, outline_pixels
from voxelmocap.score.cues.frame import CueFrame


def _camera(name: str, angle: float, size=(1088, 1920)) -> Camera:
    """A camera 3.5 m from the origin at ``angle`` (rad), 1.2 m up, looking at (0, 0, 900)."""
    eye = np.array([3500.0 * np.cos(angle), 3500.0 * np.sin(angle), 1200.0])
    z = np.array([0.0, 0.0, 900.0]) - eye
    z /= np.linalg.norm(z)
    x = np.cross(z, [0, 0, 1.0])
    x /= np.linalg.norm(x)
    rot = np.stack([x, np.cross(z, x), z])
    return Camera(name, fc=(1400.0, 1400.0), cc=(size[0] / 2, size[1] / 2), R=rot,
                  T=-rot @ eye, size=size)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--particles", type=int, default=600)
    ap.add_argument("--repeats", type=int, default=200)
    ap.add_argument("--size", type=int, default=320, help="[cues] silhouette_size")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)

    rng = np.random.default_rng(args.seed)
    model = BodyModel()
    truth = model.default_state()
    truth[[11, 12, 19, 25]] = (0.6, 0.9, 0.5, 0.8)       # an arm out, a knee raised
    noise = np.full(model.n_dims, 0.1)
    noise[:3] = 40.0
    particles = model.clip(truth + rng.normal(size=(args.particles, model.n_dims)) * noise)
    geo = model.geometry(particles)
    cameras = [_camera(f"cam{k + 1:02d}", a)
               for k, a in enumerate(np.linspace(0, 2 * np.pi, 5)[:-1])]
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, numba threads "
          f"{numba.get_num_threads()}; {args.particles} particles, {len(cameras)} cameras, "
          f"masks {args.size} px along the longer side, {args.repeats} repeats")
    # the silhouettes reduced exactly as the cue reduces a frame's (CueFrame.silhouette)
    frame = CueFrame(SimpleNamespace(
        cameras=cameras, masks=[body_mask(model.geometry(truth[None]), c) for c in cameras],
        images=[np.zeros((c.size[1], c.size[0]), np.uint8) for c in cameras]))
    rows = []
    for k, cam in enumerate(cameras):
        mask, factors = frame.silhouette(k, args.size)
        hit = np.empty(args.particles, np.int64)
        extra = np.empty(args.particles, np.int64)
        pixels, valid = outline_pixels(geo, cam, factors)               # warm-up
        sk.cover_counts(pixels, valid, mask, hit, extra)
        t_out, t_cover = [], []
        for _ in range(args.repeats):
            t0 = time.perf_counter()
            pixels, valid = outline_pixels(geo, cam, factors)
            t1 = time.perf_counter()
            sk.cover_counts(pixels, valid, mask, hit, extra)
            t2 = time.perf_counter()
            t_out.append(t1 - t0)
            t_cover.append(t2 - t1)
        rows.append((cam.name, int(mask.sum()), 1e3 * np.median(t_out), 1e3 * np.median(t_cover),
                     int(hit.sum()), int(extra.sum())))
    print("| camera | silhouette px | outline_pixels (ms, median) | cover_counts (ms, median) | "
          "Σ hit | Σ extra |")
    print("|---|---|---|---|---|---|")
    for name, n, a, b, hs, es in rows:
        print(f"| {name} | {n} | {a:.2f} | {b:.2f} | {hs} | {es} |")
    print(f"cover_counts, median of the cameras' medians: {np.median([r[3] for r in rows]):.2f} ms "
          f"per call of {args.particles} particles")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
