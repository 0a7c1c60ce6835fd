"""How well the voxel likelihood recovers a subject's lengths: the fit of ``voxelmocap.pose.body_size``
started from poses fitted to the ground truth with the height-scaled average adult, compared with
the subject's body file (per-length ratio fitted / file, and the average's ratio for reference).

The poses come from the answer (the ground-truth landmarks), so this isolates the body fit from
the tracking; ``scripts/bench_no_answer.py --set init.body='"fitted"'`` measures the whole thing.

Usage::

    python scripts/study_body_size.py --data /work/bench/data [--frames 10] [--fit 5]

Feeds docs/benchmarks.md, "Body size" (the forearm's fitted length from ground-truth poses, which is
why the forearm is not fitted).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from bench_accuracy import SEQUENCES as CLIPS

from voxelmocap.body import BodyModel, fit_to_landmarks
from voxelmocap.config import TrackConfig
from voxelmocap.io.body_file import read_body_file
from voxelmocap.io.sequence import open_sequence
from voxelmocap.joints import endpoints_to_landmarks
from voxelmocap.pose.body_size import FITTED_KEYS, fit_body_dimensions, pick_frames
from voxelmocap.run.measurement import MeasurementRunner


def length(dims, key) -> float:
    return float(np.mean(getattr(dims, key)))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", default="/work/bench/data")
    parser.add_argument("--frames", type=int, default=10, help="first frames considered")
    parser.add_argument("--fit", type=int, default=5, help="frames fitted, spread over them")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--free-height", action="store_true")
    parser.add_argument("--coverage", type=float, default=0.0)
    parser.add_argument("--with-do", action="store_true",
                        help="keep the double-occupancy term in the fit (the default drops it)")
    parser.add_argument("--subjects", default=",".join(CLIPS))
    args = parser.parse_args()
    config = TrackConfig()
    print("ratio fitted / body file (avg: the height-scaled average / body file)")
    print("subject " + " ".join(f"{k[:9]:>9}" for k in FITTED_KEYS) + "   ll0 → ll   s")
    for subject in args.subjects.split(","):
        seq = open_sequence(args.data, subject, CLIPS[subject])
        truth = read_body_file(seq.body_file)
        gt = seq.ground_truth()
        frames = seq.frame_numbers[:args.frames]
        pick = frames[pick_frames(len(frames), args.fit)]
        stage = MeasurementRunner(seq, config)
        observations, landmarks = [], []
        for frame, images in seq.frames(frames):
            obs = stage.measure(images, frame=frame)
            if frame in pick:
                observations.append(obs)
                row = int(np.searchsorted(gt.frames, frame))
                landmarks.append(endpoints_to_landmarks(gt.endpoints[row]))
        base = BodyModel.scaled(truth.height).dimensions
        model = BodyModel(base)
        states = np.array([fit_to_landmarks(model, lm) for lm in landmarks])
        t0 = time.perf_counter()
        fit = fit_body_dimensions(observations, states, base,
                                  variances=config.likelihood.variances,
                                  rounds=args.rounds, keep_height=not args.free_height,
                                  coverage=args.coverage, double_occupancy=args.with_do)
        dt = time.perf_counter() - t0
        ratios = [length(fit.dimensions, k) / max(length(truth, k), 1e-9) for k in FITTED_KEYS]
        avg = [length(base, k) / max(length(truth, k), 1e-9) for k in FITTED_KEYS]
        print(f"{subject} fit " + " ".join(f"{r:9.2f}" for r in ratios)
              + f"  {fit.start_log_likelihood:.1f} → {fit.log_likelihood:.1f}  {dt:.0f}")
        print(f"{subject} avg " + " ".join(f"{r:9.2f}" for r in avg))
        print(f"{subject} mm  " + " ".join(f"{length(truth, k):9.0f}" for k in FITTED_KEYS))


if __name__ == "__main__":
    main()
