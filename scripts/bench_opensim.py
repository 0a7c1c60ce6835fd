"""OpenSim joint angles of tracked clips against the angles of the rendered ground truth.

For every result ``RUN/<Subject>/<Action>_<Trial>.h5`` a copy is handed to ``voxelmocap export
--opensim`` (a model scaled to the tracked body, OpenSim inverse kinematics), and the knee and
hip flexion of the ``.mot`` are compared with the same angles computed in closed form from the
data set's ground-truth landmarks (``DATA/<Subject>/Mocap_Data/<Action>_<Trial>.xml``):
:func:`voxelmocap.evaluation.knee_flexion` and :func:`~voxelmocap.evaluation.hip_flexion`
(``tests/io/test_opensim.py`` checks OpenSim against them on ground truth to 0.5°). Printed per
result: the landmarks' μ, the mean absolute knee and hip flexion error (left / right, degrees)
and the largest IK marker RMS (mm). Needs the ``opensim`` extra.

Usage::

    python scripts/bench_opensim.py --data DATA --runs RUN [RUN ...]

Feeds docs/benchmarks.md, "Outputs", "OpenSim joint angles".
"""

from __future__ import annotations

import argparse
import contextlib
import io
import shutil
import tempfile
from pathlib import Path

import numpy as np

from voxelmocap.evaluation import hip_flexion, knee_flexion
from voxelmocap.io.body_pose_xml import read_body_pose_xml
from voxelmocap.io.results import read_result
from voxelmocap.joints import endpoints_to_landmarks


def _table(osim, path: Path) -> dict[str, np.ndarray]:
    """A .mot / .sto as columns, with its time column as ``"time"`` (s)."""
    table = osim.TimeSeriesTable(str(path))
    labels = list(table.getColumnLabels())
    values = np.array([[table.getRowAtIndex(i)[j] for j in range(len(labels))]
                       for i in range(table.getNumRows())])
    return {"time": np.array(table.getIndependentColumn()),
            **dict(zip(labels, values.T, strict=True))}


def main() -> None:
    import opensim as osim

    from voxelmocap.cli import main as cli
    from voxelmocap.io.opensim import opensim_paths

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", required=True)
    parser.add_argument("--runs", nargs="+", required=True)
    args = parser.parse_args()
    print("| run | clip | μ (mm) | knee flexion error l / r (°) | hip flexion error l / r (°) "
          "| IK marker RMS max (mm) |")
    print("|---|---|---|---|---|---|")
    knees = []
    for run in args.runs:
        for path in sorted(Path(run).glob("*/*.h5")):
            with tempfile.TemporaryDirectory() as tmp:
                copy = Path(tmp) / path.name  # the export writes beside the result
                shutil.copy(path, copy)
                with contextlib.redirect_stdout(io.StringIO()):
                    if cli(["export", str(copy), "--opensim", "-q"]) != 0:
                        raise SystemExit(f"{path}: export --opensim failed")
                paths = opensim_paths(copy)
                mot, errors = _table(osim, paths["motion"]), _table(osim, paths["errors"])
            res = read_result(path)
            gt = read_body_pose_xml(Path(args.data) / path.parent.name / "Mocap_Data"
                                    / f"{path.stem}.xml")
            rows = gt.index_of(res.frames)
            if (rows < 0).any():
                raise SystemExit(f"{path}: frames without ground truth")
            mu = float(np.linalg.norm(res.landmarks - endpoints_to_landmarks(gt.endpoints[rows]),
                                      axis=2).mean())
            # the .mot holds the frames with a person only: matched by its time column
            frames = np.rint(mot["time"] * float(res.attrs["frame_rate"])).astype(int) \
                + int(res.frames[0])
            truth = endpoints_to_landmarks(gt.endpoints[gt.index_of(frames)])
            knee = [float(np.abs(mot[f"knee_angle_{s}"] - knee_flexion(truth, s)).mean())
                    for s in "lr"]
            hip = [float(np.abs(mot[f"hip_flexion_{s}"] - hip_flexion(truth, s)).mean())
                   for s in "lr"]
            knees += knee
            print(f"| {run} | {path.stem} | {mu:.1f} | {knee[0]:.1f} / {knee[1]:.1f} | "
                  f"{hip[0]:.1f} / {hip[1]:.1f} | "
                  f"{1000 * float(errors['marker_error_RMS'].max()):.1f} |", flush=True)
    print(f"\nknee flexion error, mean over runs and sides: {np.mean(knees):.1f}° "
          f"(largest {np.max(knees):.1f}°)")


if __name__ == "__main__":
    main()
