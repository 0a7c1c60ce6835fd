"""Facing benchmark (issue 33): does the start face the right way, are left and right right?

The five ``../shared/mocap`` clips of ``bench_accuracy.py`` (never ``holdout/``) are rendered with
the person's starting heading turned (``voxelmocap.synth.generate(heading_deg=...)``: the motion
turned about the vertical through frame 1's pelvis, the ground truth turned with it) and tracked
*without the answer*: a copy of each render without ``Mocap_Data`` (no ground truth, no body file;
``bench_no_answer.stripped_copy``), scored against the render's ground truth afterwards.

Protocols (``--protocol``):

* ``facing`` (default): headings 0°, 45°, …, 315°; headings 0, 90, 180, 270 rendered with the
  first noise seed of ``--noise-seeds``, 45, 135, 225, 315 with the second; the first 40 frames;
  tracking seeds 0 and 1: 5 × 8 × 2 = 80 runs. Acceptance (issue 33): facing right in ≥ 79,
  left/right right in ≥ 78.
* ``accuracy``: heading 0, 100 frames, both noise seeds (or the one ``--noise-seeds`` names),
  tracking seeds 0, 1, 2 (30 runs). Acceptance: no run's μ above 60 mm, mean μ ≤ 40 mm.

Per run:

* **heading error**: ``|evaluation.hip_axis_angle|`` at frame 10, the angle in the floor plane
  between the tracked left-hip→right-hip vector and the true one; *facing right* = within 45°.
  (A run shorter than 10 frames is judged at its last frame.)
* **left/right right**: ``evaluation.left_right_correct`` over frames 10 to the last: for each
  limb pair (elbows, wrists, knees, ankles) the tracked left joint is on average nearer the true
  left one than the true right one, *and* the tracked right joint nearer the true right one than
  the true left one; right on every limb = all four pairs right.
* **turned round at**: the first frame from which the heading error stays within 45° to the end
  (``evaluation.first_lasting_frame``; "never" when the last frame is off).
* μ (mean landmark error, mm) and MMTA (δ = 100 mm), wall time and seconds per frame; the
  frames the tracker flagged without a person (not scored: every one flagged makes μ NaN).

``--start-turned`` starts every run from the render's ground truth turned 180° on purpose (the
config keys ``init.method = "ground_truth"`` and ``init.start_turned = true``, the tracker's test
hook) and reports at which frame each run turned round (issue 33: within 30 frames, counted here
as "turned round at" frame 30 or earlier).

``--no-plate`` (issue 34) tracks a copy stripped of the ``Background/`` videos too
(``renders/<render>/stripped_noplate/``): the tracker learns its plate from the sequence itself
(``measurement.silhouette.plate_passes`` passes, ``voxelmocap.run.plan``); its runs go to their
own folder (default tag ``<commit>_default_noplate``, marked by a ``no_plate`` file; a
``--tag`` holding runs of the other kind is refused, not resumed), each record says
``"no_plate": true``. Compare with the
with-plate runs of the same renders and seeds (``--protocol accuracy``: issue 34 asks every
clip's no-plate mean μ within 10 % of its with-plate one).

A render whose ground truth leaves the cameras' common view (some endpoint unseen by some camera,
``voxelmocap.synth.heading.frames_out_of_view``) is reported, and its runs are marked ``!``.

Everything is cached under ``--out``: renders by (clip, heading, noise seed, frames) in
``renders/``, runs in ``<protocol>/<tag>/<render>/seed<k>/`` (a run whose result and
``score.json`` exist is not run again; an interrupted one resumes). ``<tag>`` names the code and
settings: ``--tag``, by default ``<commit>_default`` or ``<commit>_cfg-<hash of the config>``
when ``--config`` / ``--set`` / ``--start-turned`` change it, ``_noplate`` appended with
``--no-plate`` (``<commit>`` the checkout's short
hash, ``-dirty`` with uncommitted changes under ``voxelmocap/``), so a new commit never reuses
an older one's results; pass ``--tag`` to resume across commits. The records go to
``<protocol>/<tag>/results.json`` and ``results.csv``, the printed summary to ``summary.txt``.

Usage::

    python scripts/bench_facing.py [--protocol facing|accuracy] [--out /tmp/voxelmocap_facing]
        [--clips Walking,Jog] [--headings 0,180] [--seeds 0,1] [--noise-seeds 1,2]
        [--frames N] [--jobs 2] [--config F.toml] [--set filter.particles=300 ...]
        [--tag NAME] [--start-turned | --no-plate] [--mocap DIR] [--dry-run]
"""

