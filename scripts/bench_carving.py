"""Benchmark: carving speed against Open3D and a NumPy reference, and the whole measurement stage.

Everything is measured side by side in one run on the same masks and grid: the 7-camera
``calib/humaneva_i_like`` rig (640×480), the floor-standing box all cameras see at 2 cm voxels
(``VoxelGrid.from_rig``, ~3.8 M voxels), and silhouettes of a body made of ellipsoids, drawn by
casting each pixel's ray (so the masks never come from the carver's projection).

1. Carving one frame: ``Carver.carve`` (tables built once, not timed per frame; their build time is
   printed), ``carve_reference`` (plain NumPy), and Open3D's ``VoxelGrid.carve_silhouette``
   (dense grid + one call per camera). Open3D differs in three ways, and the benchmark measures
   how much each changes the result:
   * the corner rule: a voxel survives a view when any of its 8 corners falls on a silhouette pixel;
   * bilinear mask lookup: a corner counts when the bilinearly interpolated mask is > 0, i.e. when
     any of the 4 surrounding pixels is set (a one-pixel dilation);
   * a pinhole without distortion: it is given masks undistorted with OpenCV (same K), and on a
     distortion-free copy of the rig (exact masks) to isolate the first two differences.
   ``keep_voxels_outside_image=True`` matches our rule that a camera never carves what it does not see.
2. The measurement stage per frame: decode (MJPG AVIs written by the benchmark), background
   subtraction (Gaussian model), carving, surface voxels and smoothing, for 7 cameras.

Run: ``python scripts/bench_carving.py`` (about two minutes on 2 cores); ``--quick`` for a smoke run.

Feeds docs/benchmarks.md, "Carving" (carving one frame against Open3D and the NumPy reference, how
Open3D's occupancy differs, the measurement stage per frame).
"""

from __future__ import annotations

import argparse
import platform
import statistics
import tempfile
import time
from pathlib import Path

import cv2
import numba
import numpy as np
from scipy import ndimage

from voxelmocap.camera import Camera, Rig
from voxelmocap.grid import VoxelGrid
from voxelmocap.io.calibration import read_rig
from voxelmocap.measure import _carving_kernels
from voxelmocap.measure.carving import Carver, carve_reference
from voxelmocap.measure.silhouette import SilhouetteConfig, build_backgrounds
from voxelmocap.measure.stage import MeasurementStage
from voxelmocap.measure.surface import smooth_surface, surface_voxels

RIG_DIR = Path(__file__).resolve().parents[1] / "calib" / "humaneva_i_like"

#: A standing person as ellipsoids: centre (mm), semi-axes (mm).
BODY = [
    ((0, 0, 1250), (170, 110, 290)),     # torso
    ((0, 0, 1670), (95, 105, 120)),      # head
    ((0, 0, 930), (160, 105, 120)),      # pelvis
    ((-95, 0, 680), (75, 75, 240)),      # thighs
    ((95, 30, 680), (75, 75, 240)),
    ((-100, -20, 250), (55, 55, 230)),   # shins
    ((105, 80, 260), (55, 55, 230)),
    ((-240, 0, 1310), (50, 50, 170)),    # upper arms
    ((240, 40, 1310), (50, 50, 170)),
    ((-270, 90, 1080), (42, 42, 150)),   # forearms
    ((280, 160, 1100), (42, 42, 150)),
]
OFFSET = np.array([250.0, -150.0, 0.0])


def body_mask(cam: Camera, offset=OFFSET) -> np.ndarray:
    """(H, W) bool: pixels whose ray hits one of the body's ellipsoids."""
    w, h = cam.size
    uu, vv = np.meshgrid(np.arange(w, dtype=float), np.arange(h, dtype=float))
    o, d = cam.rays(np.stack([uu.ravel(), vv.ravel()], axis=1))
    hit = np.zeros(len(o), dtype=bool)
    for centre, semi in BODY:
        semi = np.asarray(semi, float)
        oo = (o - (np.asarray(centre, float) + offset)) / semi
        dd = d / semi
        a = np.einsum("ij,ij->i", dd, dd)
        b = 2 * np.einsum("ij,ij->i", oo, dd)
        c = np.einsum("ij,ij->i", oo, oo) - 1
        disc = b * b - 4 * a * c
        far = (-b + np.sqrt(np.maximum(disc, 0))) / (2 * a)
        hit |= (disc >= 0) & (far > 0)
    return hit.reshape(h, w)


def median_time(fn, repeats: int) -> tuple[float, object]:
    """Median wall time of ``repeats`` calls (the minimum is kept in ``BEST``) and the last result."""
    times, out = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    BEST[fn] = min(times)
    return statistics.median(times), out


#: Best (minimum) time of each timed callable: on a shared machine the median carries the
#: neighbours' load, the minimum is closer to the code's own cost.
BEST: dict = {}


def open3d_dense(grid: VoxelGrid):
    """Open3D's dense voxel grid over our grid (voxel indices coincide with ours)."""
    import open3d as o3d

    size = grid.voxel_size
    dims = np.asarray(grid.shape) * size
    return o3d.geometry.VoxelGrid.create_dense(origin=grid.low, color=np.zeros(3), voxel_size=size,
                                               width=dims[0], height=dims[1], depth=dims[2])


