"""Stage runners: from a HumanEva-layout sequence on disk to tracking results on disk.

:func:`track_sequence` runs the whole chain for one sequence (decode → background subtraction →
carving → surface → annealed particle filter over the body model's likelihood) and writes

* ``RUN/<Subject>/<Action>_<Trial>.h5`` (:mod:`voxelmocap.io.results`), replaced atomically after
  every frame together with the filter's checkpoint, so an interrupted run can be resumed and
  continues exactly as an uninterrupted run with the same seed would;
* ``RUN/<Subject>/<Action>_<Trial>.xml``: the estimates as body_pose XML (``HUMANEVA.md`` §6);
* ``RUN/<Subject>/<Action>_<Trial>.bvh``: the tracked skeleton as BVH.

Only this module, :mod:`voxelmocap.io` and the command line touch files.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .config import TrackConfig, config_to_toml
from .errors import InputError
from .frames import parse_frame_range
from .measurement_runner import MeasurementRunner  # re-export: it lived here

__all__ = [
    "MeasurementRunner",
    "TrackOutcome",
    "body_model_for",
    "build_filter",
    "initial_state_from_voxels",
    "noise_std",
    "parse_frame_range",
    "track_sequence",
]


@dataclass
class TrackOutcome:
    """What :func:`track_sequence` produced."""

    result_path: Path
    xml_path: Path
    bvh_path: Path
    frames: np.ndarray
    init_method: str
    resumed_from: int  #: frames already done when the run started (0 for a fresh run)
    seconds_per_frame: float


#: Trunk angles that get the root rotation's noise, not the limbs' (see :func:`noise_std`).
_TRUNK_ANGLES = ("waist_flex", "waist_side", "waist_twist", "neck_flex", "neck_side")


def noise_std(model, config: TrackConfig) -> np.ndarray:
    """(27,) per-frame propagation noise (mm, rad): translation, root rotation and joint groups.

    The root, waist and neck angles get ``rotation_std_rad``; shoulders, elbows, hips and knees
    ``joint_std_rad``. The trunk moves as slowly as the root, and the pelvis orientation is nearly
    unobservable (no part spans the pelvis), so a compensating root pitch + waist flexion + hip
    flexion change costs almost nothing in the likelihood. With the limbs' larger noise on the
    waist the filter random-walked along that direction (root pitch −40°, waist +44° after 6
    frames of a walk) and lost the legs. Measured with ``scripts/study_tracking.py`` (synthetic,
    7 cameras, 6 × 300 particles, ``joint_std_rad`` 0.1): trunk on the limbs' noise → on the
    root's: walk μ 58 → 59 mm (5 seeds, no change), jog 67 → 60 mm, box 68 → 56 mm (3 seeds);
    ``docs/benchmarks.md``, tracking accuracy study.
    """
    fc = config.filter
    std = np.full(model.n_dims, fc.joint_std_rad)
    std[:3] = fc.translation_std_mm
    std[3:6] = fc.rotation_std_rad
    names = list(model.state_names)
    std[[names.index(n) for n in _TRUNK_ANGLES]] = fc.rotation_std_rad
    return std


def build_filter(model, config: TrackConfig, rng):
    """The annealed particle filter of a config, over the body model's legal ranges."""
    from .tracking import AnnealedParticleFilter, RandomWalk, TwoStateElbow, VelocityModel

    fc = config.filter
    names = list(model.state_names)
    # Angles that wrap (heading) get no velocity drift across the ±π seam problems; all others do.
    if fc.dynamics == "random_walk":
        dynamics = RandomWalk()
    elif fc.dynamics == "velocity":
        dynamics = VelocityModel(0.7)
    else:
        dynamics = TwoStateElbow(
            [names.index("l_shoulder_rot"), names.index("r_shoulder_rot")],
            [names.index("l_elbow"), names.index("r_elbow")], factor=0.7)
    return AnnealedParticleFilter(
        fc.particles, fc.layers, model.low, model.high, noise_std(model, config),
        strategy=fc.strategy, rng=rng, survival=fc.survival, noise_decay=fc.noise_decay,
        dynamics=dynamics)


