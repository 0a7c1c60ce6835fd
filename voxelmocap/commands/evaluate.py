"""``voxelmocap evaluate RUN --dataset DATASET``: the paper's Table 1 for a run folder."""

from __future__ import annotations

import argparse
import logging

logger = logging.getLogger(__name__)


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "evaluate",
        help="score tracking results against ground truth: μ, σ, MMTP, MMTA, HumanEva error",
        description="Match every RUN/<Subject>/<Action>_<Trial>.h5 (or .xml) with the data set's "
                    "ground truth and print the paper's Table 1: one row per action, then the "
                    "Average row (all frames pooled).",
    )
    parser.add_argument("run_dir", metavar="RUN", help="run folder written by 'voxelmocap track'")
    parser.add_argument("--dataset", required=True, help="data set root with the ground truth")
    parser.add_argument("--delta", type=float, default=100.0, help="MMTA threshold δ in mm "
                                                                   "(default 100)")
    parser.add_argument("--json", help="write the report as JSON to this file")
    parser.add_argument("--csv", help="write per_frame.csv and per_joint.csv into this folder")
    parser.add_argument("--plots", help="write error_per_frame.png and error_per_joint.png here")
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from ..errors import InputError
    from ..io._outputs import check_output_dir, check_output_file
    from ..io.reports import evaluate_files, format_table, report_json, write_csvs, write_json

    if not args.delta > 0:
        raise InputError("--delta", f"must be positive, got {args.delta}")
    # Every output is checked before anything is computed or written: a bad --plots must not
    # leave the JSON and CSV of a failed command behind.
    if args.json:
        check_output_file(args.json)
    for folder in (args.csv, args.plots):
        if folder:
            check_output_dir(folder)
    sequences = evaluate_files(args.run_dir, args.dataset, delta=args.delta)
    print(format_table(sequences, args.delta))
    if args.json:
        write_json(args.json, report_json(sequences, args.delta))
        logger.info("JSON: %s", args.json)
    if args.csv:
        paths = write_csvs(args.csv, sequences)
        logger.info("CSV: %s, %s", paths[0], paths[1])
    if args.plots:
        from ..viz.plots import plot_errors

        paths = plot_errors(sequences, args.plots, delta=args.delta)
        logger.info("plots: %s", ", ".join(str(p) for p in paths))
    return 0
