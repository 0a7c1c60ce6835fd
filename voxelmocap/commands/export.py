"""``voxelmocap export RUN_OR_H5 [--format trc,c3d,csv] [--opensim] [--smooth HZ]``: landmark
files of results, and OpenSim's joint angles."""

from __future__ import annotations

import argparse
import logging

import numpy as np


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "export",
        help="write TRC / C3D / CSV landmark files of tracking results (optionally smoothed), "
             "or an OpenSim model and its joint angles (--opensim)",
        description="Convert tracking results (one RUN/<Subject>/<Action>_<Trial>.h5, or every "
                    "one of a run folder) into landmark files at the result's frame rate, in mm, "
                    "in the calibration's world frame: TRC (OpenSim, Pose2Sim), C3D (residual = "
                    "the particle spread) and a tidy CSV with a confidence column. Written "
                    "beside each result as <Action>_<Trial>.<ext>, with _butterworth<HZ>Hz "
                    "before the extension when smoothed and _yup in OpenSim's Y-up axes "
                    "(docs/outputs.md). --opensim writes the OpenSim hand-off instead (or as "
                    "well, with --format): the tracked skeleton as a model scaled to the tracked "
                    "body (<Action>_<Trial>_scaled.osim), the markers it was fitted to (Y up, m, "
                    "_opensim.trc), OpenSim's inverse kinematics as joint angles at the data's "
                    "frame rate (.mot, degrees) and the marker errors (_ik_marker_errors.sto).",
    )
    parser.add_argument("source", metavar="RUN_OR_H5", help="a result file or a run folder")
    parser.add_argument("--format", metavar="FORMATS",
                        help="comma-separated of trc, c3d, csv, or none (default trc,csv; none "
                             "with --opensim)")
    parser.add_argument("--opensim", action="store_true",
                        help="OpenSim model, inverse kinematics and joint angles (needs the "
                             "opensim package: pip install -e \".[opensim]\")")
    parser.add_argument("--smooth", type=float, metavar="HZ",
                        help="zero-lag Butterworth low-pass cut-off (default: none)")
    parser.add_argument("--order", type=int, default=4,
                        help="order of the zero-lag filter, even (default 4: a 2nd-order "
                             "Butterworth run forward and backward)")
    parser.add_argument("--axes", choices=("world", "y_up"), default="world",
                        help="world: the calibration's frame, Z up (default); y_up: OpenSim's "
                             "Y-up axes, as Pose2Sim writes (files named …_yup.<ext>; the TRC's "
                             "first line, the C3D's POINT:X_SCREEN/Y_SCREEN and the CSV's "
                             "x_yup_mm… columns say so)")
    parser.add_argument("--out", help="folder for the files (default: beside each result)")
    parser.set_defaults(run=run)


def _results(source):
    from pathlib import Path

    from ..errors import InputError
    from ..io.reports import find_result_files

    source = Path(source)
    if source.is_file():
        if source.suffix.lower() != ".h5":
            raise InputError(source, "expected a tracking result (.h5) or a run folder")
        return [source]
    if not source.exists():
        raise InputError(source, "no such result file or run folder")
    found = [p for p in find_result_files(source) if p.suffix.lower() == ".h5"]
    if not found:
        raise InputError(source, "no tracking result (.h5) in this run folder")
    return found


def run(args: argparse.Namespace) -> int:
    from ..io._outputs import check_output_dir
    from ..io.exports import export_result, landmark_table, parse_formats
    from ..io.results import read_result
    from ..smoothing import check_filter

    text = args.format if args.format is not None else ("none" if args.opensim else "trc,csv")
    formats = parse_formats(text)
    if args.smooth is not None:  # the order alone first: the cut-off depends on each result
        check_filter(1e5, 1.0, args.order, "--order")
    paths = _results(args.source)
    if args.out:
        check_output_dir(args.out)
    if not formats and not args.opensim:
        return 0
    # Everything is read and checked before the first file is written.
    results = [read_result(p) for p in paths]
    for path, res in zip(paths, results, strict=True):
        landmark_table(res, source=path)  # the result's own numbers, before any filter
        if args.smooth is not None:
            check_filter(float(res.attrs["frame_rate"]), args.smooth, args.order,
                         f"{path}: --smooth/--order")
    bodies = [None] * len(paths)
    if args.opensim:
        from ..io.opensim import require_opensim, tracked_body

        bodies = [tracked_body(res, path) for path, res in zip(paths, results, strict=True)]
        require_opensim()
    for path, res, body in zip(paths, results, bodies, strict=True):
        if not res.attrs.get("complete"):
            logging.getLogger(__name__).warning(
                f"{path} is an unfinished run ({len(res)} frames so far)")
        written = export_result(path, formats, cutoff_hz=args.smooth, order=args.order,
                                axes=args.axes, out_dir=args.out, result=res)
        for p in written:
            print(p)
        if args.opensim:
            from ..io.opensim import export_opensim

            done = export_opensim(path, cutoff_hz=args.smooth, order=args.order,
                                  out_dir=args.out, result=res, body=body)
            for p in done.paths:
                print(p)
            logging.getLogger(__name__).info(
                f"{path}: OpenSim inverse kinematics of {done.frames} frames, marker RMS "
                f"{np.mean(done.marker_rms_mm):.1f} mm on average, "
                f"{np.max(done.marker_rms_mm):.1f} mm at most; body: {done.body}")
    return 0
