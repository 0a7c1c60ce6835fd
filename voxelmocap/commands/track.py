"""``voxelmocap track``: track one sequence with the annealed particle filter."""

from __future__ import annotations

import argparse


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "track",
        help="track one sequence: silhouettes → voxels → annealed particle filter → poses",
        description="Track one sequence of a HumanEva-layout data set (--subject, --sequence) or "
                    "one trial of a Pose2Sim, anipose or EasyMocap project (--trial when it has "
                    "several; see docs/projects.md). Writes RUN/<Subject>/<Action>_<Trial>.h5 "
                    "(a project: RUN/<trial>/<trial>.h5) "
                    "(states, landmarks, endpoints, per-part scores, ESS, timing, config), the "
                    "body_pose XML of the estimates and a BVH of the tracked skeleton (at the "
                    "video's frame rate). Every frame is committed to the result file with the "
                    "filter's state as it is tracked, so --resume continues an interrupted run "
                    "exactly; a result being written by another run is refused.",
    )
    parser.add_argument("dataset", help="data set root (the folder holding S1/, Background/ …) "
                                        "or a Pose2Sim / anipose / EasyMocap project folder")
    parser.add_argument("--subject", help="HumanEva layout: e.g. S1")
    parser.add_argument("--sequence", help="HumanEva layout: <Action>_<Trial>, e.g. Walking_1")
    parser.add_argument("--trial", help="project: the trial to track (default: the only one)")
    parser.add_argument("--calibration", help="project: a calibration file (.toml, .qca.txt, "
                                              "intri.yml) instead of the project's own")
    parser.add_argument("--frames", help="synchronised frames A:B (inclusive; default: every "
                                         "frame with ground truth)")
    parser.add_argument("--config", help="TOML file with [measurement], [likelihood], [filter], "
                                         "[init] settings")
    parser.add_argument("--layers", type=int, help="annealing layers (default 6)")
    parser.add_argument("--particles", type=int, help="particles per layer (default 600)")
    parser.add_argument("--strategy", choices=("apf", "sir", "iapf"), help="filter strategy")
    parser.add_argument("--voxel-size", type=float, help="voxel edge in mm (default 20)")
    parser.add_argument("--cameras", help="comma-separated camera names (default: all)")
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
    outcome = track_sequence(args.dataset, args.subject, args.sequence, args.out, config=config,
                             frames=args.frames, cameras=cameras, seed=args.seed,
                             resume=args.resume, overwrite=args.overwrite,
                             progress=not args.no_progress, trial=args.trial,
                             calibration=args.calibration)
    print(f"tracked {len(outcome.frames)} frames ({outcome.frames[0]}–{outcome.frames[-1]}), "
          f"{1.0 / outcome.seconds_per_frame:.2f} frames/s")
    print(f"results: {outcome.result_path}")
    print(f"         {outcome.xml_path}")
    print(f"         {outcome.bvh_path}")
    return 0
