"""Accuracy without the answer: the five mocap clips tracked with no ground truth and no body file.

What every real user has is videos and a calibration. This benchmark renders (or reuses) the five
``../shared/mocap`` clips of ``bench_accuracy.py`` (never ``holdout/``), makes for each a copy of
the data set *without* ``Mocap_Data`` (no body_pose XML, no ``<Subject>_body.toml``: videos,
backgrounds, calibration and sync are linked, not copied), tracks the copy, and scores the
result against the original ground truth. ``--with-answer`` tracks the original instead (first
frame's ground truth and the body file), for the comparison the issue asks for.

Usage::

    python scripts/bench_no_answer.py --data /tmp/voxelmocap_acc/data --out /tmp/noanswer \\
        [--seeds 3] [--frames 100] [--with-answer | --keep-body] [--clips Walking,Jog]
        [--cameras BW1,BW2,BW3,BW4]

Feeds docs/benchmarks.md, "Accuracy on rendered clips" (with and without the answer, four cameras,
how the default got here, the ablation) and "Body size"; its runs feed ``ablation_table.py``,
``bench_smoothing.py``, ``bench_confidence.py``, ``landmark_bias.py``, ``body_size_table.py`` and
``diagnose_likelihood.py``.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import time
from pathlib import Path

from voxelmocap import cpu_paths

# Before NumPy loads: the NumPy loops and OpenBLAS kernels `voxelmocap track` runs with, so that
# these runs are the command's on any CPU (voxelmocap.cpu_paths).
cpu_paths.pin()

import numpy as np  # noqa: E402
from bench_accuracy import CLIPS, MOCAP  # noqa: E402

from voxelmocap.config import TrackConfig, with_overrides  # noqa: E402
from voxelmocap.io.humaneva import Dataset  # noqa: E402
from voxelmocap.io.reports import score_against  # noqa: E402
from voxelmocap.run.pipeline import track_sequence  # noqa: E402
from voxelmocap.synth import generate  # noqa: E402


def stripped_copy(data: Path, subject: str, dest: Path, *, keep_body: bool = False,
                  keep_background: bool = True) -> Path:
    """``dest``: the data set with ``<subject>/Mocap_Data`` left out (links, not copies);
    with ``keep_body`` the body file ``<subject>_body.toml`` stays (the ground truth goes);
    without ``keep_background`` the ``Background/`` videos go too (the tracker then learns its
    plate from the sequence)."""
    if dest.exists():
        return dest
    tmp = dest.with_name(dest.name + ".building")
    shutil.rmtree(tmp, ignore_errors=True)
    for path in data.rglob("*"):
        rel = path.relative_to(data)
        if rel.parts[0] not in ((subject, "Background") if keep_background else (subject,)):
            continue
        if "Mocap_Data" in rel.parts and not (keep_body and path.name == f"{subject}_body.toml"):
            continue
        target = tmp / rel
        if path.is_dir():
            target.mkdir(parents=True, exist_ok=True)
        else:
            target.parent.mkdir(parents=True, exist_ok=True)
            os.symlink(path.resolve(), target)
    tmp.rename(dest)
    return dest


def parse_sets(items) -> dict:
    """``["filter.search=hierarchical", "filter.refine_evaluations=40"]`` → overrides."""
    import tomllib

    out = {}
    for item in items:
        key, _, value = item.partition("=")
        try:
            out[key.strip()] = tomllib.loads(f"v = {value}")["v"]
        except tomllib.TOMLDecodeError:
            out[key.strip()] = value
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", default="/tmp/voxelmocap_acc/data",
                        help="rendered clips (made here when missing)")
    parser.add_argument("--out", default="/tmp/voxelmocap_noanswer")
    parser.add_argument("--frames", type=int, default=100)
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--clips", help="comma-separated subset of actions")
    parser.add_argument("--init", default="auto", choices=["auto", "extremities", "voxels"],
                        help="init.method (auto: the ground truth with --with-answer, else "
                             "extremities; voxels: the first method, centroid + yaw search)")
    parser.add_argument("--body", default=TrackConfig().init.body,
                        choices=["voxels", "average", "fitted"],
                        help="init.body: the body's size without a body file (default: the "
                             "package's)")
    parser.add_argument("--hypotheses", type=int, default=4, help="init.hypotheses")
    parser.add_argument("--multistart", type=int, default=None,
                        help="init.multistart_frames (default: the config's, 10)")
    parser.add_argument("--with-answer", action="store_true",
                        help="track the original data (ground truth of frame 1, body file)")
    parser.add_argument("--keep-body", action="store_true",
                        help="leave the body file in the stripped copy (no ground truth, the "
                             "subject's own body): the ablation 'body size from data vs file'")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="config override, e.g. filter.search=hierarchical (repeatable; "
                             "VALUE parsed as TOML)")
    parser.add_argument("--tag", help="name of this variant's result folder and json")
    parser.add_argument("--cameras", help="comma-separated cameras to track with (default all)")
    parser.add_argument("--track-frames", help="synchronised frames A:B to track (default all)")
    args = parser.parse_args()
    data, out = Path(args.data), Path(args.out)
    wanted = set(args.clips.split(",")) if args.clips else None
    config = with_overrides(TrackConfig(), **{"init.method": args.init, "init.body": args.body,
                                              "init.hypotheses": args.hypotheses,
                                              "init.multistart_frames": args.multistart})
    config = with_overrides(config, **parse_sets(args.set))
    tag = "with_answer" if args.with_answer else \
        f"{args.init}_{args.body}_{args.hypotheses}" \
        f"{'' if args.multistart is None else f'_multi{args.multistart}'}"
    tag = args.tag or tag
    rows = {}
    for index, (clip, action, start) in enumerate(CLIPS):
        if wanted and action not in wanted:
            continue
        subject, seq_name = f"S{index + 1}", f"{action}_1"
        if not (data / subject / "Mocap_Data" / f"{seq_name}.xml").exists():
            if not MOCAP.is_dir():
                raise SystemExit(f"{MOCAP} is not available")
            generate(data, motion=str(MOCAP / clip), frames=args.frames, subject=subject,
                     action=action, start=start, progress=True)
        gt_path = Dataset(data).sequence(subject, seq_name).ground_truth_path
        folder = "stripped_body" if args.keep_body else "stripped"
        source = data if args.with_answer else stripped_copy(
            data, subject, out / folder / subject, keep_body=args.keep_body)
        per_seed = []
        for seed in range(args.seeds):
            run = out / tag / f"seed{seed}"
            t0 = time.perf_counter()
            outcome = track_sequence(source, subject, seq_name, run, config=config, seed=seed,
                                     cameras=args.cameras.split(",") if args.cameras else None,
                                     frames=args.track_frames, resume=True, progress=False,
                                     log=lambda _m: None)
            wall = time.perf_counter() - t0
            sc = score_against(outcome.result_path, gt_path, delta=100.0).scores
            per_seed.append((sc.mu_mm, sc.mmta_pct, 1.0 / outcome.seconds_per_frame))
            print(f"{action:<9s} seed {seed}: μ {sc.mu_mm:7.1f} mm  MMTA {sc.mmta_pct:5.1f} %  "
                  f"{1.0 / outcome.seconds_per_frame:5.2f} frames/s "
                  f"({wall:.0f} s; init: {outcome.init_method})", flush=True)
        rows[action] = per_seed
    allv = np.array([np.mean(v, axis=0) for v in rows.values()])
    print(f"mean over clips: μ {allv[:, 0].mean():.1f} mm, MMTA {allv[:, 1].mean():.1f} %; "
          f"worst clip μ {allv[:, 0].max():.1f} mm")
    (out / f"{tag}.json").write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
