"""``voxelmocap groundtruth DATASET --subject S1 --sequence Walking_1 --out gt.xml``.

Computes a HumanEva-I sequence's ground truth from its raw motion capture (``Mocap_Data/
<Action>_<Trial>.mat``, ``Static.mat``, ``<Subject>.mp``) as the toolkit's ``mocap_stream`` does,
synchronised by the ``.ofs`` files, and writes it as body_pose XML, so that any tracker's XML can
be scored against it (``scripts/evaluate_mmta.py``) without MATLAB.
"""

from __future__ import annotations

import argparse
import logging

logger = logging.getLogger(__name__)


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "groundtruth",
        help="compute a sequence's ground truth from the raw mocap (.mat + .mp) as body_pose XML",
        description="Read Mocap_Data/<Action>_<Trial>.mat, Static.mat and <Subject>.mp, compute "
                    "the 20 body_pose endpoints of every synchronised frame the mocap covers as "
                    "the HumanEva toolkit does (mocap_stream/cur_frame, synchronised by the .ofs "
                    "files) and write them as body_pose XML. Frames the toolkit marks invalid are "
                    "written with Enabled = 0.",
    )
    parser.add_argument("dataset", help="data set root (the folder holding S1/, S2/ …)")
    parser.add_argument("--subject", required=True, help="subject, e.g. S1")
    parser.add_argument("--sequence", required=True, help="sequence <Action>_<Trial>, e.g. "
                                                          "Walking_1")
    parser.add_argument("--out", required=True, help="output body_pose XML file")
    parser.set_defaults(run=run)


def summary(poses, gt) -> str:
    """One line: frames written, how many valid, invalid, not computable, NaN endpoints."""
    ok = poses.status == "ok"
    failed = int((~ok).sum())
    invalid = int((ok & ~poses.valid).sum())
    nan_frames = int((ok & poses.valid & ~gt.enabled.all(axis=1)).sum())
    span = f" ({gt.frames[0]}–{gt.frames[-1]})" if len(gt) else ""
    parts = [f"{len(gt)} frames{span}", f"{int(gt.enabled.all(axis=1).sum())} fully enabled",
             f"{invalid} invalid (missing markers)"]
    if failed:
        parts.append(f"{failed} the toolkit cannot compute (disabled)")
    if nan_frames:
        parts.append(f"{nan_frames} with NaN endpoints (disabled)")
    return ", ".join(parts)


def run(args: argparse.Namespace) -> int:
    from ..errors import InputError
    from ..io._outputs import check_output_file
    from ..io.body_pose_xml import write_body_pose_xml
    from ..io.humaneva import Dataset
    from ..io.humaneva_mocap import find_mocap_files, mocap_ground_truth

    check_output_file(args.out)
    seq = Dataset(args.dataset).sequence(args.subject, args.sequence)
    files = find_mocap_files(seq.subject_dir, seq.subject, seq.name)
    if files is None:
        raise InputError(seq.subject_dir, f"no raw mocap for {seq.name} (expected "
                                          f"Mocap_Data/{seq.name}.mat)")
    attributes = {"DatasetName": "HumanEvaI", "SubjectName": seq.subject,
                  "ActionType": seq.action, "Trial": seq.trial}
    gt, poses = mocap_ground_truth(files, seq.common_time, seq.common_scaling, attributes)
    if len(gt) == 0:
        raise InputError(files.trial, "the mocap covers no synchronised frame (the .ofs files "
                                      f"put frame 1 at mocap frame {seq.common_time:.3f})")
    write_body_pose_xml(args.out, gt.frames, gt.endpoints, gt.enabled, attributes=gt.attributes)
    logger.info(f"{seq.subject}/{seq.name}: {files.describe()}; frame 1 is mocap position "
                f"{seq.common_time:.3f}, {seq.common_scaling:.4f} mocap frames per frame")
    logger.info(f"wrote {args.out}: {summary(poses, gt)}")
    return 0
