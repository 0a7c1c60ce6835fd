"""``voxelmocap evaluate RUN --dataset DATASET``: the paper's Table 1 for a run folder.

``voxelmocap evaluate RESULT --reference REF.trc --mapping MAP.toml``: the same errors against any
named 3-D reference (:mod:`voxelmocap.io.reference`).
"""

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
                    "Average row (all frames pooled). With --reference and --mapping, RUN is one "
                    "result (.h5, .xml, or a run folder holding one) and is scored against the "
                    "named 3-D points of a TRC or CSV instead: μ, σ, MMTP, MMTA and the error of "
                    "each mapped landmark.",
    )
    parser.add_argument("run_dir", metavar="RUN", help="run folder written by 'voxelmocap track' "
                                                       "(with --reference: one result)")
    parser.add_argument("--dataset", help="data set root with the ground truth")
    parser.add_argument("--reference", metavar="FILE",
                        help="a TRC or CSV of named 3-D points (mm unless the TRC says "
                             "otherwise) to score against instead of --dataset")
    parser.add_argument("--mapping", metavar="TOML",
                        help="with --reference: voxelmocap landmark = reference point (or a "
                             "pair, averaged); see docs/outputs.md")
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
    if args.reference is not None or args.mapping is not None:
        return _run_reference(args)
    if args.dataset is None:
        raise InputError("evaluate", "give --dataset (HumanEva ground truth) or --reference "
                                     "and --mapping")
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


def _one_result(path):
    """The result file of RUN: the path itself, or the only result of a run folder."""
    from pathlib import Path

    from ..errors import InputError
    from ..io.reports import find_result_files

    path = Path(path)
    if path.is_dir():
        found = find_result_files(path)
        if len(found) != 1:
            raise InputError(path, f"holds {len(found)} results; give one result file with "
                                   "--reference")
        return found[0]
    if not path.exists():
        raise InputError(path, "result file not found")
    return path


def _result_landmarks(path):
    """``(frames, landmarks (F, 15, 3) NaN where unobserved, frame_rate or None)``."""
    import numpy as np

    from ..io.reports import read_poses
    from ..joints import endpoints_to_landmarks

    if path.suffix.lower() == ".h5":
        from ..io.results import read_result

        res = read_result(path)
        landmarks = np.array(res.landmarks, dtype=float)
        landmarks[~res.observed] = np.nan
        return res.frames, landmarks, float(res.attrs.get("frame_rate", np.nan))
    frames, endpoints, enabled, _ = read_poses(path)
    return frames, endpoints_to_landmarks(endpoints, enabled), None


def _run_reference(args) -> int:
    import math

    from ..errors import InputError
    from ..evaluation import evaluate_points
    from ..io._atomic import atomic_write_text
    from ..io._outputs import check_output_file
    from ..io.reference import aligned, read_mapping, read_reference

    if args.reference is None or args.mapping is None:
        raise InputError("--reference", "needs --mapping (and --mapping needs --reference)")
    if args.dataset or args.csv or args.plots:
        which = "--dataset" if args.dataset else "--csv" if args.csv else "--plots"
        raise InputError(which, "not available with --reference")
    if args.json:
        check_output_file(args.json)
    result = _one_result(args.run_dir)
    mapping = read_mapping(args.mapping)
    reference = read_reference(args.reference)
    frames, landmarks, rate = _result_landmarks(result)
    if rate is None:  # a body_pose XML states no rate: take the reference's
        rate = reference.frame_rate or 1.0
    names, frames, est, ref = aligned(frames, landmarks, rate, reference, mapping, result)
    scores, _ = evaluate_points(est, ref, names, delta=args.delta)
    print(f"{result} against {reference.path}: {scores.frames} frames, {len(names)} landmarks")
    print(f"μ {scores.mu_mm:.1f} mm  σ {scores.sigma_mm:.1f}  MMTP {scores.mmtp_mm:.1f} mm  "
          f"MMTA {scores.mmta_pct:.1f} % (δ = {args.delta:g} mm)")
    print(f"{'landmark':<12s}{'reference':>24s}{'error (mm)':>12s}{'MMTA (%)':>10s}")
    for name, err, acc in zip(names, scores.per_landmark_mm, scores.per_landmark_mmta_pct,
                              strict=True):
        print(f"{name:<12s}{' + '.join(mapping.pairs[name]):>24s}{err:>12.1f}{acc:>10.1f}")
    if args.json:
        import json

        def clean(v):
            return None if isinstance(v, float) and not math.isfinite(v) else v

        report = {k: (list(map(clean, v)) if isinstance(v, tuple) else clean(v))
                  for k, v in scores.to_dict().items()}
        report.update(delta_mm=args.delta, result=str(result), reference=str(reference.path),
                      mapping={n: list(p) for n, p in mapping.pairs.items()})
        atomic_write_text(args.json, json.dumps(report, indent=1, ensure_ascii=False) + "\n")
        print(f"JSON: {args.json}")
    return 0