def body_model_for(seq, gt=None):
    """The body model tracking uses for a sequence, and a phrase saying where it came from.

    The subject body file when the data set has one, else limb lengths measured from the ground
    truth, else the average adult.
    """
    from .body import BodyModel

    if seq.body_file is not None:
        from .io.body_file import read_body_file

        return (BodyModel(read_body_file(seq.body_file)),
                f"subject body file {seq.body_file.name}")
    if gt is not None and gt.enabled.all(axis=1).any():
        from .joints import endpoints_to_landmarks

        valid = gt.enabled.all(axis=1)
        return BodyModel.from_landmarks(endpoints_to_landmarks(gt.endpoints[valid])), \
            "limb lengths measured from the ground truth"
    return BodyModel(), "average adult (no body file or ground truth)"


def initial_state_from_voxels(measurement, model, variances, *, n_yaw: int = 36) -> np.ndarray:
    """A standing pose at the voxel blob's centroid, facing the best of ``n_yaw`` headings.

    Raises
    ------
    InputError
        When the first frame has no occupied voxel.
    """
    from .likelihood import log_likelihood

    occ = measurement.occupancy
    idx = np.argwhere(occ)
    if len(idx) == 0:
        raise InputError("first frame", "no occupied voxel: cannot initialise from the voxels")
    centre = measurement.grid.centre_of(idx).mean(axis=0)
    base = model.default_state()
    base[0], base[1] = centre[0], centre[1]
    yaw_i = list(model.state_names).index("root_yaw")
    candidates = np.repeat(base[None], n_yaw, axis=0)
    candidates[:, yaw_i] = np.linspace(-np.pi, np.pi, n_yaw, endpoint=False)
    scores = log_likelihood(measurement, model, candidates, variances=variances)
    return candidates[int(np.argmax(scores))]


def _result_paths(out_dir: Path, seq) -> tuple[Path, Path, Path]:
    base = Path(out_dir) / seq.subject / seq.name
    return base.with_suffix(".h5"), base.with_suffix(".xml"), base.with_suffix(".bvh")


