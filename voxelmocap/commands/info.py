"""``voxelmocap info DATASET``: list and validate a HumanEva-layout data set or a project."""

from __future__ import annotations

import argparse


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "info",
        help="list subjects, sequences, cameras, frame counts and sync offsets; validate files",
        description="List what a HumanEva-I-layout data set, or a Pose2Sim / anipose / "
                    "EasyMocap project (docs/projects.md), holds and validate every file read: "
                    "calibration, sync files, videos (opened, first frame decoded and its size "
                    "checked), background videos, ground-truth XML and subject body files; for a "
                    "project, what was assumed (camera matching, image sizes, units). Exit "
                    "status: 0 all valid; 1 data that cannot be used (e.g. a camera with a video "
                    "but no sync file), listed as problems; 2 a file that cannot be read.",
    )
    parser.add_argument("dataset", help="data set root (the folder holding S1/, Background/ …) "
                                        "or a Pose2Sim / anipose / EasyMocap project folder")
    parser.add_argument("--subject", help="only this subject")
    parser.add_argument("--sequence", help="only this sequence (<Action>_<Trial>)")
    parser.add_argument("--trial", help="project: only this trial")
    parser.add_argument("--calibration", help="project: a calibration file instead of the "
                                              "project's own")
    parser.set_defaults(run=run)


def describe(dataset, subject=None, sequence=None) -> tuple[list[str], list[str]]:
    """Validate and describe a data set (raises InputError on a file that cannot be read).

    Returns
    -------
    lines : list of str
        The report.
    problems : list of str
        Data that cannot be used although present (``<subject>/<sequence>: <problem>``).
    """
    lines = [f"data set {dataset.root}"]
    problems = []
    subjects = [dataset.subject_dir(subject).name] if subject else dataset.subjects
    bdir = dataset.background_dir()
    for subj in subjects:
        names = dataset.sequences(subj)
        if sequence:
            names = [dataset.sequence(subj, sequence).name]
        lines.append(f"  {subj}: {len(names)} sequence(s)")
        for name in names:
            seq = dataset.sequence(subj, name)
            rig = seq.rig
            seq.check_video_sizes()
            seq.check_backgrounds()
            counts = seq.video_frame_counts()
            lines.append(f"    {name}: {seq.n_frames} synchronised frames, "
                         f"cameras {', '.join(seq.camera_names)}")
            lines.append(f"      mocap time of frame 1: {seq.common_time:.3f}, "
                         f"mocap frames per frame: {seq.common_scaling:.4f}")
            for cam in seq.camera_names:
                im_st, mc_st, mc_sc = seq.ofs[cam]
                n_bg = len(seq.background_paths(cam))
                w, h = rig[cam].size
                lines.append(f"      {cam:<4s} {w}x{h}  video frames {counts[cam]:>6d}  "
                             f"ofs ({im_st:g}, {mc_st:g}, {mc_sc:g})  start {seq.starts[cam]:>4d}"
                             f"  backgrounds {n_bg}")
            lines.append(f"      ground truth source: {seq.ground_truth_source or 'none'}")
            for problem in seq.problems:
                lines.append(f"      problem: {problem}")
                problems.append(f"{subj}/{name}: {problem}")
            gt = seq.ground_truth()
            if gt is None:
                lines.append("      ground truth: none")
            elif len(gt) == 0:
                lines.append("      ground truth: the XML holds no frame")
            else:
                n_valid = int(gt.enabled.all(axis=1).sum())
                lines.append(f"      ground truth: {len(gt)} frames ({gt.frames.min()}–"
                             f"{gt.frames.max()}), {n_valid} fully enabled")
            body = seq.body_file
            if body is not None:
                from ..io.body_file import read_body_file

                read_body_file(body)  # validates it
            lines.append(f"      subject body file: {body.name if body else 'none'}")
    if bdir is None:
        lines.append("  no Background folder")
    if problems:
        lines.append(f"all files read are valid, but {len(problems)} problem(s) leave data unused:")
        lines.extend(f"  {p}" for p in problems)
    else:
        lines.append("all files read are valid")
    return lines, problems


def describe_project(project, trial=None) -> tuple[list[str], list[str]]:
    """Validate and describe a project's trials (raises InputError on what cannot be read).

    Returns
    -------
    lines : list of str
        The report, with every assumption made (``note:`` lines).
    problems : list of str
        Data that cannot be used although present.
    """
    lines = [f"{project.kind} project {project.root}"]
    names = [project.trial(trial).name] if trial else list(project.trials)
    lines.append(f"  {len(project.trials)} trial(s): {', '.join(project.trials)}")
    problems = []
    for name in names:
        seq = project.sequence(name)
        seq.check_backgrounds()
        lines.extend(seq.describe())
        problems.extend(f"{name}: {p}" for p in seq.problems)
    lines.append("  no ground truth, no body file")
    if problems:
        lines.append(f"all files read are valid, but {len(problems)} problem(s) leave data unused:")
        lines.extend(f"  {p}" for p in problems)
    else:
        lines.append("all files read are valid")
    return lines, problems


def run(args: argparse.Namespace) -> int:
    from ..errors import InputError
    from ..io.sequence import detect_layout

    if detect_layout(args.dataset) == "humaneva":
        from ..io.humaneva import Dataset

        for option in ("trial", "calibration"):
            if getattr(args, option):
                raise InputError(f"--{option}", "is for projects; a HumanEva-layout data set has "
                                                "--subject and --sequence")
        lines, problems = describe(Dataset(args.dataset), args.subject, args.sequence)
    else:
        from ..io.project import Project

        trial = args.trial or args.sequence or args.subject
        lines, problems = describe_project(Project(args.dataset, calibration=args.calibration),
                                           trial)
    for line in lines:
        print(line)
    return 1 if problems else 0