from __future__ import annotations

import argparse
import csv
import hashlib
import io
import json
import multiprocessing
import os
import resource
import subprocess
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

from voxelmocap import cpu_paths

# Before NumPy loads, here and in the spawned workers (they inherit the environment): the NumPy
# loops and OpenBLAS kernels `voxelmocap track` runs with, so that these runs are the command's on
# any CPU (unpinned, an Intel and an AMD AVX-512 server track the same renders apart).
cpu_paths.pin()

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_accuracy import CLIPS, MOCAP  # noqa: E402
from bench_no_answer import parse_sets, stripped_copy  # noqa: E402

#: Starting headings of the facing protocol (degrees, counter-clockwise seen from above).
HEADINGS = tuple(range(0, 360, 45))
#: Protocol → (headings, frames, tracking seeds).
PROTOCOLS = {"facing": (HEADINGS, 40, (0, 1)), "accuracy": ((0,), 100, (0, 1, 2))}
#: Frame at which the heading is judged, first frame of the left/right test.
JUDGE_FRAME = 10
#: Facing right / turned round: hip axis within this many degrees of the truth.
FACING_TOLERANCE = 45.0
DELTA = 100.0


def mocap_folder(path) -> Path | None:
    """The clips' folder: ``path``, else ``bench_accuracy.MOCAP``; None when it is missing."""
    folder = Path(path) if path else MOCAP
    return folder if folder.is_dir() else None


def plan(protocol: str, *, clips=None, headings=None, seeds=None, noise_seeds=(1, 2),
         frames=None) -> list[dict]:
    """Every run of a protocol (filtered), as dicts naming its render and tracking seed.

    The noise seed of heading ``h`` is ``noise_seeds[0]`` for even multiples of 45° and
    ``noise_seeds[1]`` for odd ones (facing); the accuracy protocol renders every clip with each
    (both by default, one when one is given).
    """
    p_headings, p_frames, p_seeds = PROTOCOLS[protocol]
    headings = p_headings if headings is None else headings
    seeds = p_seeds if seeds is None else seeds
    frames = p_frames if frames is None else frames
    runs = []
    for index, (clip, action, start) in enumerate(CLIPS):
        if clips and action not in clips:
            continue
        for heading in headings:
            if protocol == "accuracy":
                noises = tuple(dict.fromkeys(noise_seeds))
            else:
                odd = round(heading / 45.0) % 2 == 1
                noises = (noise_seeds[1 if odd else 0],)
            for noise in noises:
                render = {"clip": clip, "action": action, "start": start,
                          "subject": f"S{index + 1}", "heading": float(heading),
                          "noise_seed": int(noise), "frames": int(frames)}
                render["key"] = render_key(render)
                runs.extend({**render, "seed": int(seed)} for seed in seeds)
    return runs


def render_key(render: dict) -> str:
    """Cache folder name of a render: ``<action>_h<deg>_n<noise>_f<frames>``."""
    return (f"{render['action']}_h{render['heading'] % 360:g}_n{render['noise_seed']}"
            f"_f{render['frames']}")


def _write_json(path: Path, data) -> None:
    from voxelmocap.io._atomic import atomic_write_text

    atomic_write_text(path, json.dumps(data, indent=1) + "\n")


#: Stripped copy of a render tracked without (``True``) and with (``False``) its background
#: videos, in ``renders/<render>/``.
STRIPPED = {False: "stripped", True: "stripped_noplate"}


def make_render(render: dict, renders: str, mocap: str, no_plate: bool = False) -> dict:
    """Render (or reuse) one clip at one heading; its stripped copy (and with ``no_plate`` the
    copy without the background videos too, made here once per render, not by its runs, which
    may run side by side); the common-view check."""
    from voxelmocap.io.humaneva import Dataset
    from voxelmocap.synth import generate
    from voxelmocap.synth.heading import frames_out_of_view

    folder = Path(renders) / render["key"]
    data, done = folder / "data", folder / "render.json"
    if done.exists():
        info = {**json.loads(done.read_text()), "cached": True}
    else:
        t0 = time.perf_counter()
        generate(data, motion=str(Path(mocap) / render["clip"]), frames=render["frames"],
                 subject=render["subject"], action=render["action"], start=render["start"],
                 seed=render["noise_seed"], heading_deg=render["heading"], progress=False)
        seconds = time.perf_counter() - t0
        stripped_copy(data, render["subject"], folder / STRIPPED[False])
        seq = Dataset(data).sequence(render["subject"], f"{render['action']}_1")
        miss = frames_out_of_view(seq.rig, seq.ground_truth().endpoints)
        info = {**render, "render_seconds": round(seconds, 1),
                "out_of_view_frames": [int(f) + 1 for f in np.flatnonzero(miss.any(axis=1))],
                "out_of_view_cameras": sorted(c for c, m in zip(seq.rig.names, miss.any(axis=0),
                                                                 strict=True) if m)}
        _write_json(done, info)
    if no_plate:
        stripped_copy(data, render["subject"], folder / STRIPPED[True], keep_background=False)
    return info


