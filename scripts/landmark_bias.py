"""Constant per-landmark offsets of a run in the body's frame: proportions or pose?

For each result of a ``bench_no_answer.py`` run (``RUN/seed*/<Subject>/<Action>_1.h5``), the error
vector of every landmark is expressed in the pelvis frame of the ground truth (x: right hip → left
hip, z: pelvis → thorax made orthogonal, y = z × x) and averaged over the frames. A large mean
offset that stays put over the clip is a body-model matter (where the model puts the joint); what
is left after removing it is the pose error. Prints μ, μ after removing the offsets, and the size
of each landmark's offset.

Usage::

    python scripts/landmark_bias.py RUN --data DATA

Feeds docs/benchmarks.md, "Accuracy on rendered clips" (what is left without the answer) and "Body size".
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from bench_accuracy import CLIPS

from voxelmocap.io.reports import score_against
from voxelmocap.joints import LANDMARK_NAMES, endpoints_to_landmarks


def body_frame_errors(est, gt):
    """``(F, 15, 3)`` errors ``est − gt`` in the truth's pelvis frame (landmarks (F, 15, 3))."""
    x = gt[:, 8] - gt[:, 11]
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    z = gt[:, 0] - gt[:, 1]
    z -= np.sum(z * x, axis=1, keepdims=True) * x
    z /= np.linalg.norm(z, axis=1, keepdims=True)
    rot = np.stack([x, np.cross(z, x), z], axis=1)
    return np.einsum("fij,flj->fli", rot, est - gt)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("run", help="a bench_no_answer.py variant folder (with seed*/)")
    parser.add_argument("--data", required=True, help="the rendered clips (with ground truth)")
    args = parser.parse_args()
    for index, (_clip, action, _start) in enumerate(CLIPS):
        subject, name = f"S{index + 1}", f"{action}_1"
        for seed in sorted(Path(args.run).glob("seed*")):
            h5 = seed / subject / f"{name}.h5"
            if not h5.exists():
                continue
            ev = score_against(h5, Path(args.data) / subject / "Mocap_Data" / f"{name}.xml",
                               delta=100.0)
            est, gt = endpoints_to_landmarks(ev.est), endpoints_to_landmarks(ev.gt)
            d = body_frame_errors(est, gt)
            bias = d.mean(axis=0)
            print(f"{subject} {name} {seed.name}: μ {np.linalg.norm(d, axis=2).mean():.1f} mm, "
                  f"after removing the offsets {np.linalg.norm(d - bias, axis=2).mean():.1f} mm")
            print("   offsets: " + " ".join(f"{n} {np.linalg.norm(b):.0f}"
                                           for n, b in zip(LANDMARK_NAMES, bias, strict=True)))


if __name__ == "__main__":
    main()
