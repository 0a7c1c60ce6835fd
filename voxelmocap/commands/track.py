"""``voxelmocap track``: track one sequence (or every sequence, ``--all``) with the APF."""

from __future__ import annotations

import argparse
import logging
import time

from ..logs import NO_PROGRESS_HELP, duration

logger = logging.getLogger(__name__)


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "track",
        help="track one sequence: silhouettes → voxels → annealed particle filter → poses",
        description="Track one sequence of a HumanEva-layout data set (--subject, --sequence) or "
                    "one trial of a Pose2Sim, anipose, EasyMocap or FreeMoCap project (--trial "
                    "when it has "
                    "several; see docs/projects.md). Writes RUN/<Subject>/<Action>_<Trial>.h5 "
                    "(a project: RUN/<trial>/<trial>.h5) "
                    "(states, landmarks, endpoints, per-part scores, ESS, timing, config), the "
                    "body_pose XML of the estimates and a BVH of the tracked skeleton (at the "
                    "video's frame rate). Every frame is committed to the result file with the "
                    "filter's state as it is tracked, so --resume continues an interrupted run "
                    "exactly; a result being written by another run is refused. With --all, every "
                    "sequence of the data set or trial of the project is tracked (as Dask tasks "
                    "with --scheduler or "
                    "--workers), complete results are skipped, and a summary lists what was "
                    "done, skipped and failed (exit code 1 if any failed). Messages are also "
                    "appended to RUN/voxelmocap.log.",
    )
    parser.add_argument("dataset", help="data set root (the folder holding S1/, Background/ …) "
                                        "or a Pose2Sim / anipose / EasyMocap / FreeMoCap project "
                                        "folder")
    parser.add_argument("--subject", help="HumanEva layout: e.g. S1 (required unless --all)")
    parser.add_argument("--sequence", help="HumanEva layout: <Action>_<Trial>, e.g. Walking_1 "
                                           "(required unless --all)")
    parser.add_argument("--trial", help="project: the trial to track (default: the only one)")
    parser.add_argument("--calibration", help="project: a calibration file (.toml, .qca.txt, "
                                              "intri.yml) instead of the project's own")
    parser.add_argument("--masks", metavar="DIR",
                        help="person masks from another tool as the silhouettes (no background "
                             "subtraction): one mask video or numbered-image folder per camera, "
                             "named like the camera or its video, frame for frame with it; grey "
                             "> 127 is the person (see docs/projects.md)")
    parser.add_argument("--plate-from", metavar="RUN",
                        help="without background videos: learn the plate with the body a "
                             "previous run (its folder or .h5) tracked in this sequence as the "
                             "person, instead of carving against a first plate; the run then "
                             "uses the silhouette cue too. Without it a run that learns its plate "
                             "does this itself: a first pass, then passes each with the plate "
                             "from the body of the pass before, the third starting from the "
                             "second's pose ([measurement.silhouette] plate_passes, [init] "
                             "previous_pass_start; docs/projects.md)")
    parser.add_argument("--all", action="store_true",
                        help="track every sequence with videos of the data set, or every trial "
                             "of the project (Pose2Sim sessions with cascading Config.toml, "
                             "anipose nested sessions, FreeMoCap recordings; Pose2Sim's "
                             "exclude_from_batch left out); finished ones are skipped, "
                             "interrupted ones resumed")
    parser.add_argument("--scheduler", help="with --all: address of a running Dask scheduler")
    parser.add_argument("--workers", type=int,
                        help="with --all: worker processes of a local Dask cluster (default: "
                             "the sequences run one after another in this process)")
    parser.add_argument("--rerun", metavar="FILE.rrd",
                        help="also write a Rerun recording of the run (cameras, silhouettes, "
                             "voxels, particles, skeleton per frame); needs the 'rerun' extra")
    parser.add_argument("--frames", help="synchronised frames A:B (inclusive; default: every "
                                         "frame with ground truth, else every frame, or a "
                                         "Pose2Sim trial's [project] frame_range)")
    parser.add_argument("--config", help="TOML file with [measurement], [likelihood], [filter], "
                                         "[init] settings")
    parser.add_argument("--layers", type=int, help="annealing layers (default 6)")
    parser.add_argument("--particles", type=int, help="particles per layer (default 600)")
    parser.add_argument("--strategy", choices=("apf", "sir", "iapf"), help="filter strategy")
    parser.add_argument("--voxel-size", type=float, help="voxel edge in mm (default 20)")
    parser.add_argument("--cameras", help="comma-separated camera names (default: all)")
    parser.add_argument("--cues", help="likelihood cues and weights, e.g. voxel,roi=4,edges=0.1 "
                                       "(voxel, edges, dt, roi, blob3d, skin, uniform, silhouette; 'fused' = "
                                       "voxel,roi=4,edges=0.1; default voxel; see docs/cues.md). "
                                       "voxel and blob3d need two cameras or more")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    parser.add_argument("--resume", action="store_true", help="continue an interrupted run")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing result")
    parser.add_argument("--no-progress", action="store_true", help=NO_PROGRESS_HELP)
    parser.add_argument("--export", metavar="FORMATS",
                        help="landmark files to write beside the result: comma-separated of trc, "
                             "c3d, csv, or none (default: [export] formats, trc,csv)")
    parser.add_argument("--smooth", type=float, metavar="HZ",
                        help="zero-lag Butterworth cut-off for those files (default: none; the "
                             "result file always holds the raw estimates)")
    parser.add_argument("--out", required=True, help="run folder RUN")
    parser.set_defaults(run=run, log_folder=lambda args: args.out)