def run_one(run: dict, renders: str, runs_dir: str, config_toml: str,
            no_plate: bool = False) -> dict:
    """Track one stripped render (resuming), score it, write ``score.json``; the record.

    ``no_plate``: track the copy without the background videos too (``stripped_noplate``)."""
    from voxelmocap.config import config_from_toml
    from voxelmocap.io.humaneva import Dataset
    from voxelmocap.io.reports import score_against
    from voxelmocap.run.pipeline import track_sequence

    run_dir = Path(runs_dir) / run["key"] / f"seed{run['seed']}"
    score = run_dir / "score.json"
    seq_name = f"{run['action']}_1"
    result = run_dir / run["subject"] / f"{seq_name}.h5"
    if score.exists() and result.exists():
        return json.loads(score.read_text())
    folder = Path(renders) / run["key"]
    render = json.loads((folder / "render.json").read_text())
    messages: list[str] = []
    t0, cpu0 = time.perf_counter(), _cpu_seconds()
    # --start-turned starts from the render's ground truth turned round (init.method =
    # ground_truth with init.start_turned): a start exactly 180° wrong, with left and right
    # exchanged; without it the copy stripped of the answer is tracked
    config = config_from_toml(config_toml, "bench config")
    source = folder / ("data" if config.init.start_turned else STRIPPED[no_plate])
    outcome = track_sequence(source, run["subject"], seq_name, run_dir,
                             config=config, seed=run["seed"], frames=f"1:{run['frames']}",
                             resume=True,
                             progress=False, log=messages.append)
    wall, cpu = time.perf_counter() - t0, _cpu_seconds() - cpu0
    gt_path = Dataset(folder / "data").sequence(run["subject"], seq_name).ground_truth_path
    ev = score_against(outcome.result_path, gt_path, delta=DELTA)
    record = {**run, **judge(ev), "mu_mm": ev.scores.mu_mm, "mmta_pct": ev.scores.mmta_pct,
              "wall_seconds": round(wall, 1), "cpu_seconds": round(cpu, 1),
              "seconds_per_frame": outcome.seconds_per_frame,
              "resumed_from": outcome.resumed_from, "init_method": outcome.init_method,
              "out_of_view_frames": len(render["out_of_view_frames"]), "no_plate": no_plate}
    (run_dir / "messages.txt").write_text("\n".join(messages) + "\n")
    _write_json(score, record)
    return record


def _cpu_seconds() -> float:
    """CPU time of this process, all its threads (user + system, s): a shared machine's wall
    time says little."""
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def judge(ev) -> dict:
    """Facing and left/right of one scored run (``io.reports.EvaluatedSequence``)."""
    from voxelmocap.evaluation import first_lasting_frame, hip_axis_angle, left_right_correct
    from voxelmocap.joints import endpoints_to_landmarks

    frames = np.asarray(ev.frames)
    est = endpoints_to_landmarks(ev.est, ev.est_enabled)  # NaN where the tracker saw nobody
    gt = endpoints_to_landmarks(ev.gt)
    angle = hip_axis_angle(est, gt)
    judge_frame = int(min(JUDGE_FRAME, frames.max()))
    at = int(np.flatnonzero(frames == judge_frame)[0]) if judge_frame in frames else -1
    error = float(abs(angle[at]))
    pairs = left_right_correct(est[frames >= judge_frame], gt[frames >= judge_frame])
    with np.errstate(invalid="ignore"):
        lasting = first_lasting_frame(np.abs(angle) <= FACING_TOLERANCE)
    return {"judge_frame": judge_frame, "heading_error_deg": error,
            "frames_without_person": int((~np.asarray(ev.est_enabled).any(axis=1)).sum()),
            "facing_right": bool(error <= FACING_TOLERANCE), "left_right": pairs,
            "left_right_right": bool(all(pairs.values())),
            "turned_round_at": None if lasting is None else int(frames[lasting]),
            "heading_error_per_frame": [None if np.isnan(a) else round(float(a), 1)
                                        for a in angle]}


