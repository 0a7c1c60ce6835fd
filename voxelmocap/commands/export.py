"""``voxelmocap export RUN_OR_H5 --format trc,c3d,csv [--smooth HZ]``: landmark files of results."""

from __future__ import annotations

import argparse
import logging


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "export",
        help="write TRC / C3D / CSV landmark files of tracking results (optionally smoothed)",
        description="Convert tracking results (one RUN/<Subject>/<Action>_<Trial>.h5, or every "
                    "one of a run folder) into landmark files at the result's frame rate, in mm, "
                    "in the calibration's world frame: TRC (OpenSim, Pose2Sim), C3D (residual = "
                    "the particle spread) and a tidy CSV with a confidence column. Written "
                    "beside each result as <Action>_<Trial>.<ext>, or "
                    "<Action>_<Trial>_butterworth<HZ>Hz.<ext> when smoothed (docs/outputs.md).",
    )
    parser.add_argument("source", metavar="RUN_OR_H5", help="a result file or a run folder")
    parser.add_argument("--format", default="trc,csv", metavar="FORMATS",
                        help="comma-separated of trc, c3d, csv (default trc,csv)")
    parser.add_argument("--smooth", type=float, metavar="HZ",
                        help="zero-lag Butterworth low-pass cut-off (default: none)")
    parser.add_argument("--order", type=int, default=4,
                        help="order of the zero-lag filter, even (default 4: a 2nd-order "
                             "Butterworth run forward and backward)")
    parser.add_argument("--axes", choices=("world", "y_up"), default="world",
                        help="world: the calibration's frame, Z up (default); y_up: OpenSim's "
                             "Y-up axes, as Pose2Sim writes")
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

    formats = parse_formats(args.format)
    if args.smooth is not None:  # the order alone first: the cut-off depends on each result
        check_filter(1e5, 1.0, args.order, "--order")
    paths = _results(args.source)
    if args.out:
        check_output_dir(args.out)
    if not formats:
        return 0
    # Everything is read and checked before the first file is written.
    results = [read_result(p) for p in paths]
    for path, res in zip(paths, results, strict=True):
        landmark_table(res, source=path)  # the result's own numbers, before any filter
        if args.smooth is not None:
            check_filter(float(res.attrs["frame_rate"]), args.smooth, args.order,
                         f"{path}: --smooth/--order")
    for path, res in zip(paths, results, strict=True):
        if not res.attrs.get("complete"):
            logging.getLogger(__name__).warning(
                f"{path} is an unfinished run ({len(res)} frames so far)")
        written = export_result(path, formats, cutoff_hz=args.smooth, order=args.order,
                                axes=args.axes, out_dir=args.out, result=res)
        for p in written:
            print(p)
    return 0
