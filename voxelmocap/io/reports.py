"""Evaluation of result files against ground truth: matching, Table-1 rows, JSON and CSV.

A *result* is a tracking result HDF5 (:mod:`voxelmocap.io.results`) or any body_pose XML (so results
of other trackers in the HumanEva XML format can be scored the same way). Its frames are matched by
number with the ground-truth XML; frames whose ground truth has a disabled endpoint are skipped and
counted. Rows of the table are per action (all sequences of that action pooled frame by frame);
the ``Average`` row pools every frame, which is how the paper's Table 1 averages (its Average row
is not the mean of its action rows).
"""

from __future__ import annotations

import csv
import io
import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..evaluation import SequenceScores, evaluate_sequence
from ..joints import LANDMARK_NAMES
from ._atomic import atomic_write_text, ensure_output_dir
from .body_pose_xml import BodyPoseSequence, read_body_pose_xml

__all__ = [
    "EvaluatedSequence",
    "evaluate_files",
    "find_result_files",
    "format_table",
    "read_poses",
    "report_json",
    "write_csvs",
]


@dataclass
class EvaluatedSequence:
    """One result file matched with its ground truth and scored."""

    subject: str
    action: str
    trial: str
    result_path: Path
    frames: np.ndarray  #: (F,) frame numbers present in both
    est: np.ndarray  #: (F, 20, 3)
    gt: np.ndarray  #: (F, 20, 3)
    gt_enabled: np.ndarray  #: (F, 20)
    missing_gt: int  #: result frames without ground truth
    scores: SequenceScores
    per_frame: dict
    est_enabled: np.ndarray | None = None  #: (F, 20)
    complete: bool | None = None  #: for tracking results: whether the run finished


def read_poses(path):
    """``(frames (F,), endpoints (F, 20, 3), enabled (F, 20), complete)`` of a result file.

    ``complete`` is whether a tracking result (``.h5``) finished, None for body_pose ``.xml``.
    """
    path = Path(path)
    if path.suffix.lower() == ".h5":
        from .results import read_result

        res = read_result(path)
        endpoints = np.asarray(res.endpoints, float)
        # A frame flagged without a person has no estimate: all its endpoints disabled, as a
        # body_pose XML of the same result says (the evaluation skips such frames).
        enabled = np.ones(endpoints.shape[:2], bool)
        if res.observed is not None:
            enabled[~res.observed] = False
        return (np.asarray(res.frames, int), endpoints, enabled,
                bool(res.attrs.get("complete", False)))
    seq = read_body_pose_xml(path)
    if seq.endpoints.shape[-1] != 3:
        raise InputError(path, "holds 2-D poses; 3-D endpoints are needed")
    return seq.frames, seq.endpoints, seq.enabled, None


def score_against(result_path, gt_path, *, delta: float, subject="", action="", trial=""):
    """Match a result with the ground truth by frame number and score it.

    ``gt_path`` is a body_pose XML file or an already loaded :class:`BodyPoseSequence` (e.g. the
    ground truth computed from raw mocap by :meth:`voxelmocap.io.humaneva.Sequence.ground_truth`).
    """
    frames, est, est_enabled, complete = read_poses(result_path)
    if isinstance(gt_path, BodyPoseSequence):
        gt, gt_path = gt_path, gt_path.attributes.get("Source", "ground truth")
    else:
        gt = read_body_pose_xml(gt_path)
    if gt.endpoints.shape[-1] != 3:
        raise InputError(gt_path, "ground truth holds 2-D poses")
    rows = gt.index_of(frames)
    keep = rows >= 0
    if not keep.any():
        raise InputError(result_path, f"no frame in common with the ground truth {gt_path}")
    scores, per_frame = evaluate_sequence(est[keep], gt.endpoints[rows[keep]],
                                          gt.enabled[rows[keep]], delta=delta,
                                          est_enabled=est_enabled[keep])
    return EvaluatedSequence(subject, action, trial, Path(result_path), frames[keep], est[keep],
                             gt.endpoints[rows[keep]], gt.enabled[rows[keep]],
                             int((~keep).sum()), scores, per_frame, est_enabled[keep], complete)


def find_result_files(run_dir) -> list[Path]:
    """``RUN/<Subject>/<Action>_<Trial>.h5`` files (or ``.xml`` where no ``.h5`` exists)."""
    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        raise InputError(run_dir, "run folder not found")
    found = []
    for subject_dir in sorted(p for p in run_dir.iterdir() if p.is_dir()):
        h5 = {p.stem: p for p in subject_dir.glob("*.h5") if not p.name.startswith(".")}
        xml = {p.stem: p for p in subject_dir.glob("*.xml") if not p.name.startswith(".")}
        for stem in sorted(set(h5) | set(xml)):
            found.append(h5.get(stem) or xml[stem])
    if not found:
        raise InputError(run_dir, "no result files (<Subject>/<Action>_<Trial>.h5 or .xml)")
    return found


def evaluate_files(run_dir, dataset_root, *, delta: float = 100.0) -> list[EvaluatedSequence]:
    """Score every result file of a run folder against the data set's ground truth."""
    from .humaneva import Dataset

    dataset = Dataset(dataset_root)
    out = []
    for path in find_result_files(run_dir):
        subject = path.parent.name
        name = path.stem
        seq = dataset.sequence(subject, name)
        gt = seq.ground_truth()  # the body_pose XML, or computed from the raw mocap files
        if gt is None:
            raise InputError(path, f"the data set has no ground truth for {subject}/{name}")
        out.append(score_against(path, gt, delta=delta, subject=seq.subject,
                                 action=seq.action, trial=seq.trial))
    return out


