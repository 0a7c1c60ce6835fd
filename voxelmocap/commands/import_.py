"""``voxelmocap import PROJECT --out DATASET``: a project's trial written into the HumanEva layout."""

from __future__ import annotations

import argparse

from ..logs import NO_PROGRESS_HELP


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "import",
        help="write a Pose2Sim / anipose / EasyMocap trial into the HumanEva layout (optional: "
             "track reads projects directly)",
        description="Copy one trial of a Pose2Sim, anipose or EasyMocap project into a "
                    "HumanEva-I-layout data set: calibration as .cal + sizes.toml (mm, image "
                    "sizes as reconciled with the videos), the synchronised frames as lossless "
                    "FFV1 AVI (frame rate kept), .ofs files of an already synchronised sequence "
                    "(1, 1, 1), background videos when the trial has them. Camera names keep "
                    "letters and digits only. Tracking does not need this step.",
    )
    parser.add_argument("project", help="the project folder")
    parser.add_argument("--out", required=True, help="data set root to write into")
    parser.add_argument("--trial", help="the trial (default: the only one)")
    parser.add_argument("--calibration", help="a calibration file instead of the project's own")
    parser.add_argument("--cameras", help="comma-separated camera names (default: all)")
    parser.add_argument("--subject", default="S1", help="subject folder to write (default S1)")
    parser.add_argument("--action", help="action name, letters only (default: from the trial "
                                         "name)")
    parser.add_argument("--no-progress", action="store_true", help=NO_PROGRESS_HELP)
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from ..errors import InputError
    from ..io.importer import import_sequence
    from ..io.project import Project
    from ..io.sequence import detect_layout

    if detect_layout(args.project) == "humaneva":
        raise InputError(args.project, "is a HumanEva-layout data set already")
    cameras = [c for c in args.cameras.split(",") if c.strip()] if args.cameras else None
    seq = Project(args.project, calibration=args.calibration).sequence(args.trial,
                                                                      cameras=cameras)
    outcome = import_sequence(seq, args.out, subject=args.subject, action=args.action,
                              progress=not args.no_progress)
    print(f"data set {outcome.root}: track it with --subject {outcome.subject} --sequence "
          f"{outcome.sequence}")
    return 0