def resolve_config(args):
    """The config of a command: defaults ← ``--config`` file ← command-line options."""
    from ..config import TrackConfig, load_config, with_overrides

    config = load_config(args.config) if getattr(args, "config", None) else TrackConfig()
    formats = getattr(args, "export", None)
    if formats is not None:
        from ..io.exports import parse_formats

        formats = list(parse_formats(formats, "--export"))
    if getattr(args, "cues", None):
        import dataclasses

        from ..score.cues import parse_cues

        config = dataclasses.replace(config, cues=dataclasses.replace(
            config.cues, weights=parse_cues(args.cues)))
    return with_overrides(config, **{
        "export.formats": formats,
        "export.cutoff_hz": getattr(args, "smooth", None),
        "filter.layers": getattr(args, "layers", None),
        "filter.particles": getattr(args, "particles", None),
        "filter.strategy": getattr(args, "strategy", None),
        "measurement.voxel_size": getattr(args, "voxel_size", None),
    })


def run(args: argparse.Namespace) -> int:
    from ..errors import InputError

    started = time.perf_counter()  # the closing line's rate is the whole command's

    if args.all:
        for name in ("subject", "sequence", "trial", "rerun", "masks", "plate_from"):
            if getattr(args, name):
                raise InputError(f"--{name.replace('_', '-')}",
                                 "not with --all (every sequence is tracked)")
        if args.resume:
            raise InputError("--resume", "not needed with --all: interrupted sequences are "
                                         "resumed, finished ones skipped")
        return _run_all(args)
    for name in ("scheduler", "workers"):
        if getattr(args, name) is not None:
            raise InputError(f"--{name}", "only with --all")
    from ..run.pipeline import track_sequence

    if args.masks and args.plate_from:  # refused before any note about what they select
        raise InputError("--plate-from", "not with --masks (given masks need no plate)")
    config = resolve_config(args)
    cameras = [c for c in args.cameras.split(",") if c.strip()] if args.cameras else None
    if cameras is not None:
        from ..io.sequence import open_sequence
        from ..score.cues import CueSet

        # an unknown camera is named as such before the cues judge how many cameras they have
        open_sequence(args.dataset, args.subject, args.sequence, trial=args.trial,
                      cameras=cameras, calibration=args.calibration)
        # refused here, before the background models are learnt, when the cameras are named
        CueSet.check_weights_for_cameras(config.cues.weights, cameras)
        if len(cameras) == 1 and config.measurement.grid_origin is None:
            config = _grid_of_full_rig(args, config)
    recorder = None
    if args.rerun:
        from ..viz.rerun_recording import RerunRecorder

        recorder = RerunRecorder(args.rerun)
    try:
        outcome = track_sequence(args.dataset, args.subject, args.sequence, args.out,
                                 config=config, frames=args.frames, cameras=cameras,
                                 seed=args.seed, resume=args.resume, overwrite=args.overwrite,
                                 progress=not args.no_progress, recorder=recorder,
                                 trial=args.trial, calibration=args.calibration,
                                 masks=args.masks, plate_from=args.plate_from,
                                 cues_given=bool(args.cues))
        recorded = recorder.close() if recorder is not None else None
    finally:
        if recorder is not None:
            recorder.abort()  # a failed run leaves no recording (no-op once closed)
    logger.info(_closing_line(outcome, time.perf_counter() - started))
    logger.info(f"results: {outcome.result_path}")
    logger.info(f"         {outcome.xml_path}")
    logger.info(f"         {outcome.bvh_path}")
    for path in outcome.export_paths:
        logger.info(f"         {path}")
    if recorded is not None:
        logger.info(f"recording: {recorded}")
    elif recorder is not None:
        logger.warning(f"no recording written to {recorder.path}: nothing was tracked (the "
                       "result was complete; --overwrite tracks and records it again)")
    return 0


