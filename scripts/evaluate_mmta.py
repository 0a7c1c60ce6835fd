"""Stand-alone MMTA/MMTP evaluation of 3-D pose results against HumanEva-format ground truth.

Works on results of any tracker written as body_pose XML (``HUMANEVA.md`` §6), or on voxelmocap
result HDF5 files. Prints the paper's Table 1 layout (μ, σ, MMTP, MMTA, HumanEva error; one row per
action, then the pooled Average) and optionally writes the JSON report.

Usage::

    python scripts/evaluate_mmta.py RESULT.xml GT.xml [RESULT2.h5 GT2.xml ...] [--delta 100] [--json out.json]

The action of a pair is the ground truth's ``ActionType`` attribute (else the file name's
``<Action>_<Trial>``).

Not a benchmark: the stand-alone scorer of ``docs/humaneva_mocap.md`` and the README
(``tests/io/test_reports.py`` runs it).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from voxelmocap.errors import VoxelmocapError
from voxelmocap.io._outputs import check_output_file
from voxelmocap.io.body_pose_xml import read_body_pose_xml
from voxelmocap.io.reports import format_table, report_json, score_against, write_json


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("files", nargs="+", help="pairs RESULT GT (result .xml/.h5, ground-truth .xml)")
    parser.add_argument("--delta", type=float, default=100.0, help="MMTA threshold in mm (default 100)")
    parser.add_argument("--json", help="write the JSON report here")
    args = parser.parse_args(argv)
    if not args.delta > 0:
        parser.error("--delta must be positive")
    if len(args.files) % 2:
        parser.error("files must come in RESULT GT pairs")
    try:
        if args.json:
            check_output_file(args.json)
        sequences = []
        for result, gt in zip(args.files[::2], args.files[1::2], strict=True):
            attrs = read_body_pose_xml(gt).attributes
            stem = Path(gt).stem
            action = attrs.get("ActionType") or stem.rsplit("_", 1)[0]
            trial = attrs.get("Trial") or (stem.rsplit("_", 1)[-1] if "_" in stem else "")
            sequences.append(score_against(result, gt, delta=args.delta,
                                           subject=attrs.get("SubjectName", ""), action=action,
                                           trial=str(trial)))
        print(format_table(sequences, args.delta))
        if args.json:
            write_json(args.json, report_json(sequences, args.delta))
            print(f"JSON: {args.json}")
    except VoxelmocapError as exc:
        print(f"evaluate_mmta: error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
