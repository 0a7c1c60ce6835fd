"""Benchmark of the synthetic sequence generator (``voxelmocap synth``).

Measures, in one run:

1. the end-to-end time of ``generate`` for N frames × 7 cameras × 640×480 (the issue's target:
   100 frames well under a minute), including the camera-lead frames, the 7 background videos
   and the encoding;
2. side by side, per image (medians over frames and repeats): ray casting over the person's
   region of interest with per-primitive pixel boxes vs without boxes vs over the whole image,
   and the floor shadow with vs without its per-primitive culling discs (each pair gives
   identical pixels; the tests check it);
3. the sensor model (blur, gain, noise, 8-bit) per image.

Usage: ``python scripts/bench_synth.py [--frames 100] [--repeats 3] [--codec MJPG]``

Feeds docs/benchmarks.md, "Synthetic rendering".
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np


def _median_time(fn, repeats):
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=100)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--codec", default="MJPG")
    parser.add_argument("--e2e-runs", type=int, default=1)
    args = parser.parse_args()

    from voxelmocap.io.calibration import read_rig
    from voxelmocap.synth import _render_kernels as K
    from voxelmocap.synth import default_rig_path, generate, procedural_points
    from voxelmocap.synth.body_shape import BodyShape, body_primitives
    from voxelmocap.synth.render import _VIEW_CACHE, Renderer, _shadow_discs
    from voxelmocap.synth.scene import AMBIENT, LIGHT, sensor

    rig = read_rig(default_rig_path())
    # warm-up: numba compilation / cache load, view tables
    tmp = Path(tempfile.mkdtemp(prefix="bench_synth_"))
    generate(tmp / "warm", frames=2, cameras=["C1"], progress=False, background_frames=2)

    e2e, e2e_cpu = [], []
    for k in range(args.e2e_runs):
        out = tmp / f"run{k}"
        _VIEW_CACHE.clear()  # every run builds its 7 camera views (rays, room) from scratch
        t0, c0 = time.perf_counter(), time.process_time()
        generate(out, motion="walk", frames=args.frames, progress=False, codec=args.codec,
                 seed=k, background_frames=2)
        e2e.append(time.perf_counter() - t0)
        e2e_cpu.append(time.process_time() - c0)
        size = sum(p.stat().st_size for p in out.rglob("*") if p.is_file())
        shutil.rmtree(out)
    from voxelmocap.synth.writer import _write_backgrounds

    t0 = time.perf_counter()
    _write_backgrounds(Renderer(rig), rig, tmp / "bg", args.codec, 60.0, 120,
                       np.random.default_rng(0), 1.0, False)
    bg_time = time.perf_counter() - t0

    renderer = Renderer(rig)
    shape = BodyShape.for_subject("S1", 1750)
    pts = procedural_points("walk", np.arange(20) / 60.0)
    prims = [body_primitives(p, shape) for p in pts]
    roi_t, nobox_t, full_t, cull_t, nocull_t = [], [], [], [], []
    for cam in rig:
        view = renderer._views[cam.name]
        H, W = view.bg_depth.shape
        full = np.array([0, W, 0, H], dtype=np.int64)
        for pr in prims:
            caps = np.ascontiguousarray(pr.capsules)
            ells = np.ascontiguousarray(pr.ellipsoids)
            cc, ec = pr.capsule_colours, pr.ellipsoid_colours
            roi = renderer.roi(cam.name, pr, shadow=False)
            sroi = renderer.roi(cam.name, pr, body=False)

            cb, eb = renderer.primitive_boxes(cam.name, pr)
            nb_c = np.tile([-(1 << 30), 1 << 30, -(1 << 30), 1 << 30], (len(caps), 1))
            nb_e = np.tile([-(1 << 30), 1 << 30, -(1 << 30), 1 << 30], (len(ells), 1))

            def cast(box, cb, eb, caps=caps, ells=ells, cc=cc, ec=ec, view=view):
                img = view.background.copy()
                mask = np.zeros(view.bg_depth.shape, bool)
                depth = np.zeros(view.bg_depth.shape, np.float32)
                K.cast_body(view.rays, view.origin, box, caps, cc, cb, ells, ec, eb,
                            view.bg_depth, LIGHT, AMBIENT, img, mask, depth)

            roi_t.append(_median_time(lambda roi=roi, cast=cast, cb=cb, eb=eb: cast(roi, cb, eb),
                                      args.repeats))
            nobox_t.append(_median_time(
                lambda roi=roi, cast=cast, a=nb_c, b=nb_e: cast(roi, a, b), args.repeats))
            full_t.append(_median_time(
                lambda full=full, cast=cast, a=nb_c, b=nb_e: cast(full, a, b), args.repeats))
            semi = 1.0 / np.linalg.svd(ells[:, 3:].reshape(-1, 3, 3), compute_uv=False)
            r_mean = semi.mean(axis=1)
            cap_cull, ell_cull = _shadow_discs(caps, ells[:, :3], semi.max(axis=1), r_mean)
            none = np.column_stack([np.zeros((len(caps), 2)), np.full(len(caps), 1e12)])
            none_e = np.column_stack([np.zeros((len(ells), 2)), np.full(len(ells), 1e12)])

            def shadow(c1, c2, caps=caps, ells=ells, r_mean=r_mean, roi=sroi, view=view):
                img = view.background.copy()
                K.floor_shadow(view.floor_points, view.is_floor, roi, caps, ells, r_mean, c1, c2,
                               LIGHT, 0.5, img)

            cull_t.append(_median_time(lambda s=shadow, a=cap_cull, b=ell_cull: s(a, b),
                                       args.repeats))
            nocull_t.append(_median_time(lambda s=shadow, a=none, b=none_e: s(a, b),
                                         args.repeats))
    shutil.rmtree(tmp, ignore_errors=True)
    rng = np.random.default_rng(0)
    bg = renderer.background("C1")
    sens_c = _median_time(lambda: sensor(bg, gray=False, gain=1.0, noise_sigma=2.0, rng=rng),
                          5 * args.repeats)
    sens_g = _median_time(lambda: sensor(bg, gray=True, gain=1.0, noise_sigma=2.0, rng=rng),
                          5 * args.repeats)

    med = statistics.median
    n_img = args.frames * len(rig)
    print(f"end-to-end: {args.frames} frames x {len(rig)} cameras x 640x480 ({args.codec}, lead "
          f"frames and camera/room set-up included): median {med(e2e):.1f} s wall, "
          f"{med(e2e_cpu):.1f} s CPU over "
          f"{len(e2e)} run(s) = {1000 * med(e2e) / n_img:.1f} ms wall per synchronised image; "
          f"{size / 1e6:.0f} MB written")
    print(f"background videos (7 x 120 frames, written by the same run of generate): "
          f"{bg_time:.1f} s")
    print("per image (serial kernels), medians:")
    print(f"  ray casting: ROI + per-primitive boxes {1000 * med(roi_t):.2f} ms | ROI "
          f"only {1000 * med(nobox_t):.2f} ms (x{med(nobox_t) / med(roi_t):.1f}) | whole image, "
          f"no boxes {1000 * med(full_t):.2f} ms (x{med(full_t) / med(roi_t):.1f})")
    print(f"  floor shadow: culled {1000 * med(cull_t):.2f} ms vs unculled "
          f"{1000 * med(nocull_t):.2f} ms -> x{med(nocull_t) / med(cull_t):.1f}")
    print(f"  sensor model: colour {1000 * sens_c:.2f} ms, grey {1000 * sens_g:.2f} ms")
    print(f"load average during the run: {' '.join(f'{x:.1f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