# ---------------------------------------------------------------------- summaries
def _pct(n: int, d: int) -> str:
    return f"{n}/{d}"


def _group_table(records, field: str, label: str, fmt) -> list[str]:
    lines = [f"{label:<10s}{'runs':>5s}{'facing':>9s}{'L/R':>9s}{'worst err':>11s}"
             f"{'mean μ':>9s}{'max μ':>8s}{'MMTA':>7s}"]
    for value in sorted({r[field] for r in records}, key=lambda v: (str(type(v)), v)):
        rs = [r for r in records if r[field] == value]
        mu = np.array([r["mu_mm"] for r in rs])
        lines.append(f"{fmt(value):<10s}{len(rs):>5d}"
                     f"{_pct(sum(r['facing_right'] for r in rs), len(rs)):>9s}"
                     f"{_pct(sum(r['left_right_right'] for r in rs), len(rs)):>9s}"
                     f"{max(r['heading_error_deg'] for r in rs):>10.0f}°"
                     f"{mu.mean():>8.1f}{mu.max():>8.1f}"
                     f"{np.mean([r['mmta_pct'] for r in rs]):>6.1f}%")
    return lines


def run_line(r: dict) -> str:
    """One run, one line."""
    wrong = [k.split("/")[0][2:] for k, ok in r["left_right"].items() if not ok]
    turned = r["turned_round_at"] if r["turned_round_at"] is not None else "never"
    view = " !out of view" if r.get("out_of_view_frames") else ""
    nobody = r.get("frames_without_person")
    view += f" !{nobody} frames without a person" if nobody else ""
    return (f"{r['action']:<9s} h{r['heading']:>4.0f} n{r['noise_seed']} seed {r['seed']}: "
            f"heading err {r['heading_error_deg']:5.1f}° at frame {r['judge_frame']} "
            f"{'ok   ' if r['facing_right'] else 'WRONG'}  L/R "
            f"{'ok' if not wrong else 'swapped ' + ','.join(wrong)}  "
            f"μ {r['mu_mm']:6.1f} mm  MMTA {r['mmta_pct']:5.1f} %  turned round at {turned}  "
            f"[{r['wall_seconds']:.0f} s wall, {r.get('cpu_seconds', float('nan')):.0f} s CPU, "
            f"{r['seconds_per_frame']:.2f} s/frame]{view}")


def summary(records, protocol: str, start_turned: bool) -> str:
    """The report: the summary line(s), per-clip and per-heading tables, the failing runs."""
    n = len(records)
    out = []
    facing = sum(r["facing_right"] for r in records)
    lr = sum(r["left_right_right"] for r in records)
    out.append(f"facing right in {facing}/{n}, left/right right in {lr}/{n}")
    mu = np.array([r["mu_mm"] for r in records])
    worst = records[int(np.argmax(mu))]
    out.append(f"μ: mean {mu.mean():.1f} mm, max {mu.max():.1f} mm ({worst['action']} "
               f"h{worst['heading']:g} n{worst['noise_seed']} seed {worst['seed']}), "
               f"{int((mu > 60).sum())} run(s) above 60 mm; mean MMTA "
               f"{np.mean([r['mmta_pct'] for r in records]):.1f} %")
    if start_turned:
        at = [r["turned_round_at"] for r in records]
        within = sum(a is not None and a <= 30 for a in at)
        out.append(f"started turned 180°: turned round within 30 frames in {within}/{n} "
                   f"(frames: {', '.join('never' if a is None else str(a) for a in at)})")
    oov = [r for r in records if r.get("out_of_view_frames")]
    out.append("renders leaving the cameras' common view: "
               + (", ".join(sorted({f"{r['action']} h{r['heading']:g}" for r in oov}))
                  if oov else "none"))
    out.append("")
    out += _group_table(records, "action", "clip", str)
    if protocol == "facing":
        out.append("")
        out += _group_table(records, "heading", "heading", lambda v: f"{v:g}°")
    else:
        out.append("")
        out += _group_table(records, "noise_seed", "noise seed", str)
    bad = [r for r in records if not (r["facing_right"] and r["left_right_right"])]
    out.append("")
    out.append(f"runs facing wrong or with a limb swapped ({len(bad)}):" if bad else
               "no run facing wrong or with a limb swapped")
    out += [run_line(r) for r in bad]
    return "\n".join(out)


