"""Constant per-landmark offsets of a run in the body's frame: proportions or pose?

For each result of a ``bench_no_answer.py`` run (``RUN/seed*/<Subject>/<Action>_1.h5``), the error
vector of every landmark is expressed in the pelvis frame of the ground truth (x: right hip → left
hip, z: pelvis → thorax made orthogonal, y = z × x) and averaged over the frames. A large mean
offset that stays put over the clip is a body-model matter (where the model puts the joint); what
is left after removing it is the pose error. Prints μ, μ after removing the offsets, and the size
of each landmark's offset, and each wrist's and ankle's error along its estimated limb.

Usage::

    python scripts/landmark_bias.py RUN --data DATA
    python scripts/landmark_bias.py OUT/accuracy/TAG --renders OUT/renders   # bench_facing.py runs

With ``--renders``, RUN is a ``bench_facing.py`` tag folder (``<render>/seed*/<Subject>/<name>.h5``)
and each run is scored against its render's ground truth (``OUT/renders/<render>/data``); a last
line gives each landmark's mean error over all the runs.

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


#: The limbs' ends and the joints before them: the end's error along the estimated limb.
LIMB_ENDS = (("l_elbow", "l_wrist"), ("r_elbow", "r_wrist"), ("l_knee", "l_ankle"),
             ("r_knee", "r_ankle"))


def along_limb(est, gt) -> np.ndarray:
    """``(4,)`` mean component (mm) of each limb end's error along its estimated limb (elbow →
    wrist, knee → ankle; :data:`LIMB_ENDS`), landmarks ``(F, 15, 3)``: positive = beyond the
    true joint, as when a cone takes in the hand or the foot."""
    index = {n: i for i, n in enumerate(LANDMARK_NAMES)}
    out = []
    for joint, end in LIMB_ENDS:
        axis = est[:, index[end]] - est[:, index[joint]]
        axis /= np.linalg.norm(axis, axis=1, keepdims=True)
        out.append(np.sum((est[:, index[end]] - gt[:, index[end]]) * axis, axis=1).mean())
    return np.array(out)


def runs(run: Path, data: str | None, renders: str | None):
    """``(label, result, ground-truth xml)`` of every result in ``run``."""
    if renders is not None:   # a bench_facing.py tag folder
        for h5 in sorted(run.glob("*/seed*/*/*.h5")):
            render, seed, subject = h5.parts[-4], h5.parts[-3], h5.parts[-2]
            xml = Path(renders) / render / "data" / subject / "Mocap_Data" / f"{h5.stem}.xml"
            yield f"{render} {seed}", h5, xml
        return
    for index, (_clip, action, _start) in enumerate(CLIPS):
        subject, name = f"S{index + 1}", f"{action}_1"
        for seed in sorted(run.glob("seed*")):
            h5 = seed / subject / f"{name}.h5"
            if h5.exists():
                yield (f"{subject} {name} {seed.name}", h5,
                       Path(data) / subject / "Mocap_Data" / f"{name}.xml")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("run", help="a bench_no_answer.py variant folder (with seed*/), or a "
                                    "bench_facing.py tag folder with --renders")
    where = parser.add_mutually_exclusive_group(required=True)
    where.add_argument("--data", help="the rendered clips (with ground truth)")
    where.add_argument("--renders", help="bench_facing.py's renders folder (OUT/renders)")
    args = parser.parse_args()
    errors, along = [], []
    for label, h5, xml in runs(Path(args.run), args.data, args.renders):
        ev = score_against(h5, xml, delta=100.0)
        est, gt = endpoints_to_landmarks(ev.est), endpoints_to_landmarks(ev.gt)
        d = body_frame_errors(est, gt)
        bias = d.mean(axis=0)
        size = np.linalg.norm(d, axis=2)
        errors.append(size.mean(axis=0))
        print(f"{label}: μ {size.mean():.1f} mm, "
              f"after removing the offsets {np.linalg.norm(d - bias, axis=2).mean():.1f} mm")
        print("   errors:  " + " ".join(f"{n} {e:.0f}"
                                        for n, e in zip(LANDMARK_NAMES, size.mean(axis=0),
                                                        strict=True)))
        print("   offsets: " + " ".join(f"{n} {np.linalg.norm(b):.0f}"
                                        for n, b in zip(LANDMARK_NAMES, bias, strict=True)))
        along.append(along_limb(est, gt))
        print("   along the limb: " + " ".join(f"{e} {a:+.0f}" for (_, e), a
                                               in zip(LIMB_ENDS, along[-1], strict=True)))
    if errors:
        print(f"mean error over {len(errors)} runs: " + " ".join(
            f"{n} {e:.0f}" for n, e in zip(LANDMARK_NAMES, np.mean(errors, axis=0), strict=True)))
        print("mean along the limb: " + " ".join(
            f"{e} {a:+.1f}" for (_, e), a in zip(LIMB_ENDS, np.mean(along, axis=0), strict=True)))


if __name__ == "__main__":
    main()
