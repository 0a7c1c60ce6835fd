"""Tracking-accuracy study on synthetic sequences: which setting moves μ, MMTA and the drift.

Renders procedural motions once (``voxelmocap.synth.generate``, cached under ``--data``), carves
every frame once per measurement setting (occupancy cached as ``.npz`` next to the data), then runs
the product's tracker (:class:`voxelmocap.pose.tracker.BodyTracker`, the class
:func:`voxelmocap.run.pipeline.track_sequence` steps, with the body model of ``body_model_for`` and the
ground-truth initialisation) for every setting and seed, and prints one table:

    setting → μ (mm, mean ± sd over seeds), MMTA (%, δ = 100 mm), mean error per quarter of the
    sequence (the drift), the three worst landmarks, filter seconds/frame.

``--check`` first verifies that tracking the cached occupancies reproduces ``track_sequence`` bit
for bit on the first frames of the baseline. ``--diagnose`` prints, per frame, the four scores and the
log-likelihood of the *ground-truth* pose (the body model fitted to the true landmarks with
``fit_to_landmarks``) next to those of the baseline's estimate, and the landmark offset between the
renderer's joints and the fitted cone model: if the truth scores worse than the estimate, the
likelihood (not the search) is at fault.

Examples::

    python scripts/study_tracking.py --motion walk --frames 60 --settings baseline,paper_var
    python scripts/study_tracking.py --motion walk --diagnose --settings baseline
    python scripts/study_tracking.py --list

Settings are TrackConfig overrides relative to the demo's working point (6 layers × 300
particles, 20 mm voxels, defaults otherwise); see ``SETTINGS``. Results of every (data, config,
seed) run are cached as JSON under ``--out`` so that a table can be re-printed or extended cheaply.
"""

from __future__ import annotations

import argparse
import dataclasses
import hashlib
import json
import sys
import time
from pathlib import Path

import numpy as np

from voxelmocap.config import TrackConfig, config_to_toml, with_overrides

ACTIONS = {"walk": "Walking", "jog": "Jog", "box": "Box", "gestures": "Gestures",
           "throwcatch": "ThrowCatch"}
CAMERAS = ["C1", "C2", "C3", "BW1", "BW2", "BW3", "BW4"]

#: The defaults before this study (trunk angles on the limbs' noise, joint_std_rad 0.15).
BEFORE = {"profile": "root_only", "filter.joint_std_rad": 0.15}

