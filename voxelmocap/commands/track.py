"""``voxelmocap track``: track one sequence with the annealed particle filter."""

from __future__ import annotations

import argparse


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "track",
        help="track one sequence: silhouettes → voxels → annealed particle filter → poses",
        description="Track one HumanEva-layout sequence. Writes RUN/<Subject>/<Action>_<Trial>.h5 "
                    "(states, landmarks, endpoints, per-part scores, ESS, timing, config), the "
                    "body_pose XML of the estimates and a BVH of the tracked skeleton (at the "
                    "video's frame rate). Every frame is committed to the result file with the "
                    "filter's state as it is tracked, so --resume continues an interrupted run "
                    "exactly; a result being written by another run is refused.",
    )
    parser.add_argument("dataset", help="data set root (the folder holding S1/, Background/ …)")
    parser.add_argument("--subject", required=True, help="e.g. S1")
    parser.add_argument("--sequence", required=True, help="<Action>_<Trial>, e.g. Walking_1")
    parser.add_argument("--frames", help="synchronised frames A:B (inclusive; default: every "
                                         "frame with ground truth)")
    parser.add_argument("--config", help="TOML file with [measurement], [likelihood], [filter], "
                                         "[init] settings")
    parser.add_argument("--layers", type=int, help="annealing layers (default 6)")
    parser.add_argument("--particles", type=int, help="particles per layer (default 600)")
    parser.add_argument("--strategy", choices=("apf", "sir", "iapf"), help="filter strategy")
    parser.add_argument("--voxel-size", type=float, help="voxel edge in mm (default 20)")
    parser.add_argument("--cameras", help="comma-separated camera names (default: all)")
    parser.add_argument("--cues", help="likelihood cues and weights, e.g. voxel,roi=4,edges=0.1 "
                                       "(voxel, edges, dt, roi, blob3d, skin, uniform; 'fused' = "
                                       "voxel,roi=4,edges=0.1; default voxel; see docs/cues.md). "
                                       "voxel and blob3d need two cameras or more")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    parser.add_argument("--resume", action="store_true", help="continue an interrupted run")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing result")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument("--out", required=True, help="run folder RUN")
    parser.set_defaults(run=run)


def resolve_config(args):
    """The config of a command: defaults ← ``--config`` file ← command-line options."""
    from ..config import TrackConfig, load_config, with_overrides

    config = load_config(args.config) if getattr(args, "config", None) else TrackConfig()
    if getattr(args, "cues", None):
        import dataclasses

        from ..cues import parse_cues

        config = dataclasses.replace(config, cues=dataclasses.replace(
            config.cues, weights=parse_cues(args.cues)))
    return with_overrides(config, **{
        "filter.layers": getattr(args, "layers", None),
        "filter.particles": getattr(args, "particles", None),
        "filter.strategy": getattr(args, "strategy", None),
        "measurement.voxel_size": getattr(args, "voxel_size", None),
    })


def run(args: argparse.Namespace) -> int:
    from ..pipeline import track_sequence

    config = resolve_config(args)
    cameras = [c for c in args.cameras.split(",") if c.strip()] if args.cameras else None
    if cameras is not None:
        from ..cues import CueSet

        # refused here, before the background models are learnt, when the cameras are named
        CueSet.check_weights_for_cameras(config.cues.weights, cameras)
        if len(cameras) == 1 and config.measurement.grid_origin is None:
            config = _grid_of_full_rig(args, config)
    outcome = track_sequence(args.dataset, args.subject, args.sequence, args.out, config=config,
                             frames=args.frames, cameras=cameras, seed=args.seed,
                             resume=args.resume, overwrite=args.overwrite,
                             progress=not args.no_progress)
    print(f"tracked {len(outcome.frames)} frames ({outcome.frames[0]}–{outcome.frames[-1]}), "
          f"{1.0 / outcome.seconds_per_frame:.2f} frames/s")
    print(f"results: {outcome.result_path}")
    print(f"         {outcome.xml_path}")
    print(f"         {outcome.bvh_path}")
    return 0


def _grid_of_full_rig(args, config):
    """Monocular mode: carve on the grid of the sequence's whole rig (one camera alone sees no
    floor-to-head box, so it cannot derive one; the voxels only serve the per-part scores)."""
    from ..config import with_overrides
    from ..grid import VoxelGrid
    from ..io.humaneva import Dataset

    rig = Dataset(args.dataset).sequence(args.subject, args.sequence).rig
    grid = VoxelGrid.from_rig(rig, config.measurement.voxel_size, bytes_per_voxel=8.0)
    print(f"one camera: carving on the grid of all {len(rig)} cameras ({grid.shape[0]}x"
          f"{grid.shape[1]}x{grid.shape[2]} voxels)")
    return with_overrides(config, **{"measurement.grid_origin": list(grid.origin),
                                     "measurement.grid_shape": list(grid.shape)})
