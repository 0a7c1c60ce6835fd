"""Bit-identity of tracked results before and after a change that should not alter them.

Usage::

    python scripts/check_identical.py make OUT [--python PY] [--pythonpath DIR]
    python scripts/check_identical.py compare REFERENCE CANDIDATE
    python scripts/check_identical.py REFERENCE.h5 CANDIDATE.h5

``make`` renders one fixed synthetic walk (90 frames, seed 0, the packaged rig) into
``OUT/data`` and tracks it through the command line three ways, each a separate process:

* ``gt20``: frames 1–20 started from the ground truth with the subject's body file;
* ``auto30``: frames 1–30 without ground truth or body file (the start searched from the voxels,
  the multi-start, the body fitted);
* ``passes``: frames 1–20 without background videos, ground truth or body file: the plate
  learnt from the sequence, three passes, the third continuing the second
  (``--layers 3 --particles 200`` to keep it short).

``--pythonpath DIR`` runs another checkout's package (e.g. a ``git worktree`` of the commit
before the change), so the same scenarios come from both versions. ``compare`` checks every
result file of one ``make`` folder against the other's (every pass's); the two-file form
compares two result files. Each comparison prints one line per dataset (``state``,
``map_state``, ``landmarks``, ``endpoints``, ``log_likelihood``, ``part_scores``, ``ess``,
``betas``, ``frames``): equal bit for bit (the same bytes) or the largest difference.
Exit status 1 when anything differs.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np

NAMES = ("frames", "state", "map_state", "landmarks", "endpoints", "log_likelihood",
         "part_scores", "ess", "betas")
#: scenario → (data folder, track arguments)
SCENARIOS = {
    "gt20": ("data", ["--frames", "1:20"]),
    "auto30": ("noanswer", ["--frames", "1:30"]),
    "passes": ("noplate", ["--frames", "1:20", "--layers", "3", "--particles", "200"]),
}


def _read(path) -> dict:
    with h5py.File(path, "r", swmr=True, locking=False) as f:
        n = None
        if "commit" in f:  # streamed format: rows beyond the committed count are not results
            n = int(f["commit"][0])
        return {k: f[k][()] if n is None else f[k][:n] for k in NAMES if k in f}


def compare_files(ref, new, *, prefix: str = "") -> bool:
    """Print one line per dataset; True when all are equal bit for bit."""
    a_all, b_all = _read(ref), _read(new)
    ok = True
    for name in NAMES:
        if name not in a_all or name not in b_all:
            print(f"{prefix}{name:15s} missing in {'reference' if name not in a_all else 'candidate'}")
            ok = False
            continue
        a, b = a_all[name], b_all[name]
        # bit for bit (NaN in the flagged frames' ESS and β compares equal to itself this way)
        same = a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()
        detail = "" if same else (f" shapes {a.shape} vs {b.shape}" if a.shape != b.shape else
                                  f" max |Δ| = {np.nanmax(np.abs(a - b)):.3g}")
        print(f"{prefix}{name:15s} {'identical' if same else 'DIFFERENT'}{detail}")
        ok &= same
    return ok


def _cli(python: str, pythonpath: str | None, args: list[str]) -> None:
    env, cwd = dict(os.environ), None
    code = "import sys; from voxelmocap.cli import main; sys.exit(main(sys.argv[1:]))"
    if pythonpath:
        root = Path(pythonpath).resolve()
        if os.sep in python:  # a path, relative to here, not to the checkout the child runs in
            python = os.path.abspath(python)  # not resolve(): a venv's python is a symlink
        env["PYTHONPATH"], cwd = str(root), root
        # "python -c" puts its working folder first on sys.path: run it in the checkout, and
        # refuse to go on if another copy of the package is imported (an editable install's
        # finder, a stray folder)
        code = ("import sys, voxelmocap; from pathlib import Path; "
                f"assert Path(voxelmocap.__file__).resolve().is_relative_to({str(root)!r}), "
                "voxelmocap.__file__; " + code)
    subprocess.run([python, "-c", code, *args], check=True, env=env, cwd=cwd)


def make(out: Path, python: str, pythonpath: str | None) -> None:
    out.mkdir(parents=True, exist_ok=True)
    data = out / "data"
    if not data.exists():
        _cli(python, pythonpath, ["synth", str(data), "--motion", "walk", "--frames", "90",
                                  "--seed", "0", "--no-progress"])
    for name, drop in (("noanswer", ("Mocap_Data", "*_body.toml")),
                       ("noplate", ("Background", "Mocap_Data", "*_body.toml"))):
        if not (out / name).exists():
            shutil.copytree(data, out / name, ignore=shutil.ignore_patterns(*drop))
    for name, (folder, extra) in SCENARIOS.items():
        _cli(python, pythonpath, ["track", str(out / folder), "--subject", "S1", "--sequence",
                                  "Walking_1", "--seed", "0", "--no-progress", "--overwrite",
                                  "--out", str(out / name), *extra])


def compare(ref: Path, new: Path) -> bool:
    ok = True
    files = sorted(p.relative_to(ref) for p in ref.rglob("*.h5") if p.parts[len(ref.parts)]
                   in SCENARIOS)
    if not files:
        print(f"no result files under {ref}")
        return False
    for rel in files:
        print(f"== {rel}")
        if not (new / rel).is_file():
            print(f"   missing in {new}")
            ok = False
            continue
        ok &= compare_files(ref / rel, new / rel, prefix="   ")
    return ok


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if len(argv) == 2 and all(a.endswith(".h5") for a in argv):
        ok = compare_files(*argv)
    else:
        parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
        sub = parser.add_subparsers(dest="what", required=True)
        m = sub.add_parser("make")
        m.add_argument("out", type=Path)
        m.add_argument("--python", default=sys.executable)
        m.add_argument("--pythonpath")
        c = sub.add_parser("compare")
        c.add_argument("reference", type=Path)
        c.add_argument("candidate", type=Path)
        args = parser.parse_args(argv)
        if args.what == "make":
            make(args.out.resolve(), args.python, args.pythonpath)
            return 0
        ok = compare(args.reference, args.candidate)
    print("bit-identical" if ok else "NOT bit-identical")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