#: name → TrackConfig overrides ("section.key": value) on top of the demo's working point and the
#: *current* defaults; ``"profile"`` selects a candidate body of ``tracker.noise_profile``
#: (:data:`PROFILES`). ``before_*`` settings are relative to the defaults before this study.
SETTINGS: dict[str, dict] = {
    "baseline": {},
    "before": dict(BEFORE),
    # propagation noise: structure and levels
    "before_trunk_as_root": {"filter.joint_std_rad": 0.15},
    "before_joint0.1": {"profile": "root_only", "filter.joint_std_rad": 0.1},
    "before_joint0.07": {"profile": "root_only", "filter.joint_std_rad": 0.07},
    "before_rot0.02": dict(BEFORE, **{"filter.rotation_std_rad": 0.02}),
    "before_noise_x0.5": {"profile": "root_only", "filter.translation_std_mm": 12.5,
                          "filter.rotation_std_rad": 0.03, "filter.joint_std_rad": 0.075},
    "before_noise_x2": {"profile": "root_only", "filter.translation_std_mm": 50.0,
                        "filter.rotation_std_rad": 0.12, "filter.joint_std_rad": 0.3},
    "before_trans12": dict(BEFORE, **{"filter.translation_std_mm": 12.0}),
    "before_limbs_by_speed": {"profile": "limbs_by_speed", "filter.joint_std_rad": 0.15},
    "joint0.12": {"filter.joint_std_rad": 0.12},
    "joint0.07": {"filter.joint_std_rad": 0.07},
    "limbs_by_speed": {"profile": "limbs_by_speed"},
    "pitch_roll_low": {"profile": "pitch_roll_low"},
    "rot0.03": {"filter.rotation_std_rad": 0.03},
    "rot0.1": {"filter.rotation_std_rad": 0.1},
    "rot0.03_survival0.3": {"filter.rotation_std_rad": 0.03, "filter.survival": 0.3},
    "trans18": {"filter.translation_std_mm": 18.0},
    "trans35": {"filter.translation_std_mm": 35.0},
    # dynamics
    "velocity": {"filter.dynamics": "velocity"},
    "elbow": {"filter.dynamics": "elbow"},
    "before_velocity": dict(BEFORE, **{"filter.dynamics": "velocity"}),
    # annealing
    "survival0.3": {"filter.survival": 0.3},
    "survival0.7": {"filter.survival": 0.7},
    "decay0.3": {"filter.noise_decay": 0.3},
    "decay0.7": {"filter.noise_decay": 0.7},
    "before_survival0.7": dict(BEFORE, **{"filter.survival": 0.7}),
    "before_decay0.7": dict(BEFORE, **{"filter.noise_decay": 0.7}),
    "particles600": {"filter.particles": 600},
    "particles150": {"filter.particles": 150},
    "layers10": {"filter.layers": 10},
    "init_spread1": {"init.spread": 1.0},
    # balance of the four scores (σ²_Out, σ²_DO, σ²_Empty, σ²_Surf); default = the paper's
    "var_do0.1": {"likelihood.variances": (0.01, 0.1, 0.1, 0.1)},
    "var_do1": {"likelihood.variances": (0.01, 1.0, 0.1, 0.1)},
    "var_empty0.03": {"likelihood.variances": (0.01, 0.01, 0.03, 0.1)},
    "var_do0.1_empty0.03": {"likelihood.variances": (0.01, 0.1, 0.03, 0.1)},
    "var_surf1": {"likelihood.variances": (0.01, 0.01, 0.1, 1.0)},
    "var_surf0.03": {"likelihood.variances": (0.01, 0.01, 0.1, 0.03)},
    "before_var_do0.1": dict(BEFORE, **{"likelihood.variances": (0.01, 0.1, 0.1, 0.1)}),
    "before_var_do0.1_empty0.03": dict(BEFORE, **{"likelihood.variances":
                                                  (0.01, 0.1, 0.03, 0.1)}),
    # measurement
    "surf_sigma2": {"measurement.surface_sigma": 2.0},
    "surf_sigma0.5": {"measurement.surface_sigma": 0.5},
    "min_views6": {"measurement.min_views": 6},
    "min_views5": {"measurement.min_views": 5},
}


def _root_only(model, config, base):
    """The noise_std before this study: only the root angles on ``rotation_std_rad``, the waist
    and neck on the limbs' ``joint_std_rad``."""
    std = base(model, config).copy()
    names = list(model.state_names)
    for n in ("waist_flex", "waist_side", "waist_twist", "neck_flex", "neck_side"):
        std[names.index(n)] = config.filter.joint_std_rad
    return std


def _trunk_as_root(model, config, base):
    """Waist and neck angles on the root rotation's std (what ``tracker.noise_profile`` does)."""
    std = base(model, config).copy()
    names = list(model.state_names)
    for n in ("waist_flex", "waist_side", "waist_twist", "neck_flex", "neck_side"):
        std[names.index(n)] = config.filter.rotation_std_rad
    return std


def _limbs_by_speed(model, config, base):
    """Trunk as the root; hips and shoulders at 0.6× the joint std, knees and elbows at the full
    joint std (the distal hinges move fastest in gait)."""
    std = _trunk_as_root(model, config, base)
    names = list(model.state_names)
    for i, n in enumerate(names):
        if n.endswith(("_hip_flex", "_hip_abd", "_hip_rot", "_shoulder_flex", "_shoulder_abd",
                       "_shoulder_rot")):
            std[i] = 0.6 * config.filter.joint_std_rad
    return std


def _pitch_roll_low(model, config, base):
    """Root pitch and roll at a third of ``rotation_std_rad`` (they span a near-null direction of
    the likelihood with the waist and the hips); yaw and trunk unchanged."""
    std = base(model, config).copy()
    names = list(model.state_names)
    for n in ("root_pitch", "root_roll"):
        std[names.index(n)] = config.filter.rotation_std_rad / 3.0
    return std