def _pooled(sequences: list[EvaluatedSequence], delta: float) -> SequenceScores:
    est = np.concatenate([s.est for s in sequences])
    gt = np.concatenate([s.gt for s in sequences])
    enabled = np.concatenate([s.gt_enabled for s in sequences])
    est_enabled = np.concatenate([np.ones(s.est.shape[:2], bool) if s.est_enabled is None
                                  else s.est_enabled for s in sequences])
    return evaluate_sequence(est, gt, enabled, delta=delta, est_enabled=est_enabled)[0]


def table_rows(sequences: list[EvaluatedSequence], delta: float):
    """``[(action, SequenceScores), …, ("Average", SequenceScores)]`` (actions in first-seen order)."""
    actions = list(dict.fromkeys(s.action for s in sequences))
    rows = [(a, _pooled([s for s in sequences if s.action == a], delta)) for a in actions]
    rows.append(("Average", _pooled(sequences, delta)))
    return rows


def _fmt(value: float, digits: int = 2) -> str:
    return "–" if value is None or (isinstance(value, float) and math.isnan(value)) \
        else f"{value:.{digits}f}"


def format_table(sequences: list[EvaluatedSequence], delta: float) -> str:
    """The paper's Table 1 layout as text."""
    lines = [f"{'':<12s}{'frames':>8s}{'μ (mm)':>10s}{'σ':>9s}{'MMTP (mm)':>11s}"
             f"{'MMTA (%)':>10s}{'HumanEva err (mm)':>19s}"]
    for action, sc in table_rows(sequences, delta):
        lines.append(f"{action:<12s}{sc.frames:>8d}{_fmt(sc.mu_mm):>10s}{_fmt(sc.sigma_mm):>9s}"
                     f"{_fmt(sc.mmtp_mm):>11s}{_fmt(sc.mmta_pct):>10s}"
                     f"{_fmt(sc.humaneva_error_mm):>19s}")
    skipped = sum(s.scores.skipped for s in sequences)
    missing = sum(s.missing_gt for s in sequences)
    unobserved = sum(s.scores.unobserved for s in sequences)
    lines.append(f"δ = {delta:g} mm; {skipped} frame(s) skipped (ground truth disabled), "
                 f"{missing} result frame(s) without ground truth")
    if unobserved:
        lines.append(f"{unobserved} frame(s) flagged without a person by the tracker: skipped")
    incomplete = [s for s in sequences if s.complete is False]
    for s in incomplete:
        lines.append(f"note: {s.result_path} is an unfinished run ({len(s.frames)} frames so far; "
                     "'voxelmocap track --resume' continues it)")
    return "\n".join(lines)


def _clean(value):
    # JSON has no NaN or infinity; a missing or unbounded score is null.
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def report_json(sequences: list[EvaluatedSequence], delta: float) -> dict:
    """The JSON report: per-sequence scores and the pooled average."""
    seqs = []
    for s in sequences:
        d = s.scores.to_dict()
        seqs.append({"subject": s.subject, "action": s.action, "trial": s.trial,
                     "result": str(s.result_path), "frames": d["frames"],
                     "skipped_frames": d["skipped"], "unobserved_frames": d["unobserved"],
                     "mu_mm": _clean(d["mu_mm"]),
                     "sigma_mm": _clean(d["sigma_mm"]), "mmtp_mm": _clean(d["mmtp_mm"]),
                     "mmta_pct": _clean(d["mmta_pct"]),
                     "humaneva_error_mm": _clean(d["humaneva_error_mm"])})
    avg = _pooled(sequences, delta).to_dict()
    average = {k: _clean(v) for k, v in avg.items() if k != "skipped"}
    return {"delta_mm": delta, "sequences": seqs, "average": average}


def write_json(path, report: dict) -> None:
    """Write a report as strict JSON (no ``NaN``/``Infinity`` tokens), atomically."""
    path = Path(path)
    text = json.dumps(report, indent=2, allow_nan=False) + "\n"
    try:
        atomic_write_text(path, text)
    except OSError as exc:
        raise InputError(path, f"cannot write the JSON report ({exc.strerror or exc})") from None


def write_csvs(out_dir, sequences: list[EvaluatedSequence]) -> tuple[Path, Path]:
    """``per_frame.csv`` (one row per frame) and ``per_joint.csv`` (one row per frame and joint)."""
    out_dir = ensure_output_dir(out_dir)
    frame_buf, joint_buf = io.StringIO(), io.StringIO()
    fw = csv.writer(frame_buf, lineterminator="\n")
    jw = csv.writer(joint_buf, lineterminator="\n")
    fw.writerow(["subject", "action", "trial", "frame", "valid", "mean_error_mm", "mmta_pct",
                 "mmtp_mm", "humaneva_error_mm"])
    jw.writerow(["subject", "action", "trial", "frame", "joint", "error_mm"])
    for s in sequences:
        pf = s.per_frame
        for i, frame in enumerate(s.frames):
            fw.writerow([s.subject, s.action, s.trial, int(frame), int(pf["valid"][i]),
                         _num(pf["mean_error"][i]), _num(pf["mmta"][i]), _num(pf["mmtp"][i]),
                         _num(pf["humaneva_error"][i])])
            for j, name in enumerate(LANDMARK_NAMES):
                jw.writerow([s.subject, s.action, s.trial, int(frame), name,
                             _num(pf["landmark_errors"][i, j])])
    frame_path, joint_path = out_dir / "per_frame.csv", out_dir / "per_joint.csv"
    try:
        atomic_write_text(frame_path, frame_buf.getvalue())
        atomic_write_text(joint_path, joint_buf.getvalue())
    except OSError as exc:
        raise InputError(out_dir, f"cannot write the CSV files ({exc.strerror or exc})") from None
    return frame_path, joint_path


def _num(value) -> str:
    return "" if value is None or not np.isfinite(value) else f"{float(value):.3f}"