def _closing_line(outcome, wall: float) -> str:
    """What the command did, at the rate a user waited for it (every pass, plates, starts and
    exports), beside the last pass's frame loop alone."""
    n = len(outcome.frames)
    new = n - outcome.resumed_from
    if new == 0:
        return (f"nothing to track: the result of frames {outcome.frames[0]}–"
                f"{outcome.frames[-1]} was complete ({duration(wall)})")
    done = f"tracked {new} frames" + ("" if new == n else f" (after {outcome.resumed_from} resumed)")
    return (f"{done} of {outcome.frames[0]}–{outcome.frames[-1]} in {duration(wall)}: "
            f"{new / wall:.2f} frames/s for the whole command "
            f"(the last pass's frame loop {1.0 / outcome.seconds_per_frame:.2f} frames/s)")


def _run_all(args: argparse.Namespace) -> int:
    """``--all``: every sequence; the summary; exit code 1 if any sequence failed."""
    from ..run.batch import BatchRequest, run_batch

    cameras = [c for c in args.cameras.split(",") if c.strip()] if args.cameras else None
    request = BatchRequest(args.dataset, args.out, config=resolve_config(args),
                           frames=args.frames, cameras=cameras, seed=args.seed,
                           overwrite=args.overwrite, cues_given=bool(args.cues),
                           calibration=args.calibration)
    summary = run_batch(request, scheduler=args.scheduler, n_workers=args.workers,
                        progress=not args.no_progress)
    logger.info(f"summary: {summary.describe()}")
    for key in summary.done:
        logger.info(f"  done:    {key}")
    for key in summary.skipped:
        logger.info(f"  skipped: {key} (complete)")
    for key, reason in summary.failed:
        logger.info(f"  failed:  {key}: {reason}")
    return 1 if summary.failed else 0


def _grid_of_full_rig(args, config):
    """Monocular mode: carve on the grid of the sequence's whole rig (one camera alone sees no
    floor-to-head box, so it cannot derive one; the voxels only serve the per-part scores)."""
    from ..config import with_overrides
    from ..grid import VoxelGrid
    from ..io.sequence import open_sequence

    rig = open_sequence(args.dataset, args.subject, args.sequence, trial=args.trial,
                        calibration=args.calibration).rig
    grid = VoxelGrid.from_rig(rig, config.measurement.voxel_size, bytes_per_voxel=8.0)
    logger.info(f"one camera: carving on the grid of all {len(rig)} cameras ({grid.shape[0]}x"
                f"{grid.shape[1]}x{grid.shape[2]} voxels)")
    return with_overrides(config, **{"measurement.grid_origin": list(grid.origin),
                                     "measurement.grid_shape": list(grid.shape)})