#: Candidate bodies of ``tracker.noise_profile`` (setting key ``"profile"``), each given the current
#: ``noise_profile`` as ``base``; the result goes to the tracker as its ``noise_std``.
PROFILES = {"root_only": _root_only, "trunk_as_root": _trunk_as_root,
            "limbs_by_speed": _limbs_by_speed, "pitch_roll_low": _pitch_roll_low}

#: The demo's working point (``voxelmocap demo``), on which every setting is applied.
DEMO = {"filter.layers": 6, "filter.particles": 300, "measurement.voxel_size": 20.0}


def parse_setting(name: str) -> dict:
    """Overrides of a named setting, or of an ad-hoc ``key=value;key=value`` string."""
    if name in SETTINGS:
        return dict(SETTINGS[name])
    if "=" not in name:
        raise SystemExit(f"unknown setting {name!r}; --list shows the named ones")
    out = {}
    for item in name.split(";"):
        key, value = item.split("=", 1)
        try:
            out[key.strip()] = json.loads(value)
        except ValueError:
            out[key.strip()] = value.strip()
    return {k: tuple(v) if isinstance(v, list) else v for k, v in out.items()}


def source_hash(*names: str) -> str:
    """Hash of package sources (globs under ``voxelmocap/``), so that caches made with other code
    (the checkout is shared and changes under a running study) are not reused."""
    root = Path(__file__).resolve().parents[1] / "voxelmocap"
    h = hashlib.sha1()
    for name in names:
        for path in sorted(root.glob(name)):
            h.update(path.read_bytes())
    return h.hexdigest()[:10]


MEASUREMENT_SOURCES = ("silhouette.py", "carving.py", "_carving_kernels.py", "measurement.py",
                       "grid.py", "camera.py", "io/humaneva.py", "pipeline.py")
TRACKING_SOURCES = MEASUREMENT_SOURCES + ("likelihood.py", "_raster_kernels.py", "surface.py",
                                          "body/*.py", "tracking/*.py", "config.py",
                                          "tracker.py")


def make_config(overrides: dict) -> TrackConfig:
    overrides = {k: v for k, v in overrides.items() if k != "profile"}
    return with_overrides(with_overrides(TrackConfig(), **DEMO), **overrides)


# ------------------------------------------------------------------------------------ data
def dataset(root: Path, motion: str, frames: int, cameras: int, seed: int) -> Path:
    """Render a procedural sequence once; later calls reuse it."""
    from voxelmocap.synth import generate

    path = root / f"{motion}_f{frames}_c{cameras}_s{seed}"
    if not (path / "S1" / "Mocap_Data" / f"{ACTIONS[motion]}_1.xml").exists():
        print(f"rendering {path} ...", file=sys.stderr)
        generate(path, motion=motion, frames=frames, subject="S1", action=ACTIONS[motion],
                 trial=1, seed=seed, cameras=CAMERAS[:cameras], progress=False)
    return path


def measurements(data: Path, motion: str, config: TrackConfig):
    """(frame numbers (F,), occupancies (F, nx, ny, nz), grid, seconds/frame of carving);
    cached per measurement setting (surface_sigma is applied later, it does not change carving)."""
    from voxelmocap.grid import VoxelGrid
    from voxelmocap.io.humaneva import Dataset
    from voxelmocap.run.measurement import MeasurementRunner

    mc = config.measurement
    key = json.dumps({"voxel": mc.voxel_size, "min_views": mc.min_views,
                      "origin": mc.grid_origin, "shape": mc.grid_shape,
                      "bg": mc.background_frames, "sil": dataclasses.asdict(mc.silhouette),
                      "code": source_hash(*MEASUREMENT_SOURCES)}, sort_keys=True)
    cache = data / f"occupancy_{hashlib.sha1(key.encode()).hexdigest()[:10]}.npz"
    if cache.exists():
        z = np.load(cache)
        occ = np.unpackbits(z["packed"], axis=-1)[..., : int(z["nz"])].astype(bool)
        grid = VoxelGrid(tuple(z["origin"]), float(z["voxel"]), tuple(int(s) for s in z["shape"]))
        return z["frames"], occ, grid, float(z["seconds"])
    seq = Dataset(data).sequence("S1", f"{ACTIONS[motion]}_1")
    gt = seq.ground_truth()
    runner = MeasurementRunner(seq, config, log=None)
    frames, occs = [], []
    t0 = time.perf_counter()
    for frame_number, images in seq.frames(np.intersect1d(seq.frame_numbers, gt.frames)):
        frames.append(int(frame_number))
        occs.append(runner.measure(images).occupancy)
    seconds = (time.perf_counter() - t0) / len(frames)
    occ = np.array(occs)
    g = runner.grid
    np.savez_compressed(cache, packed=np.packbits(occ, axis=-1), nz=occ.shape[-1],
                        frames=np.array(frames), origin=np.array(g.origin), voxel=g.voxel_size,
                        shape=np.array(g.shape), seconds=seconds)
    return np.array(frames), occ, g, seconds