def write_tables(records, folder: Path, text: str) -> None:
    """``results.json``, ``results.csv`` and ``summary.txt`` of one protocol and tag."""
    from voxelmocap.io._atomic import atomic_write_text

    _write_json(folder / "results.json", records)
    cols = ["action", "heading", "noise_seed", "seed", "frames", "frames_without_person",
            "no_plate", "heading_error_deg",
            "facing_right", "left_right_right", "turned_round_at", "mu_mm", "mmta_pct",
            "wall_seconds", "cpu_seconds", "seconds_per_frame", "out_of_view_frames"]
    buf = io.StringIO()
    writer = csv.writer(buf)
    pairs = list(records[0]["left_right"]) if records else []
    writer.writerow(cols + pairs)
    for r in records:
        writer.writerow([r.get(c) for c in cols] + [r["left_right"][p] for p in pairs])
    atomic_write_text(folder / "results.csv", buf.getvalue())
    atomic_write_text(folder / "summary.txt", text + "\n")


# ---------------------------------------------------------------------- command line
def _numbers(text, kind=float):
    return None if text is None else tuple(kind(v) for v in text.split(",") if v.strip())


def build_config(args):
    """TrackConfig: defaults ← ``--config`` ← ``--set`` ← ``--start-turned``; and its tag."""
    from voxelmocap.config import TrackConfig, config_to_toml, load_config, with_overrides

    config = load_config(args.config) if args.config else TrackConfig()
    overrides = parse_sets(args.set)
    if args.start_turned:
        overrides["init.start_turned"] = True
        overrides["init.method"] = "ground_truth"
    config = with_overrides(config, **overrides)
    text = config_to_toml(config)
    if args.tag:
        return text, args.tag
    settings = ("default" if text == config_to_toml(TrackConfig())
                else "cfg-" + hashlib.sha1(text.encode()).hexdigest()[:8])
    return text, f"{code_version()}_{settings}" + ("_noplate" if args.no_plate else "")


def check_plate_kind(runs_dir: Path, no_plate: bool) -> None:
    """A run folder holds runs of one kind, with the background videos or (marked by its file
    ``no_plate``) without: SystemExit when it already holds runs of the other kind; else the
    mark made (``no_plate``)."""
    marked = (runs_dir / "no_plate").exists()
    if marked != no_plate and any(runs_dir.glob("*/seed*")):
        raise SystemExit(f"{runs_dir}: holds runs {'without' if marked else 'with'} the "
                         f"background videos; {'without' if no_plate else 'with'} them needs "
                         "another --tag")
    if no_plate:
        runs_dir.mkdir(parents=True, exist_ok=True)
        (runs_dir / "no_plate").touch()


