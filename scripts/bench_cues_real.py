"""Cue comparison on a real recording (the Pose2Sim demo): ``voxelmocap track --cues X`` per setting.

Every setting is the product's own run (:func:`voxelmocap.run.pipeline.track_sequence`, what
``voxelmocap track DEMO --out RUN/<setting> --cues X --layers L --particles P`` does: start from
the voxels, multi-start, body fitted, limb sweep), with the same filter budget (layers ×
particles, the joint search for every setting unless it is named in ``--hierarchical``). The
frames are measured once (background plate, silhouettes, voxels) and the same observations are
replayed to every setting: the runs differ by their cues only, and the measurement (minutes on
four 1080 × 1920 videos) is not repeated. Each run is then scored by
``scripts/bench_real.py landmarks RUN --ref REF`` (the independent MediaPipe reference) and one
JSON line per setting is appended to ``--json``: mean / median error, share within 100 mm,
µs per particle of the likelihood (over the frames tracked after the start was chosen).

    python scripts/bench_cues_real.py --out /tmp/cues_real --layers 4 --particles 150 \\
        --settings voxel,fused4,roi,edges,dt,blob3d,skin,uniform,voxel_hier --json real.jsonl
    python scripts/bench_cues_real.py --table real.jsonl

Feeds docs/benchmarks.md, "Image cues" (the Pose2Sim demo's table).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import re
import subprocess
import sys
import time
from pathlib import Path

from voxelmocap import cpu_paths

# Before NumPy loads: the NumPy loops and OpenBLAS kernels `voxelmocap track` runs with, so that
# these runs are the command's on any CPU (voxelmocap.cpu_paths).
cpu_paths.pin()

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_cues import HIERARCHICAL, SETTINGS  # noqa: E402

DEMO = Path("/work/p2s/x/Pose2Sim/Demo_SinglePerson")
REF = Path("/work/p2s_ref")


class _Replay:
    """A measurement runner that measures each frame once and hands the same observation to
    every later run of this process (the runs differ by their cues, not their measurement)."""

    def __init__(self, real):
        self._real = real
        self._observations: dict[int, object] = {}

    def __getattr__(self, name):
        return getattr(self._real, name)

    def measure(self, images, *, frame=None):
        if frame is None:
            return self._real.measure(images, frame=frame)
        if int(frame) not in self._observations:
            self._observations[int(frame)] = self._real.measure(images, frame=frame)
        return self._observations[int(frame)]


class _Costs:
    """A ``track_sequence`` recorder summing the likelihood's seconds and evaluations of the
    frames tracked after the start was chosen (the multi-start's frames are replayed with no
    tracker: not counted)."""

    def __init__(self):
        self.seconds, self.evaluations, self.frames = 0.0, 0, 0

    def start(self, seq, grid):
        pass

    def observe(self, frame, images, observation):
        pass

    def __call__(self, record, tracker):
        if tracker is None:
            return
        self.seconds += record.likelihood_seconds
        self.evaluations += tracker.filter.step_evaluations
        self.frames += 1


def run(demo, out, name, *, layers, particles, seed, frames, replay, hier=None):
    """Track the demo with one setting; (µs per particle, evaluations per frame, wall s).
    ``hier``: more config overrides for a hierarchical setting."""
    import voxelmocap.run.measurement as measurement
    import voxelmocap.run.pipeline as pipeline
    from voxelmocap.config import CuesConfig, TrackConfig, with_overrides

    search = "hierarchical" if name in HIERARCHICAL else "joint"
    config = with_overrides(TrackConfig(), **{"filter.layers": layers,
                                              "filter.particles": particles,
                                              "filter.search": search,
                                              "export.formats": [],
                                              # one pass: the cues' cost on one plate's frames
                                              "measurement.silhouette.plate_passes": 1,
                                              **((hier or {}) if search == "hierarchical"
                                                 else {})})
    config = dataclasses.replace(config, cues=CuesConfig(weights=dict(SETTINGS[name])))
    # the frame loop builds its runner through voxelmocap.run.measurement.MeasurementRunner
    real_runner = measurement.MeasurementRunner

    def runner(seq, cfg, log=None, **options):
        if "r" not in replay:
            replay["r"] = _Replay(real_runner(seq, cfg, log=log, **options))
        return replay["r"]

    costs = _Costs()
    measurement.MeasurementRunner = runner
    t0 = time.perf_counter()
    try:
        pipeline.track_sequence(demo, None, None, out, config=config, seed=seed, frames=frames,
                                progress=False, overwrite=True, recorder=costs)
    finally:
        measurement.MeasurementRunner = real_runner
    wall = time.perf_counter() - t0
    return (1e6 * costs.seconds / max(costs.evaluations, 1),
            costs.evaluations / max(costs.frames, 1), wall)


def score(run_dir: Path, ref: Path) -> dict:
    """``scripts/bench_real.py landmarks`` of one run: its summary line parsed, and its table."""
    script = Path(__file__).resolve().parent / "bench_real.py"
    text = subprocess.run([sys.executable, str(script), "landmarks", str(run_dir), "--ref",
                           str(ref)], capture_output=True, text=True, check=True).stdout
    m = re.search(r"mean (\d+) mm, median (\d+) mm, within 100 mm (\d+) %", text)
    return {"mean_mm": float(m[1]), "median_mm": float(m[2]), "within_100_pct": float(m[3]),
            "landmarks": text}


def table(paths) -> str:
    """A Markdown table of JSON-lines results: one row per setting and seed, in ``SETTINGS``
    order, then the mean over seeds of the settings run with more than one."""
    rows = [json.loads(line) for p in paths for line in Path(p).read_text().splitlines() if line]
    order = list(SETTINGS)
    rows.sort(key=lambda r: (order.index(r["setting"]), r["seed"]))
    out = ["| cues | search | seed | mean (mm) | median (mm) | within 100 mm | µs/particle | "
           "evaluations/frame |", "|---|---|---|---|---|---|---|---|"]

    def label(r):
        return ", ".join(k if v == 1 else f"{k}={v:g}" for k, v in r["weights"].items())

    for r in rows:
        out.append(f"| {label(r)} | {r['search']} | {r['seed']} | {r['mean_mm']:.0f} | "
                   f"{r['median_mm']:.0f} | {r['within_100_pct']:.0f} % | "
                   f"{r['us_per_particle']:.0f} | {r['evaluations_per_frame']:.0f} |")
    for name in order:
        got = [r for r in rows if r["setting"] == name]
        if len(got) > 1:
            mean = {k: sum(r[k] for r in got) / len(got)
                    for k in ("mean_mm", "median_mm", "within_100_pct")}
            out.append(f"| {label(got[0])} | {got[0]['search']} | mean of {len(got)} | "
                       f"{mean['mean_mm']:.0f} | {mean['median_mm']:.0f} | "
                       f"{mean['within_100_pct']:.0f} % | | |")
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--demo", type=Path, default=DEMO)
    ap.add_argument("--ref", type=Path, default=REF)
    ap.add_argument("--out", type=Path, help="run folders go to OUT/<setting>")
    ap.add_argument("--settings", default="voxel,fused4,roi,edges,dt,blob3d,skin,uniform")
    ap.add_argument("--layers", type=int, default=4)
    ap.add_argument("--particles", type=int, default=150)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--frames", help="A:B (default: every frame)")
    ap.add_argument("--hier", action="append", default=[], metavar="KEY=VALUE",
                    help="config override for the hierarchical settings only (repeatable), "
                         "e.g. filter.trunk_particles=125 to match the joint search's budget")
    ap.add_argument("--json", type=Path, help="append one JSON line per setting")
    ap.add_argument("--table", nargs="+", type=Path, help="print a Markdown table and exit")
    args = ap.parse_args(argv)
    if args.table:
        print(table(args.table))
        return 0
    if args.out is None:
        ap.error("--out is required")
    print(f"# {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, load "
          f"{open('/proc/loadavg').read().split()[0]}, {args.layers} layers × {args.particles} "
          f"particles, seed {args.seed}", flush=True)
    replay: dict = {}
    hier = {}
    for item in args.hier:
        key, _, value = item.partition("=")
        hier[key] = json.loads(value)
    for name in filter(None, args.settings.split(",")):
        started = time.strftime('%H:%M', time.gmtime())
        us, per_frame, wall = run(args.demo, args.out / name, name, layers=args.layers,
                                  particles=args.particles, seed=args.seed, frames=args.frames,
                                  replay=replay, hier=hier)
        got = score(args.out / name, args.ref)
        print(f"{name:10s} mean {got['mean_mm']:5.0f} median {got['median_mm']:5.0f} "
              f"within100 {got['within_100_pct']:3.0f} %  {us:7.0f} us/particle "
              f"{per_frame:5.0f} evals/frame  {wall:5.0f} s (from {started} UTC, load "
              f"{open('/proc/loadavg').read().split()[0]})", flush=True)
        print(got["landmarks"], flush=True)
        if args.json:
            with args.json.open("a") as f:
                f.write(json.dumps({
                    "setting": name, "weights": SETTINGS[name],
                    "search": "hierarchical" if name in HIERARCHICAL else "joint",
                    "layers": args.layers, "particles": args.particles, "seed": args.seed,
                    "us_per_particle": us, "evaluations_per_frame": per_frame,
                    "wall_s": wall, **{k: v for k, v in got.items() if k != "landmarks"}})
                    + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
