"""Recovery benchmark: a person who leaves the view and comes back, and ``--strategy iapf`` vs apf.

Part 1 (``--absence``): the clip of ``make_absence_clip.py`` (rendered into ``--absence-data`` when
missing) is tracked *without the answer* (its ``Mocap_Data`` left out of a linked copy, as in
``bench_no_answer.py``: no ground truth start, no body file) and scored against its ground truth:

* frames flagged without a person, against the truly absent ones (should be the same ± 1);
* frames from the reappearance until the mean landmark error is back under 100 mm (target ≤ 5);
* μ and MMTA over the frames outside the absence;
* re-initialisations (frame and why).

Part 2 (``--compare``): clips of the rendered benchmark set (``--bench-data``, 7 cameras, 100
frames) tracked without the answer with ``apf`` and ``iapf`` (the detector proposal, 20 % of
layer 1), one seed each, with μ, MMTA and frames per second; plus the detector proposal's cost
per frame (:func:`voxelmocap.pose.proposal.detector_proposal` timed on every frame of the first clip,
warm-started from the tracked estimate of the frame before).

Usage::

    python scripts/bench_recovery.py [--absence] [--compare Walking,Jog] [--out /tmp/bench_recovery]

Feeds docs/benchmarks.md, "Recovery".
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from voxelmocap import cpu_paths

# Before NumPy loads: the NumPy loops and OpenBLAS kernels `voxelmocap track` runs with, so that
# these runs are the command's on any CPU (voxelmocap.cpu_paths).
cpu_paths.pin()

import numpy as np  # noqa: E402
from bench_accuracy import CLIPS  # noqa: E402
from bench_no_answer import stripped_copy  # noqa: E402
from make_absence_clip import MOCAP, make_absence_clip  # noqa: E402

from voxelmocap.config import TrackConfig, with_overrides  # noqa: E402
from voxelmocap.io.humaneva import Dataset  # noqa: E402
from voxelmocap.io.reports import score_against  # noqa: E402
from voxelmocap.io.results import read_result  # noqa: E402
from voxelmocap.run.pipeline import track_sequence  # noqa: E402


def absence_run(data: Path, out: Path, config, seed: int, tag: str) -> dict:
    info = json.loads((data / "absence.json").read_text())
    subject, seq_name = info["subject"], info["sequence"]
    first, last = info["absent"]
    source = stripped_copy(data, subject, out / "stripped_absence" / subject)
    notes = []
    t0 = time.perf_counter()
    outcome = track_sequence(source, subject, seq_name, out / tag / f"seed{seed}", config=config,
                             seed=seed, overwrite=True, progress=False, log=notes.append)
    wall = time.perf_counter() - t0
    gt = Dataset(data).sequence(subject, seq_name).ground_truth_path
    res = read_result(outcome.result_path)
    observed = np.ones(len(res), bool) if res.observed is None else res.observed
    frames = res.frames
    truly_absent = (frames >= first) & (frames <= last)
    flagged = ~observed
    # Errors of every frame, flagged or not, against the true poses.
    ev = score_against(outcome.result_path, gt, delta=100.0)
    from voxelmocap.evaluation import evaluate_sequence

    _, per = evaluate_sequence(ev.est, ev.gt, ev.gt_enabled)
    err = per["mean_error"]
    after = np.flatnonzero(frames > last)
    back = next((int(frames[i] - (last + 1)) for i in after if err[i] < 100.0), None)
    outside = ~truly_absent
    mmta = float(np.mean(per["mmta"][outside]))
    return {
        "absent": [first, last], "flagged": [int(f) for f in frames[flagged]],
        "flagged_correct": int((flagged & truly_absent).sum()),
        "flagged_wrong": int((flagged & ~truly_absent).sum()),
        "missed": int((~flagged & truly_absent).sum()),
        "frames_to_recover": back, "mu_outside_mm": float(np.nanmean(err[outside])),
        "mmta_outside_pct": mmta, "error_after": [round(float(e)) for e in err[after[:8]]],
        "reinitialisations": [list(r) for r in outcome.reinitialisations],
        "init": outcome.init_method, "seconds": wall,
    }


def compare_run(bench: Path, out: Path, action: str, strategy: str, seed: int,
                overrides: dict | None = None) -> dict:
    index = [a for _, a, _ in CLIPS].index(action)
    subject, seq_name = f"S{index + 1}", f"{action}_1"
    source = stripped_copy(bench, subject, out / "stripped" / subject)
    config = with_overrides(TrackConfig(), **{"filter.strategy": strategy, **(overrides or {})})
    tag = strategy + "".join(f"_{k.split('.')[-1]}={v}" for k, v in (overrides or {}).items())
    t0 = time.perf_counter()
    outcome = track_sequence(source, subject, seq_name, out / f"compare_{tag}" / f"seed{seed}",
                             config=config, seed=seed, overwrite=True, progress=False,
                             log=lambda _m: None)
    wall = time.perf_counter() - t0
    gt = Dataset(bench).sequence(subject, seq_name).ground_truth_path
    sc = score_against(outcome.result_path, gt, delta=100.0).scores
    seconds = read_result(outcome.result_path).seconds[1:]
    return {"mu_mm": sc.mu_mm, "mmta_pct": sc.mmta_pct, "fps": 1.0 / float(np.median(seconds)),
            "wall_s": wall, "flagged": sc.unobserved,
            "reinitialisations": len(outcome.reinitialisations)}


def proposal_cost(bench: Path, out: Path, action: str, seed: int) -> dict:
    """Median ms of one detector proposal per frame (warm start: the apf run's estimates)."""
    from voxelmocap.body import BodyModel
    from voxelmocap.pose.filter_setup import noise_profile
    from voxelmocap.pose.proposal import detector_proposal
    from voxelmocap.run.measurement import MeasurementRunner

    index = [a for _, a, _ in CLIPS].index(action)
    subject, seq_name = f"S{index + 1}", f"{action}_1"
    result = read_result(out / "compare_apf" / f"seed{seed}" / subject / f"{seq_name}.h5")
    seq = Dataset(bench).sequence(subject, seq_name)
    config = TrackConfig()
    runner = MeasurementRunner(seq, config, log=None)
    model = BodyModel.scaled(float(result.attrs.get("body_height_mm", 1780.0)))
    std = noise_profile(model, config)
    ms = []
    for k, (_, obs) in enumerate(runner.observations(result.frames[1:])):
        mix = detector_proposal(obs, model, std=std, previous=result.state[k])
        ms.append(1e3 * mix.seconds)
    return {"median_ms": float(np.median(ms)), "p90_ms": float(np.percentile(ms, 90)),
            "frames": len(ms)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default="/tmp/bench_recovery")
    parser.add_argument("--absence", action="store_true", help="run part 1")
    parser.add_argument("--absence-data", default=None,
                        help="the absence clip's data set (default OUT/absence_data)")
    parser.add_argument("--strategy", default="apf", choices=["apf", "iapf"],
                        help="filter strategy of part 1")
    parser.add_argument("--compare", default="", help="part 2: comma-separated actions")
    parser.add_argument("--bench-data", default="/work/bench/data")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--strategies", default="apf,iapf", help="part 2: strategies to run")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="part 2: config override of the iapf runs, e.g. "
                             "recovery.proposal_mirror=false (TOML value)")
    parser.add_argument("--cost", default="",
                        help="only time the detector proposal on this clip (needs its apf run "
                             "from an earlier --compare in OUT)")
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    report = {}
    if args.cost:
        cost = proposal_cost(Path(args.bench_data), out, args.cost, args.seed)
        print(f"detector proposal: median {cost['median_ms']:.1f} ms per frame (p90 "
              f"{cost['p90_ms']:.1f} ms, {cost['frames']} frames of {args.cost})")
        return
    if args.absence:
        data = Path(args.absence_data) if args.absence_data else out / "absence_data"
        if not (data / "absence.json").exists():
            if not MOCAP.is_dir():
                raise SystemExit(f"{MOCAP} is not available")
            make_absence_clip(data)
        config = with_overrides(TrackConfig(), **{"filter.strategy": args.strategy})
        r = absence_run(data, out, config, args.seed, f"absence_{args.strategy}")
        report["absence"] = r
        print(f"absence clip ({args.strategy}): absent {r['absent'][0]}–{r['absent'][1]}; "
              f"flagged {len(r['flagged'])} ({r['flagged_correct']} right, "
              f"{r['flagged_wrong']} wrong, {r['missed']} missed); back under 100 mm after "
              f"{r['frames_to_recover']} frames (errors {r['error_after']}); outside the "
              f"absence μ {r['mu_outside_mm']:.1f} mm, MMTA {r['mmta_outside_pct']:.1f} %; "
              f"{r['seconds']:.0f} s", flush=True)
        for frame, note in r["reinitialisations"]:
            print(f"  frame {frame}: {note}")
    actions = [a for a in args.compare.split(",") if a]
    from voxelmocap.io.toml import parse_toml

    overrides = {k: parse_toml(f"v = {v}", "--set")["v"]
                 for k, v in (item.split("=", 1) for item in args.set)}
    for action in actions:
        for strategy in args.strategies.split(","):
            r = compare_run(Path(args.bench_data), out, action, strategy, args.seed,
                            overrides if strategy == "iapf" else None)
            report.setdefault("compare", {}).setdefault(action, {})[strategy] = r
            print(f"{action:<9s} {strategy:<5s} μ {r['mu_mm']:6.1f} mm  MMTA {r['mmta_pct']:5.1f} %"
                  f"  {r['fps']:.2f} frames/s  flagged {r['flagged']}  re-initialised "
                  f"{r['reinitialisations']}×", flush=True)
    if actions and "apf" in args.strategies.split(","):
        cost = proposal_cost(Path(args.bench_data), out, actions[0], args.seed)
        report["proposal_cost"] = cost
        print(f"detector proposal: median {cost['median_ms']:.1f} ms per frame (p90 "
              f"{cost['p90_ms']:.1f} ms, {cost['frames']} frames of {actions[0]})")
    (out / "recovery.json").write_text(json.dumps(report, indent=1))


if __name__ == "__main__":
    main()