def open3d_carve(cameras, masks, grid: VoxelGrid) -> np.ndarray:
    """Open3D dense grid + carve_silhouette per camera → (nx, ny, nz) bool on our grid."""
    import open3d as o3d

    vg = open3d_dense(grid)
    for cam, mask in zip(cameras, masks, strict=True):
        params = o3d.camera.PinholeCameraParameters()
        w, h = cam.size
        params.intrinsic = o3d.camera.PinholeCameraIntrinsic(w, h, cam.fc[0], cam.fc[1],
                                                             cam.cc[0], cam.cc[1])
        ext = np.eye(4)
        ext[:3, :3] = cam.R
        ext[:3, 3] = cam.T
        params.extrinsic = ext
        vg.carve_silhouette(o3d.geometry.Image(mask.astype(np.float32)), params,
                            keep_voxels_outside_image=True)
    occ = np.zeros(grid.shape, dtype=bool)
    idx = np.array([v.grid_index for v in vg.get_voxels()], dtype=np.int64).reshape(-1, 3)
    inside = np.all((idx >= 0) & (idx < np.asarray(grid.shape)), axis=1)
    occ[tuple(idx[inside].T)] = True
    return occ


def undistort_mask(cam: Camera, mask: np.ndarray) -> np.ndarray:
    """The mask as a distortion-free pinhole with the same K would see it (nearest neighbour)."""
    K, dist, _, _ = cam.to_opencv()
    w, h = cam.size
    map1, map2 = cv2.initUndistortRectifyMap(K, dist, None, K, (w, h), cv2.CV_32FC1)
    return cv2.remap(mask.astype(np.uint8), map1, map2, cv2.INTER_NEAREST) > 0


def compare(ours, other) -> str:
    extra = int(np.sum(other & ~ours))
    missing = int(np.sum(ours & ~other))
    n = max(int(ours.sum()), 1)
    return (f"ours {int(ours.sum())}, Open3D {int(other.sum())}: Open3D adds {extra} "
            f"(+{100 * extra / n:.1f} %) and drops {missing} ({100 * missing / n:.2f} %)")


def bench_carving(args, rig, grid):
    print(f"grid {grid.shape} = {grid.n_voxels / 1e6:.2f} M voxels of {grid.voxel_size:g} mm, "
          f"{len(rig)} cameras")
    masks = np.array([body_mask(c) for c in rig])
    _carving_kernels._warm_up()
    t0 = time.perf_counter()
    carver = Carver(rig, grid)
    t_build = time.perf_counter() - t0
    carver.carve(masks)  # first call: JIT / cache load
    f_ours = lambda: carver.carve(masks)  # noqa: E731
    t_ours, occ = median_time(f_ours, args.repeats)
    f_mv = lambda: carver.carve(masks, min_views=len(rig) - 1)  # noqa: E731
    t_mv, _ = median_time(f_mv, args.repeats)
    carver.use_bricks = False
    f_plain = lambda: carver.carve(masks)  # noqa: E731
    t_plain, plain = median_time(f_plain, args.repeats)
    threads = numba.get_num_threads()
    numba.set_num_threads(1)
    f_one = lambda: carver.carve(masks)  # noqa: E731
    t_one, _ = median_time(f_one, args.repeats)
    numba.set_num_threads(threads)
    carver.use_bricks = True
    f_ref = lambda: carve_reference(masks, rig, grid)  # noqa: E731
    t_ref, ref = median_time(f_ref, args.ref_repeats)
    assert np.array_equal(occ, ref), "fast carver disagrees with the NumPy reference"
    assert np.array_equal(occ, plain), "brick rejection disagrees with the per-voxel kernel"
    und = [undistort_mask(c, m) for c, m in zip(rig, masks, strict=True)]
    f_o3d = lambda: open3d_carve(rig, und, grid)  # noqa: E731
    t_o3d, o3d_occ = median_time(f_o3d, args.o3d_repeats)
    f_dense = lambda: open3d_dense(grid)  # noqa: E731
    t_dense, _ = median_time(f_dense, args.o3d_repeats)
    # distortion-free copy of the rig with exact masks: isolates corner rule + bilinear lookup
    rig0 = Rig(Camera(c.name, c.fc, c.cc, c.R, c.T, c.alpha_c, np.zeros(5), c.size) for c in rig)
    masks0 = np.array([body_mask(c) for c in rig0])
    occ0 = Carver(rig0, grid).carve(masks0)
    o3d0 = open3d_carve(rig0, masks0, grid)
    rows = [
        ("ours: Carver.carve (all views; brick rejection, serial)", t_ours, f_ours),
        ("ours: Carver.carve (min_views = 6)", t_mv, f_mv),
        (f"per-voxel kernel, no bricks ({threads} numba threads)", t_plain, f_plain),
        ("per-voxel kernel, no bricks (1 numba thread)", t_one, f_one),
        ("NumPy reference carve_reference", t_ref, f_ref),
        ("Open3D create_dense + carve_silhouette ×7 (1 thread)", t_o3d, f_o3d),
        ("  of which Open3D create_dense alone", t_dense, f_dense),
    ]
    best_ours = BEST[f_ours]
    print("\n| carving one frame | median | best | median / ours | best / ours |\n"
          "|---|---:|---:|---:|---:|")
    for name, t, fn in rows:
        print(f"| {name} | {1000 * t:.1f} ms | {1000 * BEST[fn]:.1f} ms | {t / t_ours:.1f}× | "
              f"{BEST[fn] / best_ours:.1f}× |")
    print(f"\ntables build (once per rig and grid): {t_build:.1f} s; medians of {args.repeats} "
          f"(ours), {args.ref_repeats} (reference), {args.o3d_repeats} (Open3D) runs; "
          "fast == per-voxel kernel == NumPy reference, voxel for voxel")
    print(f"- distortion-free rig, exact masks: {compare(occ0, o3d0)}")
    print(f"- real rig, Open3D given undistorted masks: {compare(occ, o3d_occ)}")
    return masks


