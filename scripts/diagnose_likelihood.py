"""Does the likelihood prefer the true pose? The ground truth against a run's estimates.

For each clip of ``bench_no_answer.py`` (the five ``../shared/mocap`` renders), every ``--every``-th
frame: the body model of the data set (the subject's body file) fitted to the true landmarks
(``fit_to_landmarks``) and the run's estimate are scored on that frame's voxels, with the DO
variance of the likelihood set to each value of ``--do``; prints, per clip and value, in how many
frames the true pose scores at least as well as the estimate and the mean difference of their
log-likelihoods. A negative difference means the likelihood, not the search, pulls the estimate
away from the truth. ``--parts`` also prints the per-part scores (Out, DO, Empty, Surf) of the
true pose in the first frame.

Usage::

    python scripts/diagnose_likelihood.py --data DATA --run OUT/with_answer/seed0 \\
        [--every 20] [--do 0.01,0.03,0.1,0.3] [--parts]

Feeds docs/benchmarks.md, "Likelihood" (does the likelihood prefer the truth: the double-occupancy
table).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import h5py
import numpy as np
from bench_accuracy import CLIPS

from voxelmocap.body import fit_to_landmarks
from voxelmocap.config import TrackConfig
from voxelmocap.io.humaneva import Dataset
from voxelmocap.joints import endpoints_to_landmarks
from voxelmocap.run.bodies import body_model_for
from voxelmocap.run.measurement import MeasurementRunner
from voxelmocap.score.likelihood import log_likelihood_from_scores, part_scores


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", required=True, help="the rendered clips (with ground truth)")
    parser.add_argument("--run", required=True, help="a run folder: <Subject>/<Action>_1.h5")
    parser.add_argument("--every", type=int, default=20)
    parser.add_argument("--do", default="0.01,0.03,0.1,0.3", help="DO variances to compare")
    parser.add_argument("--parts", action="store_true")
    args = parser.parse_args()
    config = TrackConfig()
    base = list(config.likelihood.variances)
    values = [float(v) for v in args.do.split(",")]
    for index, (_clip, action, _start) in enumerate(CLIPS):
        subject, name = f"S{index + 1}", f"{action}_1"
        h5 = Path(args.run) / subject / f"{name}.h5"
        if not h5.exists():
            continue
        seq = Dataset(args.data).sequence(subject, name)
        gt = seq.ground_truth()
        model, _ = body_model_for(seq, gt)
        with h5py.File(h5, "r") as f:
            states, frames = f["state"][:], f["frames"][:]
        runner = MeasurementRunner(seq, config, log=None)
        wins = np.zeros(len(values), int)
        diffs = np.zeros(len(values))
        n = 0
        for frame, images in seq.frames(frames[::args.every]):
            i = int(np.flatnonzero(frames == frame)[0])
            observation = runner.measure(images)
            truth = fit_to_landmarks(model, endpoints_to_landmarks(
                gt.endpoints[gt.index_of(np.array([frame]))[0]]))
            scores = part_scores(observation, model, np.stack([truth, states[i]]), clip=True)
            if args.parts and n == 0:
                print(f"{subject} {name} frame {frame}: true pose per part (out, do, empty, surf)")
                for part, s in zip(model.part_names, scores[0], strict=True):
                    print(f"  {part:12s} " + " ".join(f"{v:.2f}" for v in s))
            for k, v in enumerate(values):
                ll = log_likelihood_from_scores(scores, variances=(base[0], v, *base[2:]))
                wins[k] += ll[0] >= ll[1]
                diffs[k] += ll[0] - ll[1]
            n += 1
        print(f"{subject} {name:11s} " + "; ".join(
            f"σ²_DO {v:g}: truth ≥ estimate in {w}/{n}, mean Δll {d / n:+.1f}"
            for v, w, d in zip(values, wins, diffs, strict=True)), flush=True)


if __name__ == "__main__":
    main()