def track_sequence(dataset_root, subject: str, sequence: str, out_dir, *,
                   config: TrackConfig | None = None, frames: str | None = None,
                   cameras=None, seed: int = 0, resume: bool = False, overwrite: bool = False,
                   progress: bool = True, log=print, fps: float = 60.0) -> TrackOutcome:
    """Track one sequence and write its results (see the module docstring).

    Parameters
    ----------
    dataset_root : str or os.PathLike
        HumanEva-layout data set.
    subject, sequence : str
        E.g. ``"S1"``, ``"Walking_1"``.
    out_dir : str or os.PathLike
        The run folder ``RUN``.
    config : TrackConfig, optional
        Pipeline settings (defaults: the paper's working point).
    frames : str, optional
        ``"a:b"`` synchronised frames (default: every frame with ground truth, or every frame).
    cameras : list of str, optional
        Cameras to use (default: all with sync files).
    seed : int
        Seed of the filter's random generator.
    resume : bool
        Continue an interrupted run from its last completed frame (config, seed, frames and
        cameras must match).
    overwrite : bool
        Replace an existing result instead of refusing.
    progress : bool
        Show a progress bar.
    log : callable
        Where one-line messages go.
    fps : float
        Frame rate written to the BVH.
    """
    from .body import fit_to_landmarks
    from .io.humaneva import Dataset
    from .io.results import TrackResult, read_result, write_result
    from .likelihood import log_likelihood, log_likelihood_from_scores, part_scores

    config = config or TrackConfig()
    seq = Dataset(dataset_root).sequence(subject, sequence, cameras=cameras)
    for problem in seq.problems:  # cameras the data set has but this run cannot use
        log(f"warning: {problem}")
    gt = seq.ground_truth()
    available = seq.frame_numbers
    if gt is not None:
        with_gt = np.intersect1d(available, gt.frames)
        default = with_gt if len(with_gt) else available
    else:
        default = available
    if frames is None:
        selected = default
    else:
        selected = parse_frame_range(frames, available)
    if len(selected) == 0:
        raise InputError(f"{seq.subject}/{seq.name}", "no frames to track")
    result_path, xml_path, bvh_path = _result_paths(Path(out_dir), seq)
    config_text = config_to_toml(config)
    model, model_source = body_model_for(seq, gt)
    variances = config.likelihood.variances

    meta = {
        "config": config_text, "seed": int(seed), "dataset": str(Path(dataset_root).resolve()),
        "subject": seq.subject, "action": seq.action, "trial": seq.trial,
        "cameras": ",".join(seq.camera_names), "body_model": model_source,
        "frames_requested": ",".join(str(int(f)) for f in selected),
    }
    rng = np.random.default_rng(seed)
    pf = build_filter(model, config, rng)
    done: dict[str, list] = {k: [] for k in ("frames", "state", "landmarks", "endpoints",
                                             "part_scores", "ess", "betas", "seconds",
                                             "log_likelihood", "map_state")}
    resumed_from = 0
    init_method = None
    if result_path.exists():
        if not resume and not overwrite:
            raise InputError(result_path, "result exists; use --resume to continue it or "
                                          "--overwrite to replace it")
        if resume:
            previous = read_result(result_path)
            for key in ("config", "seed", "subject", "action", "trial", "cameras",
                        "frames_requested"):
                if str(previous.attrs.get(key)) != str(meta[key]):
                    raise InputError(result_path, f"cannot resume: its {key} differs from this "
                                                  "run's (use --overwrite to start again)")
            if previous.checkpoint is None:
                raise InputError(result_path, "cannot resume: the file has no checkpoint")
            if bool(previous.attrs.get("complete")):
                log(f"{result_path} is already complete")
                if not (xml_path.exists() and bvh_path.exists()):  # interrupted after the h5
                    _write_exports(xml_path, bvh_path, seq, gt, previous.frames,
                                   previous.endpoints, fps)
                return TrackOutcome(result_path, xml_path, bvh_path, previous.frames,
                                    str(previous.attrs.get("init_method")), len(previous),
                                    float(np.mean(previous.seconds)))
            pf.set_state(previous.checkpoint)
            for key in done:
                done[key] = list(getattr(previous, key))
            resumed_from = len(previous)
            init_method = str(previous.attrs.get("init_method"))
            log(f"resuming {seq.subject}/{seq.name} after frame {int(previous.frames[-1])} "
                f"({resumed_from} of {len(selected)} done)")

    stage = MeasurementRunner(seq, config, log=log)
    log(f"{seq.subject}/{seq.name}: {len(selected)} frames, cameras "
        f"{','.join(seq.camera_names)}, grid {stage.grid.shape} at {stage.grid.voxel_size:g} mm, "
        f"{config.filter.layers} layers × {config.filter.particles} particles "
        f"({config.filter.strategy}); body: {model_source}")

    if resumed_from and stage.adaptive:
        # MOG2 learnt from frames 1..k before the interruption; replay them so that the resumed
        # run sees the same background model as an uninterrupted one.
        for _, images in seq.frames(selected[:resumed_from]):
            stage.stage.masks(images)
    todo = selected[resumed_from:]
    bar = _progress(len(selected), resumed_from, progress, f"{seq.subject}/{seq.name}")
    try:
        for frame_number, images in seq.frames(todo):
            t0 = time.perf_counter()
            measurement = stage.measure(images)
            if pf.particles is None:
                init_method, mean = _initial_state(config, gt, frame_number, model,
                                                   measurement, variances, fit_to_landmarks)
                spread = config.init.spread * noise_std(model, config)
                pf.initialise(mean, spread)
                log(f"initialised from {init_method}")

            def ll(states, measurement=measurement):
                return log_likelihood(measurement, model, states, variances=variances)

            estimate = pf.step(ll)
            est = model.clip(estimate[None])
            done["frames"].append(int(frame_number))
            done["state"].append(est[0])
            done["landmarks"].append(model.landmarks(est)[0])
            done["endpoints"].append(model.endpoints(est)[0])
            scores = part_scores(measurement, model, est)[0]
            done["part_scores"].append(scores)
            done["ess"].append(np.asarray(pf.layer_ess, dtype=float))
            done["betas"].append(np.asarray(pf.layer_betas, dtype=float))
            done["log_likelihood"].append(
                float(log_likelihood_from_scores(scores, variances=variances)))
            done["map_state"].append(np.asarray(pf.map_particle, dtype=float))
            done["seconds"].append(time.perf_counter() - t0)
            attrs = dict(meta, init_method=init_method,
                         complete=len(done["frames"]) == len(selected))
            write_result(result_path, _stack(done, model, attrs, pf.get_state(), TrackResult))
            if bar is not None:
                bar.set_postfix(loglik=f"{pf.mean_log_likelihood:.2f}",
                                fps=f"{1.0 / max(done['seconds'][-1], 1e-9):.2f}")
                bar.update(1)
    finally:
        if bar is not None:
            bar.close()

    _write_exports(xml_path, bvh_path, seq, gt, np.array(done["frames"]),
                   np.array(done["endpoints"]), fps)
    return TrackOutcome(result_path, xml_path, bvh_path, np.array(done["frames"]), init_method,
                        resumed_from, float(np.mean(done["seconds"])))