def bench_stage(args, rig, grid):
    rng = np.random.default_rng(0)
    cfg = SilhouetteConfig()
    tmp = Path(tempfile.mkdtemp(prefix="bench_carving_"))
    bg_frames, paths = {}, {}
    moves = [np.array([40.0 * k, 15.0 * k, 0.0]) for k in range(args.frames)]
    for cam in rig:
        gray = cam.name.startswith("BW")
        tex = ndimage.gaussian_filter(rng.normal(size=(cam.height, cam.width, 3)), (10, 10, 0))
        tex = 60 + 120 * (tex - tex.min()) / (tex.max() - tex.min())
        if gray:
            tex = np.repeat(tex.mean(axis=2, keepdims=True), 3, axis=2)

        def shot(img, gray=gray):
            out = np.clip(np.rint(img + rng.normal(0, 2.5, img.shape)), 0, 255).astype(np.uint8)
            return out[:, :, 0] if gray else out

        bg_frames[cam.name] = [shot(tex) for _ in range(20)]
        path = tmp / f"{cam.name}.avi"
        writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 60.0, cam.size)
        for move in moves:
            img = tex.copy()
            img[body_mask(cam, OFFSET + move)] = (200.0, 200.0, 200.0) if gray else (40, 200, 90)
            frame = shot(img)
            writer.write(cv2.cvtColor(frame, cv2.COLOR_GRAY2BGR) if gray else frame)
        writer.release()
        paths[cam.name] = path
    backgrounds = build_backgrounds(cfg, rig.names, bg_frames)
    stage = MeasurementStage(rig, grid, backgrounds, cfg)
    caps = {n: cv2.VideoCapture(str(p)) for n, p in paths.items()}
    rows = {k: [] for k in ("decode", "subtract", "carve", "surface", "smooth", "total")}
    for _ in range(args.frames):
        t0 = time.perf_counter()
        images = {}
        for name, cap in caps.items():
            ok, frame = cap.read()
            assert ok
            images[name] = cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY) if name.startswith("BW") \
                else frame
        t_dec = time.perf_counter() - t0
        m = stage.measure(images)
        rows["decode"].append(t_dec)
        for k, v in m.timings.items():
            rows[k].append(v)
        rows["total"].append(time.perf_counter() - t0)
    for cap in caps.values():
        cap.release()
    print(f"\n| measurement stage, {len(rig)} cameras 640×480 | median ms per frame |\n|---|---:|")
    for k, v in rows.items():
        print(f"| {k} | {1000 * statistics.median(v):.1f} |")
    total = statistics.median(rows["total"])
    print(f"\n{args.frames} frames; {1 / total:.1f} frames/s; occupied voxels in the last frame: "
          f"{int(m.occupancy.sum())} (surface {int(surface_voxels(m.occupancy).sum())})")
    assert np.array_equal(m.smoothed, smooth_surface(m.surface, 1.0))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--voxel-size", type=float, default=20.0)
    parser.add_argument("--repeats", type=int, default=20, help="runs of our carver")
    parser.add_argument("--ref-repeats", type=int, default=2, help="runs of the NumPy reference")
    parser.add_argument("--o3d-repeats", type=int, default=3, help="runs of Open3D")
    parser.add_argument("--frames", type=int, default=15, help="frames for the stage timing")
    parser.add_argument("--quick", action="store_true", help="40 mm voxels, few repeats")
    args = parser.parse_args()
    if args.quick:
        args.voxel_size, args.repeats, args.ref_repeats, args.o3d_repeats, args.frames = \
            40.0, 3, 1, 1, 3
    print(f"bench_carving: {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, "
          f"{platform.machine()}, {platform.python_version()}, numpy {np.__version__}, "
          f"load average {open('/proc/loadavg').read().split()[0]}")
    rig = read_rig(RIG_DIR)
    grid = VoxelGrid.from_rig(rig, args.voxel_size)
    bench_carving(args, rig, grid)
    bench_stage(args, rig, grid)


if __name__ == "__main__":
    main()
