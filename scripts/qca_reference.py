"""Development script: Pose2Sim's own conversion of the demo's Qualisys calibration, as a fixture.

Runs Pose2Sim's ``calibration.calib_qca_fun`` (v0.10.49, the source beside the unpacked demo)
on ``Demo_SinglePerson/calibration/Calib.qca.txt`` and writes what it returns (names, sizes, K,
distortions, Rodrigues rotations, translations in metres) to ``tests/data/pose2sim_demo_qca.json``,
the reference ``tests/io/test_qualisys.py`` compares :func:`voxelmocap.io.qualisys.read_qca` with.

Pose2Sim's package ``__init__`` needs installed metadata, so the few functions involved are taken
from its source files and run as they are (no voxelmocap code is used).

    python scripts/qca_reference.py /work/p2s/x/Pose2Sim

Not a benchmark: it writes the fixture of ``tests/io/test_qualisys.py`` (needs Pose2Sim's source
and ``lxml``, which the package does not).
"""

from __future__ import annotations

import ast
import json
import re
import sys
from pathlib import Path

import cv2
import numpy as np
from lxml import etree


def pose2sim_functions(source_dir: Path, wanted: dict[str, list[str]]) -> dict:
    """Exec the named top-level functions of Pose2Sim's modules in one namespace."""
    namespace = {"np": np, "cv2": cv2, "etree": etree, "re": re,
                 "logging": __import__("logging")}
    for module, names in wanted.items():
        text = (source_dir / f"{module}.py").read_text()
        tree = ast.parse(text)
        for node in tree.body:
            if isinstance(node, ast.FunctionDef) and node.name in names:
                exec(compile(ast.Module([node], []), module, "exec"), namespace)
    return namespace


def main(source_dir: str) -> None:
    source = Path(source_dir)
    ns = pose2sim_functions(source, {
        "common": ["world_to_camera_persp", "rotate_cam", "natural_sort_key"],
        "calibration": ["read_qca", "calib_qca_fun"],
    })
    qca = source / "Demo_SinglePerson" / "calibration" / "Calib.qca.txt"
    ret, C, S, D, K, R, T = ns["calib_qca_fun"](str(qca), 1)
    out = {"source": "Pose2Sim 0.10.49 calibration.calib_qca_fun(Calib.qca.txt, binning_factor=1)",
           "cameras": [{"name": c, "size": list(map(float, s)), "matrix": np.asarray(k).tolist(),
                        "distortions": np.asarray(d).tolist(), "rotation": np.asarray(r).tolist(),
                        "translation_m": np.asarray(t).tolist(), "residual": float(e)}
                       for e, c, s, d, k, r, t in zip(ret, C, S, D, K, R, T, strict=True)]}
    path = Path(__file__).resolve().parents[1] / "tests" / "data" / "pose2sim_demo_qca.json"
    path.write_text(json.dumps(out, indent=1) + "\n")
    print(f"wrote {path}")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "/work/p2s/x/Pose2Sim")
