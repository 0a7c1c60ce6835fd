"""Real-data benchmark on the Pose2Sim demo: silhouettes, carving rules and tracked landmarks.

Needs the independent reference of ``scripts/reference_pose2sim_demo.py`` (MediaPipe person masks
and 2D keypoints triangulated over the four views, built without voxelmocap code).

* ``silhouettes``: precision / recall / IoU per camera of the silhouettes against MediaPipe's
  person mask, for the first fallback without a background plate (MOG2 learnt from the
  sequence, adapting while it segments; ``--no-mog2`` skips it) and for the plate learnt from
  the sequence (:mod:`voxelmocap.measure.background`) with its never-seen pixels foreground or decided
  by GrabCut (``plate_unknown``), after the measurement stage's clean-up.
* ``carving``: which carving rule wins on real data: the strict visual hull, one hole tolerated
  (``carve_holes = 1``) anywhere or only near the silhouette (``carve_hole_reach``) and
  ``min_views = 2``, each followed by the largest 3D component. Scored
  by the share of the reference's 3D keypoints (12 body joints) inside the occupancy (grown by
  one voxel) and by the IoU of the occupancy's silhouette, projected back into each view, with
  MediaPipe's mask (alone, and intersected with the view's silhouette). ``--plate-support``
  (``silhouettes``, ``carving``): the plate learnt with ``plate_support``; ``--config F``: the
  measurement settings of a ``track --config`` file.
* ``landmarks RUN``: the tracked landmarks of a ``voxelmocap track`` run against the reference:
  mean error, share within 100 mm (head top excluded: MediaPipe has no head top); ``--every N``
  also prints every N-th frame's error per landmark; ``--frame-offset N``: the run's frame F is
  the demo's frame F + N (a ``scripts/make_guise.py --first-frame N+1`` guise); ``--frame-step
  K``: its frame F is the demo's frame (F − 1)·K + 1 (+ N; a ``make_guise.py --every K`` guise).
* ``overlays RUN``: every camera's overlay of frames 1, 25, 50, 75 and 100 as PNGs
  (``--name``: the files' stem).
* ``oracle-track RUN``: a diagnostic: ``track`` with MediaPipe's masks as the silhouettes of
  every tracked frame (how much of the error the silhouettes cause); ``--cues``, ``--seed`` and
  ``--config`` as for ``track``.
* ``diagnose RUN``: a diagnostic: the run's body fitted to the reference's landmarks (the
  metric's floor for that body) and scored by the run's own cues against the run's estimate —
  does the search miss a better pose, or does the likelihood prefer the wrong one?
  ``--refine N`` first climbs both poses by compass search (N evaluations each) on that score,
  so a fitted pose that is merely off an optimum is not blamed on the likelihood.

``RUN`` may also be a result file, e.g. a first pass's ``RUN/<trial>/pass1/<trial>.h5``.

    python scripts/bench_real.py silhouettes --ref /work/p2s_ref
    python scripts/bench_real.py carving --ref /work/p2s_ref
    voxelmocap track /work/p2s/x/Pose2Sim/Demo_SinglePerson --out RUN
    python scripts/bench_real.py landmarks RUN --ref /work/p2s_ref
    python scripts/bench_real.py overlays RUN --out docs/images
    python scripts/bench_real.py oracle-track RUN_MP && python scripts/bench_real.py landmarks RUN_MP
    python scripts/bench_real.py diagnose RUN --every 5 [--mediapipe-masks] [--unseen count] [--refine 400]

Feeds docs/benchmarks.md, "Real recording (Pose2Sim demo)" (``landmarks``), "Silhouettes (Pose2Sim demo)"
(``silhouettes``) and "Carving" (``carving``: the rules on the demo); ``diagnose`` and
``oracle-track`` are the diagnostics those sections quote.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from voxelmocap import cpu_paths

# Before NumPy loads: the NumPy loops and OpenBLAS kernels `voxelmocap track` runs with, so that
# these runs are the command's on any CPU (voxelmocap.cpu_paths).
cpu_paths.pin()

import cv2  # noqa: E402
import numpy as np  # noqa: E402

DEMO = Path("/work/p2s/x/Pose2Sim/Demo_SinglePerson")
REF = Path("/work/p2s_ref")

#: voxelmocap landmark → MediaPipe landmark(s) (the mean of two for thorax and pelvis).
LANDMARK_MAP = {
    "thorax": ("left_shoulder", "right_shoulder"), "pelvis": ("left_hip", "right_hip"),
    "l_shoulder": ("left_shoulder",), "l_elbow": ("left_elbow",), "l_wrist": ("left_wrist",),
    "r_shoulder": ("right_shoulder",), "r_elbow": ("right_elbow",), "r_wrist": ("right_wrist",),
    "l_hip": ("left_hip",), "l_knee": ("left_knee",), "l_ankle": ("left_ankle",),
    "r_hip": ("right_hip",), "r_knee": ("right_knee",), "r_ankle": ("right_ankle",),
}
BODY_JOINTS = ("left_shoulder", "right_shoulder", "left_elbow", "right_elbow", "left_wrist",
               "right_wrist", "left_hip", "right_hip", "left_knee", "right_knee", "left_ankle",
               "right_ankle")


def load_reference(ref: Path):
    data = np.load(ref / "reference.npz")
    return {k: data[k] for k in data.files}


def load_masks(ref: Path, camera: str) -> np.ndarray:
    data = np.load(ref / f"masks_{camera}.npz")
    shape = data["shape"]
    return np.unpackbits(data["packed"], axis=2)[:, :, :shape[2]].astype(bool)


def scores(pred: np.ndarray, truth: np.ndarray) -> tuple[float, float, float]:
    tp = np.count_nonzero(pred & truth)
    fp = np.count_nonzero(pred & ~truth)
    fn = np.count_nonzero(~pred & truth)
    return tp / max(tp + fp, 1), tp / max(tp + fn, 1), tp / max(tp + fp + fn, 1)


def open_demo(demo: Path):
    from voxelmocap.io.sequence import open_sequence

    return open_sequence(demo)


def table(rows, header) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(lines)


# ---------------------------------------------------------------------- silhouettes
def _config(args):
    """The TrackConfig of ``--config`` (default: the defaults), with ``--plate-support``."""
    from voxelmocap.config import TrackConfig, config_from_toml, with_overrides

    base = config_from_toml(args.config.read_text()) if args.config else TrackConfig()
    return with_overrides(base, **{
        "measurement.silhouette.plate_support": True if args.plate_support else None})


def silhouettes(args) -> None:
    import dataclasses

    from voxelmocap.config import SilhouetteConfig
    from voxelmocap.measure.silhouette import build_backgrounds, segment
    from voxelmocap.run.measurement import MeasurementRunner

    seq = open_demo(args.demo)
    names = list(seq.camera_names)
    refm = {n: load_masks(args.ref, n) for n in names}
    step = args.step
    frames = list(seq.frame_numbers)
    t0 = time.perf_counter()
    plate_body = None
    if args.plate_from is not None:  # the plate of a pass learnt from an earlier run's body
        from voxelmocap.run.bodies import tracked_body

        plate_body = tracked_body(args.plate_from, seq)
    runner = MeasurementRunner(seq, _config(args), log=print, plate_body=plate_body)
    t_plate = time.perf_counter() - t0
    variants = {}
    if not args.no_mog2:
        # before: MOG2 learnt from the sequence, adapting while it segments (the first fallback)
        mog_cfg = SilhouetteConfig(method="mog2")
        sample = {n: [[]] for n in names}
        for _, images in seq.frames(frames):
            for n in names:
                sample[n][0].append(images[n])
        variants["MOG2 from the sequence"] = (mog_cfg, build_backgrounds(mog_cfg, names, sample,
                                                                         sets=True), True)
    variants["learnt plate, never-seen pixels foreground"] = (
        dataclasses.replace(runner.config, plate_unknown="foreground"), runner.backgrounds, False)
    variants[f"learnt plate, never-seen pixels by {runner.config.plate_unknown} (default)"] = (
        runner.config, runner.backgrounds, False)
    counts = {(v, n): np.zeros(3) for v in variants for n in names}
    seconds = {v: 0.0 for v in variants}
    for k, (number, images) in enumerate(seq.frames(frames)):
        truth_of = {n: refm[n][int(number) - 1] for n in names}
        for v, (cfg, models, every_frame) in variants.items():
            if k % step and not every_frame:
                continue
            for n in names:
                t1 = time.perf_counter()
                m = segment(images[n], models[n], cfg, camera=n)
                seconds[v] += time.perf_counter() - t1
                if k % step:
                    continue
                truth = truth_of[n]
                counts[v, n] += [np.count_nonzero(m & truth), np.count_nonzero(m & ~truth),
                                 np.count_nonzero(~m & truth)]
    rows = []
    for n in names:
        for v in variants:
            tp, fp, fn = counts[v, n]
            rows.append([n, v, f"{tp / max(tp + fp, 1):.2f}", f"{tp / max(tp + fn, 1):.2f}",
                         f"{tp / max(tp + fp + fn, 1):.2f}"])
    print(table(rows, ["camera", "silhouettes", "precision", "recall", "IoU"]))
    print(f"frames scored: every {step}th of {len(frames)}; plate learning + grid {t_plate:.0f} s; "
          + ", ".join(f"{v}: {s:.0f} s segmenting" for v, s in seconds.items())
          + f"; grid {runner.grid.shape} at {runner.grid.voxel_size:g} mm from "
          f"{runner.grid.low.round()} to {runner.grid.high.round()}")
    if args.save_masks:
        np.savez_compressed(args.save_masks, **{n: np.stack([
            segment(img[n], runner.backgrounds[n], runner.config, camera=n)
            for _, img in seq.frames(frames[::step])]) for n in names})


# ---------------------------------------------------------------------- carving rules
def carving(args) -> None:
    from voxelmocap.measure.background import person_component
    from voxelmocap.run.measurement import MeasurementRunner

    seq = open_demo(args.demo)
    names = list(seq.camera_names)
    ref = load_reference(args.ref)
    joint_idx = [list(ref["names"]).index(j) for j in BODY_JOINTS]
    refm = {n: load_masks(args.ref, n) for n in names}
    runner = MeasurementRunner(seq, _config(args), log=print)
    grid, carver = runner.grid, runner.carver
    rules = {"strict (every view)": lambda m: carver.carve(m),
             "one hole, anywhere (carve_hole_reach = 0)":
                 lambda m: carver.carve_with_holes(m, 1),
             f"one hole, within {runner.hole_reach:g} of the diagonal (default)":
                 lambda m: carver.carve_with_holes(m, 1, reach=runner.hole_reach),
             "min_views = 2": lambda m: carver.carve(m, min_views=2)}
    res = {r: {"inside": [], "iou": [], "volume": [], "iou_and": []} for r in rules}
    frames = list(seq.frame_numbers)[::args.step]
    for number, images in seq.frames(frames):
        if args.mediapipe_masks:
            # the reference's person masks (videos 8 columns narrower than the calibration are
            # cropped on the right, as the project reader assumes): the hull each rule gives
            # with near-perfect silhouettes
            masks = [np.pad(refm[c.name][int(number) - 1],
                            ((0, 0), (0, c.size[0] - refm[c.name].shape[2])))
                     for c in runner.cameras]
        else:
            masks = runner.masks(images)
        pts = ref["points_mm"][int(number) - 1, joint_idx]
        for rule, fn in rules.items():
            occ = person_component(fn(masks))
            grown = cv2.dilate(occ.astype(np.uint8).reshape(occ.shape[0], -1),
                               np.ones((3, 3), np.uint8)).reshape(occ.shape).astype(bool)
            idx = grid.index_of(pts[np.isfinite(pts).all(axis=1)])
            ok = grid.contains_index(idx)
            inside = np.zeros(len(idx), bool)
            inside[ok] = grown[tuple(idx[ok].T)]
            res[rule]["inside"].append(inside.mean())
            res[rule]["volume"].append(occ.sum() * grid.voxel_size ** 3 / 1e6)
            for c, cam in enumerate(runner.cameras):
                w, h = cam.size
                sil = np.zeros(h * w, np.uint8)
                t = carver.tables[c][occ.reshape(-1)]
                sil[t[t >= 0] - int(carver._offsets[c])] = 1
                sil = cv2.dilate(sil.reshape(h, w), np.ones((9, 9), np.uint8)).astype(bool)
                truth = refm[cam.name][int(number) - 1]
                truth = np.pad(truth, ((0, 0), (0, w - truth.shape[1])))
                res[rule]["iou"].append(scores(sil, truth)[2])
                # the silhouette without what carves into nothing (2D ghosts, other people)
                res[rule]["iou_and"].append(scores(sil & masks[c], truth)[2])
    rows = [[rule, f"{100 * np.mean(v['inside']):.1f} %", f"{np.mean(v['iou']):.2f}",
             f"{np.mean(v['iou_and']):.2f}", f"{np.mean(v['volume']):.0f}"]
            for rule, v in res.items()]
    print(table(rows, ["carving rule", "reference joints inside", "reprojected IoU",
                       "IoU of reprojection ∩ silhouette", "volume (litres)"]))


# ---------------------------------------------------------------------- landmarks
def _result(run: Path):
    from voxelmocap.io.reports import find_result_files
    from voxelmocap.io.results import read_result

    if run.suffix == ".h5":                     # a result file, e.g. RUN/<trial>/pass1/<trial>.h5
        if not run.is_file():
            raise SystemExit(f"{run}: no such result file")
        return run, read_result(run)
    files = [p for p in find_result_files(run) if p.suffix == ".h5"]
    if len(files) != 1:
        raise SystemExit(f"{run}: expected one result file, found {len(files)}")
    return files[0], read_result(files[0])


def landmarks(args) -> None:
    from voxelmocap.joints import LANDMARK_NAMES

    ref = load_reference(args.ref)
    names = list(ref["names"])
    _, result = _result(args.run)
    errs = []
    per = {k: [] for k in LANDMARK_MAP}
    rows = []
    for i, f in enumerate(result.frames):
        truth = ref["points_mm"][(int(f) - 1) * args.frame_step + args.frame_offset]
        row = {}
        for j, name in enumerate(LANDMARK_NAMES):
            if name not in LANDMARK_MAP:
                continue                       # head top: MediaPipe has none
            t = np.mean([truth[names.index(m)] for m in LANDMARK_MAP[name]], axis=0)
            if not np.all(np.isfinite(t)):
                continue
            e = float(np.linalg.norm(result.landmarks[i, j] - t))
            errs.append(e)
            per[name].append(e)
            row[name] = e
        rows.append((int(f), row))
    if args.every:
        # one line per frame: where in the clip a track went wrong, and which limb
        print(table([[f] + [f"{row[k]:.0f}" if k in row else "" for k in LANDMARK_MAP]
                     for f, row in rows[::args.every]], ["frame", *LANDMARK_MAP]))
    errs = np.asarray(errs)
    print(f"{len(result.frames)} frames, {len(errs)} landmark errors (head top excluded): mean "
          f"{errs.mean():.0f} mm, median {np.median(errs):.0f} mm, within 100 mm "
          f"{100 * np.mean(errs <= 100):.0f} %")
    print(table([[k, f"{np.mean(v):.0f}", f"{100 * np.mean(np.asarray(v) <= 100):.0f} %"]
                 for k, v in per.items()], ["landmark", "mean error (mm)", "within 100 mm"]))


# ---------------------------------------------------------------------- overlays
def overlays(args) -> None:
    from voxelmocap.io.sequence import open_sequence
    from voxelmocap.run.inspection import result_body_model
    from voxelmocap.viz.overlay import overlay_all

    _, result = _result(args.run)
    seq = open_sequence(args.demo)
    model = result_body_model(seq, result)          # the body the run tracked with
    args.out.mkdir(parents=True, exist_ok=True)
    rows = {int(f): i for i, f in enumerate(result.frames)}
    wanted = [f for f in (1, 25, 50, 75, 100) if f in rows]
    for number, images in seq.frames(wanted):
        i = rows[int(number)]
        img = overlay_all(images, list(seq.rig), model, result.state[i], result.landmarks[i],
                          caption=f"frame {int(number)}", max_width=args.width)
        out = args.out / f"{args.name}_{int(number):03d}.png"
        from PIL import Image

        # a 64-colour palette keeps each PNG near 100 kB (the docs hold five)
        Image.fromarray(img[:, :, ::-1]).quantize(64).save(out, optimize=True)
        print(out, f"{out.stat().st_size / 1024:.0f} kB")


# ---------------------------------------------------------------------- search or likelihood?
def _reference_landmarks(ref, frame: int) -> np.ndarray | None:
    """The reference's 15 landmarks of ``frame`` (1-based) in ``LANDMARK_NAMES`` order, or None.

    MediaPipe has no head top: it is put 120 mm above the ears' midpoint along the line from the
    shoulders' midpoint (a stand-in for the IK fit only; head top is never scored)."""
    from voxelmocap.joints import LANDMARK_NAMES

    names = list(ref["names"])
    truth = ref["points_mm"][frame - 1]

    def mean(*keys):
        return np.mean([truth[names.index(k)] for k in keys], axis=0)

    out = []
    for name in LANDMARK_NAMES:
        if name in LANDMARK_MAP:
            out.append(mean(*LANDMARK_MAP[name]))
        else:
            ears, shoulders = mean("left_ear", "right_ear"), mean("left_shoulder", "right_shoulder")
            up = ears - shoulders
            out.append(ears + 120.0 * up / np.linalg.norm(up))
    out = np.asarray(out)
    return out if np.all(np.isfinite(out)) else None