def truth(data: Path, motion: str):
    """(sequence, ground truth, body model) as the pipeline builds them."""
    from voxelmocap.io.humaneva import Dataset
    from voxelmocap.run.bodies import body_model_for

    seq = Dataset(data).sequence("S1", f"{ACTIONS[motion]}_1")
    gt = seq.ground_truth()
    model, _ = body_model_for(seq, gt)
    return seq, gt, model


# ------------------------------------------------------------------------------------ tracking
def track_cached(frames, occ, grid, gt, model, config: TrackConfig, seed: int,
                 profile: str | None = None):
    """Track cached occupancies with the product's :class:`~voxelmocap.pose.tracker.BodyTracker`.

    ``profile`` names a candidate body of ``tracker.noise_profile`` (:data:`PROFILES`), given to
    the tracker as its ``noise_std``.

    Returns (states (F, 27), endpoints (F, 20, 3), filter seconds per frame).
    """
    from voxelmocap.pose.filter_setup import noise_profile
    from voxelmocap.pose.records import Collector
    from voxelmocap.pose.starts import ground_truth_landmarks
    from voxelmocap.pose.tracker import BodyTracker
    from voxelmocap.score.likelihood import Measurement

    noise = None if profile is None else PROFILES[profile](model, config, noise_profile)
    kept = Collector("state", "endpoints", "seconds")
    tracker = BodyTracker(model, config, seed=seed, noise_std=noise, observers=[kept])
    for frame_number, o in zip(frames, occ, strict=True):
        measurement = Measurement(o, grid, sigma=config.measurement.surface_sigma)
        if not tracker.initialised:
            tracker.initialise(measurement, ground_truth_landmarks(gt, frame_number),
                               frame=frame_number)
        tracker.step(measurement, frame=frame_number)
    out = kept.stacked()
    seconds = out["seconds"]
    return out["state"], out["endpoints"], float(np.mean(seconds[1:] if len(seconds) > 1
                                                         else seconds))


def evaluate(frames, endpoints, gt):
    from voxelmocap.evaluation import evaluate_sequence

    rows = gt.index_of(frames)
    scores, per_frame = evaluate_sequence(endpoints, gt.endpoints[rows], gt.enabled[rows])
    return scores, per_frame


def run_one(args, motion, overrides, seed):
    """One (dataset, setting, seed) run; JSON-cached by the resolved config."""
    config = make_config(overrides)
    data = dataset(args.data, motion, args.frames, args.cameras, args.data_seed)
    profile = overrides.get("profile")
    key = hashlib.sha1((str(data) + config_to_toml(config) + str(seed) + str(profile)
                       + source_hash(*TRACKING_SOURCES)).encode()).hexdigest()[:16]
    cache = args.out / f"{data.name}_{key}.json"
    if cache.exists():
        return json.loads(cache.read_text())
    frames, occ, grid, carve_s = measurements(data, motion, config)
    _, gt, model = truth(data, motion)
    states, endpoints, sec = track_cached(frames, occ, grid, gt, model, config, seed,
                                          profile)
    scores, pf = evaluate(frames, endpoints, gt)
    from voxelmocap.joints import LANDMARK_NAMES

    per_joint = np.nanmean(pf["landmark_errors"], axis=0)
    out = {"data": data.name, "seed": seed, "overrides": {k: list(v) if isinstance(v, tuple)
                                                          else v for k, v in overrides.items()},
           "mu": scores.mu_mm, "mmta": scores.mmta_pct, "per_frame": pf["mean_error"].tolist(),
           "per_joint": dict(zip(LANDMARK_NAMES, per_joint.tolist(), strict=True)),
           "seconds_per_frame": sec, "carve_seconds_per_frame": carve_s,
           "states": states.tolist()}
    args.out.mkdir(parents=True, exist_ok=True)
    tmp = cache.with_suffix(".tmp")
    tmp.write_text(json.dumps(out))
    tmp.replace(cache)
    return out