def code_version() -> str:
    """Short commit of the checkout the package is imported from (``-dirty`` when its
    ``voxelmocap/`` has uncommitted changes), ``nogit`` outside git: results of one code
    version are never resumed by another."""
    import voxelmocap

    root = Path(voxelmocap.__file__).resolve().parents[1]
    try:
        head = subprocess.run(["git", "-C", str(root), "rev-parse", "--short", "HEAD"],
                              capture_output=True, text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(root), "status", "--porcelain", "voxelmocap"],
                               capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "nogit"
    return head + ("-dirty" if dirty else "")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--protocol", choices=sorted(PROTOCOLS), default="facing")
    parser.add_argument("--out", default="/tmp/voxelmocap_facing", help="renders and runs folder")
    parser.add_argument("--mocap", help=f"folder of the clips (default {MOCAP})")
    parser.add_argument("--clips", help="comma-separated subset of actions (Walking,Jog,...)")
    parser.add_argument("--headings", help="comma-separated headings, degrees (default: the "
                                           "protocol's)")
    parser.add_argument("--seeds", help="comma-separated tracking seeds (default: the protocol's)")
    parser.add_argument("--noise-seeds", default="1,2",
                        help="render noise seeds: even and odd multiples of 45° (facing), or "
                             "each (accuracy: one or more); default 1,2")
    parser.add_argument("--frames", type=int, help="frames per render (default: the protocol's)")
    parser.add_argument("--jobs", type=int, default=1, help="parallel processes (default 1)")
    parser.add_argument("--config", help="TOML config file passed to track")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="config override, e.g. filter.particles=300 (repeatable; VALUE "
                             "parsed as TOML)")
    parser.add_argument("--tag", help="name of these settings' run folder (default: "
                                      "<commit>_default or <commit>_cfg-<hash of the config>)")
    parser.add_argument("--start-turned", action="store_true",
                        help="start every run turned 180° (init.start_turned = true) and report "
                             "when it turned round")
    parser.add_argument("--no-plate", action="store_true",
                        help="track a copy without the background videos too: the plate learnt "
                             "from the sequence (issue 34)")
    parser.add_argument("--dry-run", action="store_true", help="list the runs and stop")
    args = parser.parse_args(argv)

    from voxelmocap.errors import InputError

    mocap = mocap_folder(args.mocap)
    if mocap is None:
        raise SystemExit(f"{args.mocap or MOCAP}: the mocap clips are not available (--mocap)")
    if "holdout" in mocap.resolve().parts:
        raise SystemExit(f"{mocap}: the holdout clips are not for benchmarks")
    noise_seeds = _numbers(args.noise_seeds, int)
    if len(noise_seeds) != 2 and not (args.protocol == "accuracy" and noise_seeds):
        raise SystemExit(f"--noise-seeds: two seeds needed, got {args.noise_seeds!r}")
    if args.no_plate and args.start_turned:
        raise SystemExit("--no-plate tracks the stripped copy; --start-turned the ground truth: "
                         "one or the other")
    if args.jobs < 1 or (args.frames is not None and args.frames < 1):
        raise SystemExit("--jobs and --frames must be positive")
    clips = set(args.clips.split(",")) if args.clips else None
    unknown = (clips or set()) - {a for _, a, _ in CLIPS}
    if unknown:
        raise SystemExit(f"--clips: unknown {sorted(unknown)} (choose "
                         f"{','.join(a for _, a, _ in CLIPS)})")
    try:
        config_toml, tag = build_config(args)
    except InputError as exc:
        hint = (" (the tracker has no init.start_turned yet: --start-turned cannot run)"
                if args.start_turned and "start_turned" in str(exc) else "")
        raise SystemExit(f"{exc}{hint}") from None
    runs = plan(args.protocol, clips=clips, headings=_numbers(args.headings),
                seeds=_numbers(args.seeds, int), noise_seeds=noise_seeds, frames=args.frames)
    out = Path(args.out)
    renders, runs_dir = out / "renders", out / args.protocol / tag
    print(f"{len(runs)} runs ({args.protocol}{', no plate' if args.no_plate else ''}, tag "
          f"{tag}) in {runs_dir}", flush=True)
    if args.dry_run:
        for r in runs:
            print(f"  {r['key']} seed {r['seed']}")
        return 0
    check_plate_kind(runs_dir, args.no_plate)
    runs_dir.mkdir(parents=True, exist_ok=True)
    (runs_dir / "config.toml").write_text(config_toml)
    if args.jobs > 1:
        # each process one numba thread: the jobs share the cores instead of fighting over them
        os.environ["NUMBA_NUM_THREADS"] = "1"
    records, failed = [], []
    unique = {r["key"]: r for r in runs}
    # spawn, not fork: the workers start clean (no numba or BLAS threads inherited)
    with ProcessPoolExecutor(args.jobs, mp_context=multiprocessing.get_context("spawn")) as pool:
        futures = {pool.submit(make_render, {k: v for k, v in r.items() if k != "seed"},
                               str(renders), str(mocap), args.no_plate): key
                   for key, r in unique.items()}
        for fut in as_completed(futures):
            try:
                info = fut.result()
            except Exception as exc:
                failed.append(f"render {futures[fut]}: {exc}")
                continue
            print(f"render {info['key']}: "
                  + ("cached" if info.get("cached") else f"{info['render_seconds']:.0f} s")
                  + (f", leaves the common view in frames {info['out_of_view_frames']} "
                     f"({', '.join(info['out_of_view_cameras'])})"
                     if info["out_of_view_frames"] else ""), flush=True)
        futures = {pool.submit(run_one, r, str(renders), str(runs_dir), config_toml,
                               args.no_plate): r
                   for r in runs if (renders / r["key"] / "render.json").exists()}
        for fut in as_completed(futures):
            r = futures[fut]
            try:
                record = fut.result()
            except Exception as exc:
                failed.append(f"run {r['key']} seed {r['seed']}: {exc}")
                continue
            records.append(record)
            print(run_line(record), flush=True)
    records.sort(key=lambda r: ([a for _, a, _ in CLIPS].index(r["action"]), r["heading"],
                                r["noise_seed"], r["seed"]))
    if records:
        text = summary(records, args.protocol, args.start_turned)
        print("\n" + text)
        write_tables(records, runs_dir, text)
    for line in failed:
        print("FAILED " + line)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
