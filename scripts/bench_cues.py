"""Cue comparison: voxel-only, each image cue alone and fused, on the rendered benchmark clips.

For every clip and camera set (7 cameras, a 2-camera and a 1-camera subset) the frames are
measured once (:class:`voxelmocap.run.measurement.MeasurementRunner`: silhouettes, voxels, and
the camera images the image cues read), then the product's tracker
(:class:`voxelmocap.pose.tracker.BodyTracker`) runs once per cue setting on the same observations,
started from frame 1's ground truth, with the same filter (layers × particles, so the same number
of likelihood evaluations) and seed. Every setting searches all dimensions at once
(``filter.search = "joint"``, which image cues force in the product) except ``voxel_hier``, the
voxel likelihood with the default hierarchical search (``--hier KEY=VALUE`` sizes its partitions,
e.g. ``filter.trunk_particles=125`` for 600 evaluations per frame at 4 × 150). Printed per run:
μ (mm), MMTA (%, δ = 100 mm), MMTP (mm), µs per particle of the likelihood (the filter's
likelihood seconds / evaluations) and evaluations per frame. ``--costs`` also times each cue
alone on the same 300 particles of frame 1 (best of 7 interleaved repeats), side by side in one
process.

Examples::

    python scripts/bench_cues.py --clips S3/Box_1 --cameras 7 --frames 20
    python scripts/bench_cues.py --frames 30 --layers 4 --particles 150 --json out.json
    python scripts/bench_cues.py --costs --clips S1/Walking_1
    python scripts/bench_cues.py --frames 30 --seeds 0,1,2 --settings voxel,fused4,voxel_hier,roi \
        --first-seed-only voxel_hier,roi --hier filter.trunk_particles=125 --json out.json

Settings are named cue selections (``SETTINGS``); a setting needing voxels is skipped below two
cameras (the product refuses it), and ``fused`` then means the image cues' fusion (``image``).

Feeds docs/benchmarks.md, "Image cues" (the rendered clips' tables and the cost per particle).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from pathlib import Path

from voxelmocap import cpu_paths

# Before NumPy loads: the NumPy loops and OpenBLAS kernels `voxelmocap track` runs with, so that
# these runs are the command's on any CPU (voxelmocap.cpu_paths).
cpu_paths.pin()

import numpy as np  # noqa: E402

from voxelmocap.config import CuesConfig, TrackConfig, with_overrides  # noqa: E402

CLIPS = ["S1/Walking_1", "S2/Jog_1", "S3/Box_1", "S4/Gestures_1", "S5/Combo_1"]
CAMERA_SETS = {"7": None, "2": ["C1", "C2"], "1": ["C1"]}

#: name → cue weights
SETTINGS: dict[str, dict[str, float]] = {
    "voxel": {"voxel": 1.0},
    "edges": {"edges": 1.0},
    "dt": {"dt": 1.0},
    "roi": {"roi": 1.0},
    "blob3d": {"blob3d": 1.0},
    "skin": {"skin": 1.0},
    "uniform": {"uniform": 1.0},
    "fused": {"voxel": 1.0, "roi": 1.0, "edges": 0.1},
    "voxel_roi": {"voxel": 1.0, "roi": 1.0},
    "voxel_roi4": {"voxel": 1.0, "roi": 4.0},
    "fused4": {"voxel": 1.0, "roi": 4.0, "edges": 0.1},   # = voxelmocap.score.cues.FUSED
    "fused_all": {"voxel": 1.0, "edges": 0.1, "dt": 1.0, "roi": 1.0, "blob3d": 1.0,
                  "uniform": 0.2},
    "image": {"edges": 0.1, "roi": 1.0, "dt": 1.0},
    # the voxel likelihood with the product's partitioned search (``filter.search =
    # "hierarchical"``); every other setting searches all 27 dimensions at once (image cues
    # force that in the product: ``tracker.searches_hierarchically``)
    "voxel_hier": {"voxel": 1.0},
}

#: settings searched partition by partition (the rest: ``filter.search = "joint"``)
HIERARCHICAL = {"voxel_hier"}


def observations(root: Path, clip: str, cameras, frames: int):
    """(frame numbers, observations, ground truth, body model) of the first ``frames`` frames."""
    from voxelmocap.grid import VoxelGrid
    from voxelmocap.io.humaneva import Dataset
    from voxelmocap.run.bodies import body_model_for
    from voxelmocap.run.measurement import MeasurementRunner

    subject, sequence = clip.split("/")
    # every camera set is carved on the grid of the full rig (one camera alone sees no
    # floor-to-2.2 m box, and the same grid keeps the voxel cue comparable across sets)
    full = VoxelGrid.from_rig(Dataset(root).sequence(subject, sequence).rig, 20.0)
    config = with_overrides(TrackConfig(), **{"measurement.grid_origin": list(full.origin),
                                              "measurement.grid_shape": list(full.shape)})
    seq = Dataset(root).sequence(subject, sequence, cameras=cameras)
    gt = seq.ground_truth()
    model, _ = body_model_for(seq, gt)
    runner = MeasurementRunner(seq, config, log=None)
    wanted = np.intersect1d(seq.frame_numbers, gt.frames)[:frames]
    numbers, obs = [], []
    for number, images in seq.frames(wanted):
        numbers.append(int(number))
        obs.append(runner.measure(images, frame=number))
    return numbers, obs, gt, model


def track(numbers, obs, gt, model, weights, *, layers, particles, seed, init="ground_truth",
          search="joint", overrides=None):
    """Track the observations with one cue selection.

    Returns (μ mm, MMTA %, MMTP mm, µs per particle, likelihood evaluations). ``search`` is the
    filter's search (``joint`` or ``hierarchical``); ``overrides`` more ``with_overrides`` keys.
    """
    from voxelmocap.evaluation import evaluate_sequence
    from voxelmocap.pose.starts import ground_truth_landmarks
    from voxelmocap.pose.tracker import BodyTracker

    config = with_overrides(TrackConfig(), **{"filter.layers": layers,
                                              "filter.particles": particles,
                                              "filter.search": search,
                                              "init.method": init, **(overrides or {})})
    config = dataclasses.replace(config, cues=CuesConfig(weights=dict(weights)))
    tracker = BodyTracker(model, config, seed=seed)
    endpoints, spent, evals = [], 0.0, 0
    for number, o in zip(numbers, obs, strict=True):
        if not tracker.initialised:
            tracker.initialise(o, ground_truth_landmarks(gt, number), frame=number)
        record = tracker.step(o, frame=number)
        endpoints.append(record.endpoints)
        spent += record.likelihood_seconds
        evals += tracker.filter.step_evaluations
    rows = gt.index_of(numbers)
    scores, _ = evaluate_sequence(np.array(endpoints), gt.endpoints[rows], gt.enabled[rows])
    return scores.mu_mm, scores.mmta_pct, scores.mmtp_mm, 1e6 * spent / max(evals, 1), evals


def costs(obs, gt, model, numbers, n_particles=300, repeats=7):
    """µs per particle of each cue alone on the same particles of the first frame."""
    from voxelmocap.body import fit_to_landmarks
    from voxelmocap.pose.starts import ground_truth_landmarks
    from voxelmocap.score.cues import CUES, CueSet
    from voxelmocap.score.cues.terms import Views

    x0 = fit_to_landmarks(model, ground_truth_landmarks(gt, numbers[0]))
    rng = np.random.default_rng(0)
    noise = np.r_[np.full(3, 30.0), np.full(24, 0.1)]
    states = model.clip(x0 + rng.normal(size=(n_particles, 27)) * noise)
    n_cam = len(obs[0].cameras)
    names = [n for n in CUES if n_cam >= 2 or not CUES[n].needs_voxels]
    cues = CueSet(model, CuesConfig(weights={n: 1.0 for n in names}))
    cues.learn(obs[0], x0)
    frame = cues.prepare(obs[0])
    out = {}
    t_views = []
    timings = {n: [] for n in names}
    for _ in range(repeats):      # interleaved, so that load changes hit every cue alike
        t0 = time.perf_counter()
        views = Views(model, frame, states)
        t_views.append(time.perf_counter() - t0)
        for n in names:
            t0 = time.perf_counter()
            cues.cues[n](frame, views)
            timings[n].append(time.perf_counter() - t0)
    out["(contours)"] = 1e6 * min(t_views) / n_particles
    for n in names:
        out[n] = 1e6 * min(timings[n]) / n_particles
    return out


def table(paths) -> str:
    """Markdown tables (one per camera count) of JSON-lines results: μ / MMTA / MMTP per clip
    (mean over the seeds present; MMTP only in rows that have it), µs per particle (median over
    the row's runs: a clip's first run also pays the observation's one-off preparation)."""
    rows = [json.loads(line) for p in paths for line in Path(p).read_text().splitlines() if line]
    # a (clip, cameras, setting, seed) run measured twice is the same run (deterministic): once
    rows = list({(r["clip"], r["cameras"], r["setting"], r["seed"]): r for r in rows}.values())
    out = []
    clips = [c for c in CLIPS if any(r["clip"] == c for r in rows)]
    for n_cam in sorted({r["cameras"] for r in rows}, reverse=True):
        sub = [r for r in rows if r["cameras"] == n_cam]
        with_mmtp = all("mmtp_mm" in r for r in sub)
        what = "μ (mm) / MMTA (%) / MMTP (mm)" if with_mmtp else "μ (mm) / MMTA (%)"
        out.append(f"\n{n_cam} camera{'s' if n_cam > 1 else ''}: {what}\n")
        out.append("| cues | " + " | ".join(c.split("/")[1] for c in clips)
                   + " | mean μ | mean MMTA | µs/particle |")
        out.append("|---" * (len(clips) + 4) + "|")
        for name in [s for s in SETTINGS if any(r["setting"] == s for r in sub)]:
            cells, mus, mmtas, costs = [], [], [], []
            for clip in clips:
                got = [r for r in sub if r["setting"] == name and r["clip"] == clip]
                if not got:
                    cells.append("")
                    continue
                mu = float(np.mean([r["mu_mm"] for r in got]))
                mmta = float(np.mean([r["mmta_pct"] for r in got]))
                mus.append(mu)
                mmtas.append(mmta)
                costs += [r["us_per_particle"] for r in got]
                seeds = f" ({len(got)} seeds)" if len(got) > 1 else ""
                mmtp = (f" / {np.mean([r['mmtp_mm'] for r in got]):.0f}" if with_mmtp else "")
                cells.append(f"{mu:.1f} / {mmta:.0f}{mmtp}{seeds}")
            weights = next(r["weights"] for r in sub if r["setting"] == name)
            label = ", ".join(f"{k}" if v == 1 else f"{k}={v:g}" for k, v in weights.items())
            label = name if label == name else f"{name}: {label}"
            if any(r.get("search") == "hierarchical" for r in sub if r["setting"] == name):
                label += " (hierarchical search)"
            out.append(f"| {label} | " + " | ".join(cells)
                       + f" | {np.mean(mus):.1f} | {np.mean(mmtas):.0f} "
                         f"| {np.median(costs):.0f} |")
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", type=Path, default=Path("/work/bench/data"))
    ap.add_argument("--clips", default=",".join(CLIPS))
    ap.add_argument("--cameras", default="7,2,1", help="camera sets: 7, 2 (C1,C2), 1 (C1)")
    ap.add_argument("--settings", default=",".join(SETTINGS))
    ap.add_argument("--frames", type=int, default=20)
    ap.add_argument("--layers", type=int, default=4)
    ap.add_argument("--particles", type=int, default=150)
    ap.add_argument("--seeds", default="0", help="comma-separated filter seeds (default 0)")
    ap.add_argument("--init", default="ground_truth", choices=("ground_truth", "extremities"),
                    help="start: frame 1's ground truth (default), or the voxels' extremities "
                         "(a mixture of the likeliest starts; the ROI/skin/uniform references "
                         "are then learnt from that start)")
    ap.add_argument("--first-seed-only", default="",
                    help="comma-separated settings run with the first seed only")
    ap.add_argument("--hier", action="append", default=[], metavar="KEY=VALUE",
                    help="config override for the hierarchical settings only (repeatable), "
                         "e.g. filter.trunk_particles=120 to match the joint search's budget")
    ap.add_argument("--costs", action="store_true", help="time each cue alone on frame 1")
    ap.add_argument("--json", type=Path, help="append the rows (JSON lines) to this file")
    ap.add_argument("--table", nargs="+", type=Path, help="print Markdown tables of JSON-lines "
                                                          "results and exit")
    args = ap.parse_args(argv)
    if args.table:
        print(table(args.table))
        return 0
    from voxelmocap.score.cues import CUES

    hier_overrides = {}
    for item in args.hier:
        key, _, value = item.partition("=")
        hier_overrides[key] = json.loads(value)
    print(f"# {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, load "
          f"{open('/proc/loadavg').read().split()[0]}, {args.frames} frames, {args.layers} layers "
          f"× {args.particles} particles, seeds {args.seeds}, start: {args.init}")
    print(f"{'clip':16s} {'cams':>4s} {'setting':10s} {'mu_mm':>7s} {'mmta%':>6s} "
          f"{'mmtp':>6s} {'us/part':>8s} {'evals/f':>7s}")
    warm = False
    for clip in args.clips.split(","):
        for cam_key in args.cameras.split(","):
            cams = CAMERA_SETS[cam_key]
            numbers, obs, gt, model = observations(args.data, clip, cams, args.frames)
            n_cam = len(obs[0].cameras)
            if args.costs:
                for name, us in costs(obs, gt, model, numbers).items():
                    print(f"{clip:16s} {n_cam:4d} cost {name:10s} {us:8.1f} us/particle")
                    sys.stdout.flush()
            seeds = [int(v) for v in args.seeds.split(",")]
            if not warm:   # compile the kernels before anything is timed (once per process)
                for name in SETTINGS:
                    if n_cam >= 2 or not any(CUES[c].needs_voxels for c in SETTINGS[name]):
                        track(numbers[:2], obs[:2], gt, model, SETTINGS[name], layers=2,
                              particles=20, seed=0, init=args.init,
                              search="hierarchical" if name in HIERARCHICAL else "joint")
                warm = True
            once = set(filter(None, args.first_seed_only.split(",")))
            for seed in seeds:
                for name in [n for n in args.settings.split(",") if n]:
                    if name in once and seed != seeds[0]:
                        continue
                    weights = SETTINGS[name]
                    if n_cam < 2 and name == "fused":   # monocular: the image cues' fusion
                        weights = SETTINGS["image"]
                    if n_cam < 2 and any(CUES[c].needs_voxels for c in weights):
                        continue
                    hier = name in HIERARCHICAL
                    mu, mmta, mmtp, us, evals = track(
                        numbers, obs, gt, model, weights, layers=args.layers,
                        particles=args.particles, seed=seed, init=args.init,
                        search="hierarchical" if hier else "joint",
                        overrides=hier_overrides if hier else None)
                    print(f"{clip:16s} {n_cam:4d} {name:10s} {mu:7.1f} {mmta:6.1f} {mmtp:6.1f} "
                          f"{us:8.1f} {evals / len(numbers):7.0f} seed {seed}")
                    sys.stdout.flush()
                    if args.json:
                        with args.json.open("a") as f:
                            f.write(json.dumps({
                                "clip": clip, "cameras": n_cam, "setting": name,
                                "weights": weights, "mu_mm": mu, "mmta_pct": mmta,
                                "mmtp_mm": mmtp, "us_per_particle": us, "evaluations": evals,
                                "search": "hierarchical" if hier else "joint",
                                "frames": args.frames, "layers": args.layers,
                                "particles": args.particles, "seed": seed,
                                "init": args.init}) + "\n")
            del obs
    return 0


if __name__ == "__main__":
    sys.exit(main())
