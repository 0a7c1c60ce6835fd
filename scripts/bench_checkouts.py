"""Benchmark: one ``voxelmocap`` command run from two checkouts side by side.

Runs the command (everything after ``--``) as a whole process with ``PYTHONPATH`` set to checkout
A, then to checkout B, A, B … (``--runs`` pairs, after ``--warmup`` unrecorded pairs), each in its
own fresh output folder, and prints per run and as medians the wall seconds, the CPU seconds
(user + system, from the kernel's accounting of the finished child: ``os.wait4``) and the peak
resident memory, then the ratios A/B pair by pair and their median. The string ``{out}`` in the
command is replaced by the run's output folder (deleted before and after each run, unless
``--keep``). On a shared machine quote the medians and the ratios, not a single time::

    python scripts/bench_checkouts.py A_CHECKOUT B_CHECKOUT [--runs 3] [--warmup 1] -- \\
        track Demo_SinglePerson --out {out} --no-progress -q --seed 0

Feeds docs/benchmarks.md, "Real recording (Pose2Sim demo)" (time).
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def run_once(checkout: Path, command: list[str], out: Path) -> dict:
    """One run of ``python -m voxelmocap.cli COMMAND`` importing ``checkout``'s package."""
    shutil.rmtree(out, ignore_errors=True)
    env = dict(os.environ, PYTHONPATH=str(checkout))
    args = [sys.executable, "-m", "voxelmocap.cli",
            *[a.replace("{out}", str(out)) for a in command]]
    log = out.with_suffix(".stderr")
    with open(log, "wb") as err:
        t0 = time.perf_counter()
        proc = subprocess.Popen(args, env=env, stdout=subprocess.DEVNULL, stderr=err)
        _, status, usage = os.wait4(proc.pid, 0)     # this child's own CPU time and peak RSS
        wall = time.perf_counter() - t0
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode != 0:
        tail = log.read_text(errors="replace").strip()[-500:]
        raise SystemExit(f"{checkout}: exit {proc.returncode}: {tail}")
    return {"wall": wall, "cpu": usage.ru_utime + usage.ru_stime,
            "peak_mib": usage.ru_maxrss / 1024}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("a", type=Path, help="checkout A (its folder holding voxelmocap/)")
    parser.add_argument("b", type=Path, help="checkout B")
    parser.add_argument("--runs", type=int, default=3, help="recorded pairs (default 3)")
    parser.add_argument("--warmup", type=int, default=1, help="unrecorded pairs first (default 1)")
    parser.add_argument("--keep", action="store_true", help="keep the last run's output folders")
    argv = sys.argv[1:] if argv is None else list(argv)
    # the voxelmocap command follows "--" (its options are not this script's)
    cut = argv.index("--") if "--" in argv else len(argv)
    args = parser.parse_args(argv[:cut])
    command = argv[cut + 1:]
    if not command:
        parser.error("give the voxelmocap command after --")
    for c in (args.a, args.b):
        if not (c / "voxelmocap" / "__init__.py").is_file():
            parser.error(f"{c}: no voxelmocap package there")
    if args.runs < 1 or args.warmup < 0:
        parser.error("--runs must be at least 1 and --warmup at least 0")
    work = Path(tempfile.mkdtemp(prefix="bench_checkouts_"))
    rows = {"A": [], "B": []}
    try:
        for i in range(args.warmup + args.runs):
            for name, checkout in (("A", args.a), ("B", args.b)):
                r = run_once(checkout, command, work / name)
                kind = "warm-up" if i < args.warmup else f"run {i - args.warmup + 1}"
                print(f"{kind:8s} {name}: wall {r['wall']:8.1f} s  cpu {r['cpu']:8.1f} s  "
                      f"peak {r['peak_mib']:7.0f} MiB  (load {os.getloadavg()[0]:.1f})",
                      flush=True)
                if i >= args.warmup:
                    rows[name].append(r)
        print(f"\nA = {args.a}\nB = {args.b}\ncommand: voxelmocap {' '.join(command)}")
        print(f"medians of {args.runs} run(s) each:")
        for key, unit in (("wall", "s"), ("cpu", "s"), ("peak_mib", "MiB")):
            a = statistics.median(r[key] for r in rows["A"])
            b = statistics.median(r[key] for r in rows["B"])
            pairs = [x[key] / y[key] for x, y in zip(rows["A"], rows["B"], strict=True)]
            print(f"  {key:8s} A {a:9.1f} {unit:3s}  B {b:9.1f} {unit:3s}  A/B median "
                  f"{statistics.median(pairs):.3f} (pairs {min(pairs):.3f}–{max(pairs):.3f})")
    finally:
        if not args.keep:
            shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
