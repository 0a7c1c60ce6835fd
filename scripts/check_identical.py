"""Compare two tracking result files dataset by dataset: the rebuild's bit-identity check.

Usage: ``python scripts/check_identical.py REFERENCE.h5 CANDIDATE.h5``

Prints one line per dataset (``state``, ``map_state``, ``landmarks``, ``endpoints``,
``log_likelihood``, ``part_scores``, ``ess``, ``betas``, ``frames``) saying whether the arrays are
equal bit for bit (``numpy.array_equal``) and, when not, the largest absolute difference; exits 1
when any differs. Reads the raw HDF5 datasets (rows up to the committed frame count when the file
says so), so it compares files of the old and the new result format alike.
"""

from __future__ import annotations

import sys

import h5py
import numpy as np

NAMES = ("frames", "state", "map_state", "landmarks", "endpoints", "log_likelihood",
         "part_scores", "ess", "betas")


def _read(path: str) -> dict:
    with h5py.File(path, "r") as f:
        n = None
        if "commit" in f:  # streamed format: rows beyond the committed count are not results
            n = int(f["commit"][0])
        return {k: f[k][()] if n is None else f[k][:n] for k in NAMES if k in f}


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if len(argv) != 2:
        print(__doc__.strip().splitlines()[2], file=sys.stderr)
        return 2
    ref, new = _read(argv[0]), _read(argv[1])
    ok = True
    for name in NAMES:
        if name not in ref or name not in new:
            print(f"{name:15s} missing in {'reference' if name not in ref else 'candidate'}")
            ok = False
            continue
        a, b = ref[name], new[name]
        same = a.shape == b.shape and np.array_equal(a, b)
        detail = "" if same else (f" shapes {a.shape} vs {b.shape}" if a.shape != b.shape else
                                  f" max |Δ| = {np.max(np.abs(a - b)):.3g}")
        print(f"{name:15s} {'identical' if same else 'DIFFERENT'}{detail}")
        ok &= same
    print("bit-identical" if ok else "NOT bit-identical")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
