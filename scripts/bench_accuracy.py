"""Accuracy benchmark: the five ``../shared/mocap`` clips rendered and tracked, Table 1 layout.

Each clip (walk, jog, punch, wave, combo; never the ``holdout/`` clips) is rendered with the
``calib/humaneva_i_like`` rig into 7 cameras (``voxelmocap.synth.generate``, cached in ``--data``),
tracked at the paper's working point (20 mm voxels, 6 layers × 600 particles, initialised from the
first frame's ground truth) with ``--seeds`` seeds, and evaluated (δ = 100 mm). Prints, per action,
μ, σ, MMTP, MMTA (mean ± sd over seeds) beside the paper's Table 1, plus frames per second.

Usage: ``python scripts/bench_accuracy.py [--frames 100] [--seeds 3] [--out /tmp/voxelmocap_acc]``

Feeds docs/benchmarks.md, "Accuracy on rendered clips": :data:`CLIPS` defines the five clips every
rendered-clip benchmark uses (``bench_no_answer.py``, ``bench_recovery.py``, ``diagnose_likelihood.py``,
``landmark_bias.py``, ``body_size_table.py``, ``study_body_size.py`` import it) and :data:`PAPER` the
paper's row. Its own ground-truth-started table in the Table 1 layout was last recorded on
2026-11-22, before today's defaults (in git); the section's "with the answer" row now comes from
``bench_no_answer.py --with-answer``.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from voxelmocap import cpu_paths

# Before NumPy loads: the NumPy loops and OpenBLAS kernels `voxelmocap track` runs with, so that
# these runs are the command's on any CPU (voxelmocap.cpu_paths).
cpu_paths.pin()

import numpy as np  # noqa: E402

from voxelmocap.config import TrackConfig, with_overrides  # noqa: E402
from voxelmocap.io.humaneva import Dataset  # noqa: E402
from voxelmocap.io.reports import score_against  # noqa: E402
from voxelmocap.run.pipeline import track_sequence  # noqa: E402
from voxelmocap.synth import generate  # noqa: E402

MOCAP = Path(__file__).resolve().parents[1].parent / "shared" / "mocap"

#: clip file, HumanEva action, start time in the clip (s)
CLIPS = (
    ("05_01.bvh", "Walking", 2.0),
    ("02_03.bvh", "Jog", 1.0),
    ("dataset-1_punch_normal_002.bvh", "Box", 1.0),
    ("dataset-2_wave-right-hand_normal_001.bvh", "Gestures", 1.0),
    ("01_01.bvh", "Combo", 2.0),
)
#: subject → sequence of each rendered clip (``S<k>`` renders the k-th of :data:`CLIPS`)
SEQUENCES = {f"S{k + 1}": f"{action}_1" for k, (_clip, action, _start) in enumerate(CLIPS)}

#: Canton-Ferrer et al. 2009, Table 1 (HumanEva, 7 cameras, 20 mm, 6 × 600, δ = 100 mm).
PAPER = {"Walking": (96.52, 41.64, 72.05, 79.55), "Jog": (130.34, 62.01, 92.21, 68.24),
         "Box": (122.27, 42.68, 92.77, 68.38), "Gestures": (124.87, 45.66, 90.43, 69.17),
         "Average": (121.18, 45.92, 90.17, 71.36)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default="/tmp/voxelmocap_acc", help="data and runs folder")
    parser.add_argument("--frames", type=int, default=100)
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--layers", type=int, default=6)
    parser.add_argument("--particles", type=int, default=600)
    parser.add_argument("--clips", help="comma-separated subset of actions")
    args = parser.parse_args()
    if not MOCAP.is_dir():
        raise SystemExit(f"{MOCAP} is not available")
    out = Path(args.out)
    config = with_overrides(TrackConfig(), **{"filter.layers": args.layers,
                                              "filter.particles": args.particles})
    wanted = set(args.clips.split(",")) if args.clips else None
    rows = {}
    for index, (clip, action, start) in enumerate(CLIPS):
        if wanted and action not in wanted:
            continue
        data = out / "data"
        seq_name = f"{action}_1"
        subject = f"S{index + 1}"  # every clip is another performer, hence another subject
        if not (data / subject / "Mocap_Data" / f"{seq_name}.xml").exists():
            generate(data, motion=str(MOCAP / clip), frames=args.frames, subject=subject,
                     action=action, start=start, progress=True)
        gt_path = Dataset(data).sequence(subject, seq_name).ground_truth_path
        per_seed = []
        for seed in range(args.seeds):
            run = out / f"run_seed{seed}"
            outcome = track_sequence(data, subject, seq_name, run, config=config, seed=seed,
                                     resume=True, progress=True)
            sc = score_against(outcome.result_path, gt_path, delta=100.0).scores
            fps = 1.0 / float(np.median(_seconds(outcome.result_path)))
            per_seed.append((sc.mu_mm, sc.sigma_mm, sc.mmtp_mm, sc.mmta_pct, fps))
        rows[action] = np.array(per_seed)
        _print(rows, args)
    (out / "accuracy.json").write_text(json.dumps({k: v.tolist() for k, v in rows.items()}))


def _seconds(result_path):
    from voxelmocap.io.results import read_result

    return read_result(result_path).seconds[1:]  # the first frame includes JIT compilation


def _print(rows, args) -> None:
    print(f"\n{args.frames} frames per clip, 7 cameras, 20 mm, {args.layers} × {args.particles}, "
          f"{args.seeds} seeds (mean ± sd over seeds); paper = Canton-Ferrer et al. Table 1")
    print(f"{'':<10s}{'μ (mm)':>16s}{'σ':>14s}{'MMTP (mm)':>16s}{'MMTA (%)':>16s}{'frames/s':>10s}"
          f"   paper μ / σ / MMTP / MMTA")
    allv = []
    for action, v in rows.items():
        m, s = v.mean(axis=0), v.std(axis=0)
        allv.append(v)
        paper = PAPER.get(action)
        ptxt = " / ".join(f"{p:.2f}" for p in paper) if paper else "–"
        print(f"{action:<10s}" + "".join(f"{m[i]:>9.2f} ± {s[i]:<5.2f}" for i in range(4))
              + f"{m[4]:>8.2f}   {ptxt}")
    v = np.mean(np.stack(allv), axis=0)  # average of the actions, per seed
    m, s = v.mean(axis=0), v.std(axis=0)
    print(f"{'Average':<10s}" + "".join(f"{m[i]:>9.2f} ± {s[i]:<5.2f}" for i in range(4))
          + f"{m[4]:>8.2f}   " + " / ".join(f"{p:.2f}" for p in PAPER["Average"]))


if __name__ == "__main__":
    main()