def quarters(per_frame) -> str:
    e = np.asarray(per_frame)
    return "→".join(f"{q.mean():.0f}" for q in np.array_split(e, 4))


def print_header() -> None:
    print(f"{'setting':34s} {'μ mm':>13s} {'MMTA %':>12s}  {'per quarter (mm)':22s} "
          f"{'worst landmarks (mm)':40s} {'s/frame':>7s}  μ per seed")


def print_table(rows: list[tuple[str, list[dict]]]) -> None:
    for name, runs in rows:
        mu = np.array([r["mu"] for r in runs])
        mm = np.array([r["mmta"] for r in runs])
        pf = np.mean([r["per_frame"] for r in runs], axis=0)
        pj = {k: np.mean([r["per_joint"][k] for r in runs]) for k in runs[0]["per_joint"]}
        worst = sorted(pj.items(), key=lambda kv: -kv[1])[:3]
        sec = np.mean([r["seconds_per_frame"] for r in runs])
        sd = f"±{mu.std(ddof=1):4.0f}" if len(runs) > 1 else "     "
        sdm = f"±{mm.std(ddof=1):3.0f}" if len(runs) > 1 else "    "
        print(f"{name:34s} {mu.mean():7.1f}{sd} {mm.mean():7.1f}{sdm}  {quarters(pf):22s} "
              f"{', '.join(f'{k} {v:.0f}' for k, v in worst):40s} {sec:7.2f}  "
              + " ".join(f"{m:.0f}" for m in mu))
    sys.stdout.flush()


# ------------------------------------------------------------------------------------ diagnosis
def diagnose(args, motion, overrides, seed):
    """Scores of the ground-truth pose vs the estimate, and renderer-vs-model joint offsets."""
    from voxelmocap.body import fit_to_landmarks
    from voxelmocap.joints import LANDMARK_NAMES, endpoints_to_landmarks
    from voxelmocap.score.likelihood import Measurement, log_likelihood_from_scores, part_scores

    config = make_config(overrides)
    data = dataset(args.data, motion, args.frames, args.cameras, args.data_seed)
    frames, occ, grid, _ = measurements(data, motion, config)
    _, gt, model = truth(data, motion)
    run = run_one(args, motion, overrides, seed)
    est_states = np.array(run["states"])
    var = config.likelihood.variances
    rows = gt.index_of(frames)
    print(f"diagnosis of {data.name}, setting {overrides or 'baseline'}, seed {seed}; "
          f"Σ = {var}")
    print("frame | fit offset mm | ll(GT fit) ll(est) | GT Σscores² out/do/empty/surf | "
          "est Σscores² out/do/empty/surf | err mm")
    offsets = []
    gt_better = 0
    for i, (f, o) in enumerate(zip(frames, occ, strict=True)):
        lm = endpoints_to_landmarks(gt.endpoints[rows[i]])
        x_gt = fit_to_landmarks(model, lm)
        off = np.linalg.norm(model.landmarks(x_gt[None])[0] - lm, axis=-1)
        offsets.append(off)
        m = Measurement(o, grid, sigma=config.measurement.surface_sigma)
        sc = part_scores(m, model, np.stack([x_gt, est_states[i]]), clip=True)
        ll = log_likelihood_from_scores(sc, variances=var)
        gt_better += ll[0] >= ll[1]
        terms = (sc ** 2).sum(axis=1)
        if i % args.every == 0 or i == len(frames) - 1:
            print(f"{f:5d} | {off.mean():6.1f} | {ll[0]:9.2f} {ll[1]:9.2f} | "
                  + " ".join(f"{t:.3f}" for t in terms[0]) + " | "
                  + " ".join(f"{t:.3f}" for t in terms[1]) + f" | {run['per_frame'][i]:.0f}")
    offsets = np.array(offsets)
    print(f"ground-truth pose scores at least as well as the estimate in {gt_better} of "
          f"{len(frames)} frames")
    print("renderer joints vs fitted model (mean over frames, mm): "
          + ", ".join(f"{n} {v:.0f}" for n, v in zip(LANDMARK_NAMES, offsets.mean(0),
                                                       strict=True)))
    # per-part scores of the GT pose in the first frame (constant model offsets, e.g. DO at joints)
    lm = endpoints_to_landmarks(gt.endpoints[rows[0]])
    x_gt = fit_to_landmarks(model, lm)
    m = Measurement(occ[0], grid, sigma=config.measurement.surface_sigma)
    sc = part_scores(m, model, x_gt[None], clip=True)[0]
    print("GT pose, frame 1, per part (out, do, empty, surf):")
    for name, s in zip(model.part_names, sc, strict=True):
        print(f"  {name:12s} " + " ".join(f"{v:.3f}" for v in s))


