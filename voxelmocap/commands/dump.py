"""``voxelmocap dump``: run the measurement stage on a sequence and keep every volume for inspection.

Writes an HDF5 voxel dump (:mod:`voxelmocap.io.voxels`): the grid, the rig, and per frame the
occupancy ``V^R``, the surface ``V^S`` and the smoothed surface ``Ṽ^S`` (optionally the masks), plus
optionally one PLY file of the occupied voxels per frame. The measurement settings are those of
``voxelmocap track`` (``[measurement]`` of ``--config``), so a dump shows what the tracker sees.
"""

from __future__ import annotations

import argparse
import logging

from ..logs import NO_PROGRESS_HELP

logger = logging.getLogger(__name__)


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
    parser.add_argument("--plate-from", metavar="RUN",
                        help="without background videos: learn the plate with the body RUN "
                             "tracked (a run folder, a pass folder or a .h5), as track's later "
                             "passes do: give a run's last pass folder, RUN/<subject>/pass2 by "
                             "default (a project: RUN/<trial>/pass2), to see what its final "
                             "pass measured")
    parser.add_argument("--no-progress", action="store_true", help=NO_PROGRESS_HELP)
    parser.set_defaults(run=run, log_folder=_log_folder)


def _log_folder(args):
    """The dump's folder receives voxelmocap.log (the dump is one file, not a run folder)."""
    from pathlib import Path

    return Path(args.out).parent


def _config(args):
    from ..config import TrackConfig, load_config, with_overrides

    config = load_config(args.config) if args.config else TrackConfig()
    return with_overrides(config, **{
        "measurement.voxel_size": args.voxel_size,
        "measurement.min_views": args.min_views,
        "measurement.silhouette.method": args.background,
    })


def run(args: argparse.Namespace) -> int:
    from ..run.dump import DumpRequest, dump_sequence

    cameras = [c.strip() for c in args.cameras.split(",") if c.strip()] if args.cameras else None
    plate_body = None
    if args.plate_from:
        from ..io.sequence import open_sequence
        from ..run.bodies import tracked_body

        seq = open_sequence(args.dataset, args.subject, args.sequence, cameras=cameras)
        plate_body = tracked_body(args.plate_from, seq, seq.ground_truth())
    request = DumpRequest(args.dataset, args.subject, args.sequence, args.out,
                          config=_config(args), frames=args.frames, cameras=cameras,
                          masks=args.masks, ply_dir=args.ply, ply_points=args.ply_points,
                          plate_body=plate_body)
    outcome = dump_sequence(request, progress=not args.no_progress)
    per_frame = ", ".join(f"{k} {1000 * v:.1f}" for k, v in outcome.seconds_per_frame.items())
    logger.info(f"wrote {outcome.path} ({len(outcome.frames)} frames); ms per frame: {per_frame}")
    if outcome.ply_dir is not None:
        logger.info("PLY files in %s", outcome.ply_dir)
    if outcome.summary:
        logger.warning(outcome.summary)
    return 0