def diagnose(args) -> None:
    """Per scored frame: the run's estimate against the run's body fitted to the reference.

    The fit (``fit_to_landmarks``, least squares over the 27 legal parameters, the estimate as an
    extra start) is the best this body model can do by the metric: its error is the metric's
    floor for that body (MediaPipe's points are not the model's joint centres). Both poses are
    then scored by the run's own cues (config read from the result) on that frame's measurement:
    when the fitted pose scores higher, the search missed a better optimum; when lower, the
    likelihood (its silhouettes, voxels and weights) prefers the wrong pose. With
    ``--mediapipe-masks`` both are scored on MediaPipe's masks instead (is it the silhouettes?).
    """
    from voxelmocap.body import fit_to_landmarks
    from voxelmocap.config import config_from_toml, with_overrides
    from voxelmocap.io.sequence import open_sequence
    from voxelmocap.joints import LANDMARK_NAMES
    from voxelmocap.pose.tracker import BodyTracker
    from voxelmocap.run.bodies import tracked_body
    from voxelmocap.run.inspection import result_body_model
    from voxelmocap.run.measurement import MeasurementRunner

    if args.mediapipe_masks:
        _use_mediapipe_masks(args.ref)
    ref = load_reference(args.ref)
    _, result = _result(args.run)
    config = with_overrides(config_from_toml(str(result.attrs["config"])),
                            **{"cues.silhouette_unseen": args.unseen})
    seq = open_sequence(args.demo)
    model = result_body_model(seq, result)
    plate_from = str(result.attrs.get("plate_from", ""))
    # the run's own silhouettes: a pass whose plate came from a body learns it from that body
    runner = MeasurementRunner(seq, config, log=None,
                               plate_body=tracked_body(plate_from, seq) if plate_from else None)
    tracker = BodyTracker(model, config)
    scored = [j for j, n in enumerate(LANDMARK_NAMES) if n in LANDMARK_MAP]
    rows = {int(f): i for i, f in enumerate(result.frames)}
    wanted = [f for f in sorted(rows) if (f - 1) % args.every == 0]
    out, table_rows = [], []
    for number, images in seq.frames(wanted):
        i = rows[int(number)]
        target = _reference_landmarks(ref, int(number))
        if target is None:
            continue
        fitted = fit_to_landmarks(model, target, initial=result.state[i])
        states = np.stack([result.state[i], fitted])
        lms = model.forward(states).joints[:, scored]
        err = np.linalg.norm(lms - target[scored], axis=2)            # (2, 14)
        observation = runner.measure(images, frame=int(number))
        if args.refine:
            # both poses climbed to the nearest optimum of the same score: a fitted pose that
            # stays near the reference and then outscores the estimate means the search missed
            # it; one that drifts away or stays below means the likelihood prefers another pose
            states = np.stack([_refined(tracker, observation, model, x, args.refine)
                               for x in states])
            lms = model.forward(states).joints[:, scored]
            err = np.linalg.norm(lms - target[scored], axis=2)
        with tracker._paper_likelihood():
            parts = tracker.cues.evaluate(observation, states)
        total = sum(w * parts[n] for n, w in zip(tracker.cues.names, tracker.cues.weights,
                                                  strict=True))
        out.append((err, total, parts))
        table_rows.append([str(int(number)), f"{err[0].mean():.0f}", f"{err[1].mean():.0f}",
                           f"{total[1] - total[0]:+.1f}"]
                          + [f"{parts[n][1] - parts[n][0]:+.1f}" for n in tracker.cues.names])
    print(table(table_rows, ["frame", "estimate error (mm)", "fitted error (mm)",
                             "Δ log-likelihood (fitted − estimate)"]
                + [f"Δ {n} (unweighted)" for n in tracker.cues.names]))
    est = np.concatenate([e[0][0] for e in out])
    fit = np.concatenate([e[0][1] for e in out])
    better = sum(float(t[1] >= t[0]) for _, t, _ in out)
    print(f"{len(out)} frames: estimate mean {est.mean():.0f} mm ({100 * np.mean(est <= 100):.0f} % "
          f"within 100 mm); the body fitted to the reference {fit.mean():.0f} mm "
          f"({100 * np.mean(fit <= 100):.0f} % within 100 mm); the fitted pose scores at least as "
          f"well as the estimate in {better:.0f}/{len(out)} frames")


