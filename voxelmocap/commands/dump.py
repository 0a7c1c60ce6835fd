"""``voxelmocap dump``: run the measurement stage on a sequence and keep every volume for inspection.

Writes an HDF5 voxel dump (:mod:`voxelmocap.io.voxels`): the grid, the rig, and per frame the
occupancy ``V^R``, the surface ``V^S`` and the smoothed surface ``Ṽ^S`` (optionally the masks), plus
optionally one PLY file of the occupied voxels per frame. The measurement settings are those of
``voxelmocap track`` (``[measurement]`` of ``--config``), so a dump shows what the tracker sees.
"""

from __future__ import annotations

import argparse


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "dump",
        help="silhouettes → voxels of a sequence, written to HDF5 (and PLY) for inspection",
        description="Background subtraction, carving, surface and smoothing on the frames of one "
                    "sequence; writes OUT.h5 (occupancy, surface, smoothed surface per frame; "
                    "masks with --masks) atomically, and one PLY per frame into --ply DIR.",
    )
    parser.add_argument("dataset", help="data set root (the folder holding S1/, Background/ …)")
    parser.add_argument("--subject", required=True, help="e.g. S1")
    parser.add_argument("--sequence", required=True, help="<Action>_<Trial>, e.g. Walking_1")
    parser.add_argument("--frames", help="synchronised frames A:B (inclusive) or a list 3,7,9 "
                                         "(default: all)")
    parser.add_argument("--out", required=True, help="the HDF5 file to write, e.g. vox.h5")
    parser.add_argument("--ply", metavar="DIR", help="also write DIR/frame_<F>.ply per frame")
    parser.add_argument("--ply-points", action="store_true",
                        help="PLY as a point cloud of voxel centres (default: Open3D voxel grid)")
    parser.add_argument("--masks", action="store_true", help="also store the silhouettes")
    parser.add_argument("--cameras", help="comma-separated camera names (default: all)")
    parser.add_argument("--config", help="TOML file; its [measurement] table is used")
    parser.add_argument("--voxel-size", type=float, help="voxel edge in mm (default 20)")
    parser.add_argument("--min-views", type=int,
                        help="keep voxels inside at least this many silhouettes (default: all "
                             "cameras that see the voxel)")
    parser.add_argument("--background", choices=("gaussian", "mog2"),
                        help="background model (default gaussian, the HumanEva toolkit's)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.set_defaults(run=run)


def _config(args):
    from ..config import TrackConfig, load_config, with_overrides

    config = load_config(args.config) if args.config else TrackConfig()
    return with_overrides(config, **{
        "measurement.voxel_size": args.voxel_size,
        "measurement.min_views": args.min_views,
        "measurement.silhouette.method": args.background,
    })


def run(args: argparse.Namespace) -> int:
    import time
    import warnings
    from pathlib import Path

    from ..carving import EmptySilhouetteWarning
    from ..config import config_to_toml
    from ..errors import InputError
    from ..io.humaneva import Dataset
    from ..io.voxels import VoxelDumpWriter, write_ply
    from ..pipeline import MeasurementRunner, parse_frame_range

    config = _config(args)
    cameras = [c.strip() for c in args.cameras.split(",") if c.strip()] if args.cameras else None
    seq = Dataset(args.dataset).sequence(args.subject, args.sequence, cameras=cameras)
    for problem in seq.problems:  # cameras the data set has but this run cannot use
        print(f"warning: {problem}")
    frames = (parse_frame_range(args.frames, seq.frame_numbers) if args.frames
              else seq.frame_numbers)
    if len(frames) == 0:
        raise InputError(f"{seq.subject}/{seq.name}", "no frames to dump")
    out = Path(args.out)
    if out.suffix.lower() not in (".h5", ".hdf5"):
        raise InputError("--out", f"expected an .h5 file name, got {args.out!r}")
    ply_dir = Path(args.ply) if args.ply else None
    if ply_dir is not None and ply_dir.exists() and not ply_dir.is_dir():
        raise InputError("--ply", f"{ply_dir} exists and is not a folder")

    runner = MeasurementRunner(seq, config, log=print)
    stage = runner.stage
    grid = runner.grid
    print(f"{seq.subject}/{seq.name}: {len(frames)} frames, cameras {','.join(seq.camera_names)}, "
          f"grid {grid.shape[0]}x{grid.shape[1]}x{grid.shape[2]} at {grid.voxel_size:g} mm")
    attrs = {"dataset": str(Path(args.dataset).resolve()), "subject": seq.subject,
             "sequence": seq.name, "config": config_to_toml(config),
             "surface_sigma": float(config.measurement.surface_sigma)}
    bar = None
    if not args.no_progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=len(frames), desc=f"{seq.subject}/{seq.name}", unit="frame",
                   dynamic_ncols=True)
    empty = []
    totals = {"decode": 0.0}
    t_decode = time.perf_counter()
    try:
        with VoxelDumpWriter(out, grid, cameras=list(seq.rig), attrs=attrs) as writer:
            for number, images in seq.frames(frames):
                totals["decode"] += time.perf_counter() - t_decode
                with warnings.catch_warnings(record=True) as caught:
                    warnings.simplefilter("always", EmptySilhouetteWarning)
                    m = stage.measure(images)
                if any(issubclass(w.category, EmptySilhouetteWarning) for w in caught):
                    empty.append(int(number))
                for key, value in m.timings.items():
                    totals[key] = totals.get(key, 0.0) + value
                writer.write(int(number), m.occupancy, surface=m.surface, smoothed=m.smoothed,
                             masks=m.masks if args.masks else None)
                if ply_dir is not None:
                    write_ply(ply_dir / f"frame_{int(number):05d}.ply", grid, m.occupancy,
                              points=args.ply_points)
                if bar is not None:
                    bar.update(1)
                t_decode = time.perf_counter()
    finally:
        if bar is not None:
            bar.close()
    n = len(frames)
    per_frame = ", ".join(f"{k} {1000 * v / n:.1f}" for k, v in totals.items())
    print(f"wrote {out} ({n} frames); ms per frame: {per_frame}")
    if ply_dir is not None:
        print(f"PLY files in {ply_dir}")
    if empty:
        shown = ", ".join(str(f) for f in empty[:10]) + (" …" if len(empty) > 10 else "")
        print(f"warning: {len(empty)} frame(s) had empty silhouettes in every view (no person): "
              f"{shown}")
    return 0