def _write_exports(xml_path, bvh_path, seq, gt, frames, endpoints, fps) -> None:
    """The body_pose XML (HUMANEVA.md §6) and the BVH of tracked poses."""
    from .io.body_pose_xml import write_body_pose_xml
    from .io.bvh_writer import write_landmarks_bvh
    from .joints import endpoints_to_landmarks

    source = gt.attributes if gt is not None else {}
    attributes = {"DatasetName": source.get("DatasetName", "HumanEvaI"),
                  "DatasetBasePath": source.get("DatasetBasePath", "../"),
                  "SubjectName": seq.subject, "ActionType": seq.action, "Trial": seq.trial,
                  "FrameStart": int(frames[0]), "FrameEnd": int(frames[-1]),
                  "Partition": source.get("Partition", "Validate")}
    write_body_pose_xml(xml_path, frames, endpoints, attributes=attributes)
    write_landmarks_bvh(bvh_path, endpoints_to_landmarks(endpoints), fps)


def _initial_state(config, gt, frame_number, model, measurement, variances, fit_to_landmarks):
    from .joints import endpoints_to_landmarks

    method = config.init.method
    row = -1 if gt is None else int(gt.index_of([frame_number])[0])
    has_gt = row >= 0 and bool(gt.enabled[row].all())
    if method == "ground_truth" and not has_gt:
        raise InputError("init.method", f"ground truth of frame {frame_number} is not available")
    if method == "ground_truth" or (method == "auto" and has_gt):
        landmarks = endpoints_to_landmarks(gt.endpoints[row])
        return f"the ground truth of frame {frame_number}", fit_to_landmarks(model, landmarks)
    return (f"the voxels of frame {frame_number} (centroid + yaw search)",
            initial_state_from_voxels(measurement, model, variances))


def _stack(done, model, attrs, checkpoint, result_cls):
    return result_cls(
        frames=np.array(done["frames"], dtype=int),
        state=np.array(done["state"]), landmarks=np.array(done["landmarks"]),
        endpoints=np.array(done["endpoints"]), part_scores=np.array(done["part_scores"]),
        ess=np.array(done["ess"]), betas=np.array(done["betas"]),
        seconds=np.array(done["seconds"]), log_likelihood=np.array(done["log_likelihood"]),
        map_state=np.array(done["map_state"]), state_names=list(model.state_names),
        part_names=[p.name for p in model.parts], attrs=attrs, checkpoint=checkpoint)


def _progress(total: int, initial: int, enabled: bool, desc: str):
    if not enabled:
        return None
    from tqdm.auto import tqdm

    return tqdm(total=total, initial=initial, desc=desc, unit="frame", dynamic_ncols=True)