def check(args, motion):
    """Tracking the cached occupancies reproduces track_sequence (same estimates)."""
    import tempfile

    from voxelmocap.io.results import read_result
    from voxelmocap.run.pipeline import track_sequence

    config = make_config({})
    data = dataset(args.data, motion, args.frames, args.cameras, args.data_seed)
    frames, occ, grid, _ = measurements(data, motion, config)
    _, gt, model = truth(data, motion)
    n = min(5, len(frames))
    states, _, _ = track_cached(frames[:n], occ[:n], grid, gt, model, config, 0)
    with tempfile.TemporaryDirectory() as tmp:
        out = track_sequence(data, "S1", f"{ACTIONS[motion]}_1", tmp, config=config,
                             frames=f"{frames[0]}:{frames[n - 1]}", seed=0, progress=False,
                             log=lambda msg: None)
        ref = read_result(out.result_path).state
    diff = float(np.abs(ref - states).max())
    print(f"check: cached occupancies vs track_sequence, {n} frames: max |Δstate| = {diff:.3g}")
    if diff > 1e-9:
        raise SystemExit("tracking the cached occupancies does not reproduce track_sequence")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--data", type=Path, default=Path("/tmp/vmstudy_data"),
                   help="where rendered data sets and occupancy caches live")
    p.add_argument("--out", type=Path, default=Path("/tmp/vmstudy_runs"),
                   help="where per-run JSON results are cached")
    p.add_argument("--motion", default="walk", help="comma-separated: " + ", ".join(ACTIONS))
    p.add_argument("--frames", type=int, default=60)
    p.add_argument("--cameras", type=int, default=7, help="first N of " + ",".join(CAMERAS))
    p.add_argument("--data-seed", type=int, default=0, help="seed of the rendered data")
    p.add_argument("--settings", default="baseline", help="comma-separated names (see --list) "
                   "or 'key=value;key=value' ad-hoc overrides")
    p.add_argument("--seeds", default="0", help="comma-separated filter seeds")
    p.add_argument("--diagnose", action="store_true", help="ground truth vs estimate scores")
    p.add_argument("--every", type=int, default=6, help="--diagnose: print every N-th frame")
    p.add_argument("--check", action="store_true",
                   help="verify the cached tracking against track_sequence first")
    p.add_argument("--list", action="store_true", help="list the named settings")
    args = p.parse_args(argv)
    if args.list:
        for name, ov in SETTINGS.items():
            print(f"{name:30s} {ov}")
        return 0
    seeds = [int(s) for s in args.seeds.split(",")]
    settings = [s for s in args.settings.split(",") if s]
    print(f"# voxelmocap tracking study: {args.frames} frames, {args.cameras} cameras, "
          f"demo working point {DEMO}, seeds {seeds}")
    for motion in args.motion.split(","):
        if args.check:
            check(args, motion)
        if args.diagnose:
            for s in settings:
                diagnose(args, motion, parse_setting(s), seeds[0])
            continue
        print(f"\n## {motion}")
        print_header()
        for s in settings:
            print_table([(s, [run_one(args, motion, parse_setting(s), seed) for seed in seeds])])
    return 0


if __name__ == "__main__":
    sys.exit(main())