def _refined(tracker, observation, model, x, evaluations: int) -> np.ndarray:
    """``x`` improved by compass search over all 27 parameters on the score ``diagnose``
    reports (the run's cues, paper 002's voxel likelihood without the coverage term)."""
    from voxelmocap.tracking.refine import pattern_search

    def ll(states):
        with tracker._paper_likelihood():
            return tracker.cues.log_likelihood(observation, model.clip(states))

    steps = np.where(np.arange(model.n_dims) < 3, 20.0, 0.05)      # mm for the root, else rad
    best, _, _ = pattern_search(ll, model.clip(x[None])[0], np.arange(model.n_dims), steps,
                                low=model.low, high=model.high, max_evaluations=evaluations)
    return best


# ---------------------------------------------------------------------- diagnostic
def _use_mediapipe_masks(ref_dir: Path) -> None:
    """From now on, a measured frame's silhouettes are MediaPipe's masks (a diagnostic patch).

    The grid is still placed from voxelmocap's own silhouettes; only
    :meth:`MeasurementRunner.measure` of a numbered frame sees the masks."""
    import voxelmocap.measure.stage as measurement
    import voxelmocap.run.measurement as runner_module

    ref = {n: load_masks(ref_dir, n) for n in ("cam01", "cam02", "cam03", "cam04")}
    current = {"frame": None}
    masks_of, measure_of = measurement.MeasurementStage.masks, runner_module.MeasurementRunner.measure

    def masks(self, images):
        own = masks_of(self, images)
        if current["frame"] is None:
            return own
        out = [np.pad(ref[c.name][current["frame"]],
                      ((0, 0), (0, c.size[0] - ref[c.name].shape[2]))) for c in self.cameras]
        return np.stack(out) if len({o.shape for o in out}) == 1 else out

    def measure(self, images, *, frame=None):
        current["frame"] = None if frame is None else int(frame) - 1
        try:
            return measure_of(self, images, frame=frame)
        finally:
            current["frame"] = None

    measurement.MeasurementStage.masks = masks
    runner_module.MeasurementRunner.measure = measure


def oracle_track(args) -> None:
    """``voxelmocap track`` with MediaPipe's masks as the silhouettes of every tracked frame.

    A diagnostic of how much of the tracked error the silhouettes cause (not a method: the
    reference would no longer be independent).
    """
    from voxelmocap.cli import main as cli

    _use_mediapipe_masks(args.ref)
    extra = (["--seed", str(args.seed)] + (["--cues", args.cues] if args.cues else [])
             + (["--config", str(args.config)] if args.config else []))
    cli(["track", str(args.demo), "--out", str(args.run), *extra])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="what", required=True)
    for name in ("silhouettes", "carving", "landmarks", "overlays", "oracle-track",
                 "diagnose"):
        p = sub.add_parser(name)
        p.add_argument("--demo", type=Path, default=DEMO)
        p.add_argument("--ref", type=Path, default=REF)
        if name in ("landmarks", "overlays", "oracle-track", "diagnose"):
            p.add_argument("run", type=Path)
        if name in ("silhouettes", "carving"):
            p.add_argument("--step", type=int, default=5, help="score every STEP-th frame")
            p.add_argument("--plate-support", action="store_true",
                           help="learn the plate with [measurement.silhouette] plate_support")
            p.add_argument("--config", type=Path, help="a track --config TOML (the measurement)")
        if name == "silhouettes":
            p.add_argument("--plate-from", type=Path, metavar="RUN",
                           help="learn the plate with RUN's body (track --plate-from)")
        if name == "carving":
            p.add_argument("--mediapipe-masks", action="store_true",
                           help="carve MediaPipe's masks instead of the silhouettes")
        if name == "silhouettes":
            p.add_argument("--save-masks", type=Path)
            p.add_argument("--no-mog2", action="store_true",
                           help="skip the MOG2 baseline (it segments every frame)")
        if name == "overlays":
            p.add_argument("--out", type=Path, default=Path("docs/images"))
            p.add_argument("--width", type=int, default=640)
            p.add_argument("--name", default="pose2sim_demo_overlay",
                           help="file names NAME_<frame>.png")
        if name == "diagnose":
            p.add_argument("--every", type=int, default=5, help="every EVERY-th tracked frame")
            p.add_argument("--mediapipe-masks", action="store_true",
                           help="score on MediaPipe's masks instead of the run's silhouettes")
            p.add_argument("--refine", type=int, default=0, metavar="N",
                           help="first climb both poses by compass search (N evaluations "
                                "each) on the score reported")
            p.add_argument("--unseen", choices=("ignore", "count"),
                           help="[cues] silhouette_unseen for the scoring (default: the run's; "
                                "runs older than the key read as the default, count)")
        if name == "landmarks":
            p.add_argument("--every", type=int, default=0,
                           help="also print every EVERY-th frame's errors per landmark")
            p.add_argument("--frame-offset", type=int, default=0, metavar="N",
                           help="the run's frame F is the reference's frame F + N (a guise "
                                "of scripts/make_guise.py --first-frame N+1)")
            p.add_argument("--frame-step", type=int, default=1, metavar="K",
                           help="the run's frame F is the reference's frame (F - 1)·K + 1 (+ "
                                "the offset): a guise of make_guise.py --every K")
        if name == "oracle-track":
            p.add_argument("--seed", type=int, default=0)
            p.add_argument("--cues", help="track --cues (default: the config's)")
            p.add_argument("--config", type=Path, help="track --config")
    args = ap.parse_args(argv)
    if getattr(args, "refine", 0) < 0:
        ap.error(f"--refine must be >= 0, got {args.refine}")
    {"silhouettes": silhouettes, "carving": carving, "landmarks": landmarks,
     "overlays": overlays, "oracle-track": oracle_track, "diagnose": diagnose}[args.what](args)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
