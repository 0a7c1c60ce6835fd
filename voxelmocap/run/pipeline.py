"""Stage runners: from a HumanEva-layout sequence on disk to tracking results on disk.

:func:`track_sequence` runs the whole chain for one sequence: open it
(:class:`~voxelmocap.io.humaneva.Sequence`) → measure each frame (:class:`MeasurementRunner`:
background subtraction → carving → surface) → :meth:`BodyTracker.step
<voxelmocap.pose.tracker.BodyTracker.step>` (the annealed particle filter over the body model's
likelihood) → append the :class:`~voxelmocap.pose.tracker.FrameRecord` to the result → exports. It
writes

* ``RUN/<Subject>/<Action>_<Trial>.h5`` (:mod:`voxelmocap.io.results`), one frame appended and
  committed at a time together with the filter's checkpoint, so an interrupted run (even by
  ``kill -9``) can be resumed and continues exactly as an uninterrupted run with the same seed
  would; the file is locked while a run writes it;
* ``RUN/<Subject>/<Action>_<Trial>.xml``: the estimates as body_pose XML (``HUMANEVA.md`` §6);
* ``RUN/<Subject>/<Action>_<Trial>.bvh``: the tracked skeleton as BVH, at the sequence's frame
  rate (``Sequence.frame_rate``);
* the landmark exports of ``config.export`` (TRC and CSV by default, C3D on request;
  :mod:`voxelmocap.io.exports`, ``docs/outputs.md``).

Only this module, :mod:`voxelmocap.io` and the command line touch files.
"""

from __future__ import annotations

import dataclasses
import logging
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..config import TrackConfig, config_to_toml
from ..errors import InputError
from ..frames import parse_frame_range
from ..logs import emit, run_started

# Back-compatible names: the tracker owns the noise profile, the filter and the initialisation.
from ..pose.tracker import (
    BodyTracker,
    MultiStart,
    build_filter,
    ground_truth_landmarks,
    initial_state_from_voxels,
)
from ..pose.tracker import noise_profile as noise_std
from .measurement import MeasurementRunner  # re-export: it lived here

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

logger = logging.getLogger(__name__)


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
    export_paths: list = dataclasses.field(default_factory=list)  #: TRC / C3D / CSV written
    #: frames flagged without a person (not tracked; ``config.recovery``), in this run
    absent_frames: list = dataclasses.field(default_factory=list)
    #: ``(frame, note)`` of every re-initialisation in this run
    reinitialisations: list = dataclasses.field(default_factory=list)




def body_model_for(seq, gt=None):
    """The body model tracking uses for a sequence, and a phrase saying where it came from.

    The subject body file when the data set has one, else limb lengths measured from the ground
    truth, else the average adult.
    """
    from ..body import BodyModel

    if seq.body_file is not None:
        from ..io.body_file import read_body_file

        return (BodyModel(read_body_file(seq.body_file)),
                f"subject body file {seq.body_file.name}")
    if gt is not None and gt.enabled.all(axis=1).any():
        from ..joints import endpoints_to_landmarks

        valid = gt.enabled.all(axis=1)
        return BodyModel.from_landmarks(endpoints_to_landmarks(gt.endpoints[valid])), \
            "limb lengths measured from the ground truth"
    return BodyModel(), "average adult (no body file or ground truth)"


#: Plausible standing heights (mm). The voxels' vertical extent is the height of a standing
#: person; raised arms or a crouch in the first frame move it, and outside this range it is
#: more likely that than a person of that size.
HEIGHT_RANGE_MM = (1400.0, 2100.0)


def _voxel_height(observation, frame) -> float:
    """The first frame's standing height (mm) from its voxels (:mod:`voxelmocap.measure.detect`)."""
    from ..measure.detect import find_extremities

    ex = find_extremities(observation.occupancy, observation.grid, max_extremities=0)
    if ex is None:
        raise InputError(f"frame {int(frame)}", "no occupied voxel: cannot measure the body "
                                                "(is the person in view? is the background "
                                                "model right?)")
    return float(np.clip(ex.height_mm, *HEIGHT_RANGE_MM))


def _sized_model(height_mm: float, frame):
    from ..body import BodyModel

    where = "" if frame is None else f" of frame {int(frame)}"
    return (BodyModel.scaled(height_mm),
            f"average adult scaled to {height_mm:.0f} mm, the height of the voxels{where}")


def _result_paths(out_dir: Path, seq, folder: str = "") -> tuple[Path, Path, Path]:
    base = Path(out_dir) / seq.subject / folder / seq.name
    return base.with_suffix(".h5"), base.with_suffix(".xml"), base.with_suffix(".bvh")


def track_sequence(dataset_root, subject: str | None, sequence: str | None, out_dir, *,
                   config: TrackConfig | None = None, frames: str | None = None,
                   cameras=None, seed: int = 0, resume: bool = False, overwrite: bool = False,
                   progress: bool = True, log=None, fps: float | None = None,
                   recorder=None, trial: str | None = None, calibration=None,
                   masks=None, plate_from=None, cues_given: bool = False) -> TrackOutcome:
    """Track one sequence and write its results (see the module docstring).

    A run that learns its background plate from the sequence tracks it in passes
    (:func:`voxelmocap.run.passes.plate_passes`): each pass after the first learns the plate from
    the body the previous pass tracked, as ``plate_from`` does, and from ``[init]
    previous_pass_start`` on starts from that pass's body and pose (:func:`_continues`); the
    earlier passes' results go to ``RUN/<subject>/pass<k>/`` and are resumed like the final
    one.

    Parameters
    ----------
    dataset_root : str or os.PathLike
        HumanEva-layout data set, or a Pose2Sim / anipose / EasyMocap project
        (:func:`voxelmocap.io.sequence.open_sequence`).
    subject, sequence : str or None
        E.g. ``"S1"``, ``"Walking_1"`` (HumanEva layout; for a project either may name the trial).
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
    log : callable, optional
        Also receives every one-line message (they go to the ``voxelmocap.run.pipeline`` logger
        in any case; warnings prefixed ``warning:``).
    fps : float, optional
        Frame rate (Hz) of the BVH and the result file; default the sequence's own
        (``Sequence.frame_rate``: the video metadata, else HumanEva-I's 60 Hz).
    recorder : object, optional
        Sees the run (its last tracking pass) as it goes (e.g.
        :class:`voxelmocap.viz.rerun_recording.RerunRecorder`):
        ``recorder.start(seq, grid)`` once the measurement stage is built,
        ``recorder.observe(frame, images, observation)`` after each frame is measured, and
        ``recorder(record, tracker)`` for every frame tracked (a tracker observer; ``tracker``
        is None for the frames of the starts replayed after a multi-start chose one).
        Frames already done by a resumed run are not replayed to it.
    trial : str, optional
        Project trial (default: the only one). Results go to ``RUN/<trial>/<trial>.*``.
    calibration : str or os.PathLike, optional
        Project only: a calibration file instead of the project's own.
    masks : str or os.PathLike, optional
        A folder of person masks per camera (:class:`voxelmocap.io.masks.PersonMasks`): the
        silhouettes, instead of a background subtraction.
    plate_from : str or os.PathLike, optional
        A previous run (its folder or result file) of this sequence: a plate learnt from the
        sequence takes the body it tracked for the person (:func:`tracked_body`), which finds
        the background behind the person better than carving against a first plate does.
    cues_given : bool
        The cues were chosen (``--cues``): masks or a plate from a body do not select the
        silhouette cue (:func:`voxelmocap.run.passes.masks_defaults`; a config whose cues differ
        from the defaults counts as a choice too).
    """
    from ..io.masks import PersonMasks
    from ..io.sequence import open_sequence
    from .passes import MIN_BODY_FRAMES, final_config, masks_defaults, pass_folder, plate_passes

    def say(message: str, level: int = logging.INFO) -> None:
        emit(logger, log, message, level)

    config = config or TrackConfig()
    seq = open_sequence(dataset_root, subject, sequence, trial=trial, cameras=cameras,
                        calibration=calibration)
    _ = seq.rig  # reads the calibration and reconciles image sizes (notes below)
    for problem in seq.problems:  # cameras the data set has but this run cannot use
        say(problem, logging.WARNING)
    for note in seq.notes:  # what was assumed in reading a project
        say(f"note: {note}")
    if masks is not None and plate_from is not None:
        raise InputError("--plate-from", "not with --masks (given masks need no plate)")
    person_masks = None if masks is None else PersonMasks(masks, seq)
    gt = seq.ground_truth()
    selected = _select_frames(seq, gt, frames)
    passes = plate_passes(seq, config, masks=masks, plate_from=plate_from,
                          n_frames=len(selected))
    body_config, body_message = final_config(config, cues_given)
    message = None
    if masks is not None:
        config, message = masks_defaults(config, cues_given)
    elif plate_from is not None:
        config, message = body_config, body_message
    if message:
        say(f"note: {message}")
    common = dict(dataset_root=dataset_root, gt=gt, selected=selected, seed=seed,
                  progress=progress, log=log, fps=fps, say=say)
    final = _result_paths(Path(out_dir), seq)[0]
    if passes == 1:
        return _track_pass(seq, out_dir, config=config, resume=resume, overwrite=overwrite,
                           recorder=recorder, masks=masks, person_masks=person_masks,
                           plate_from=plate_from, **common)
    if final.exists():  # refused now, not after the first passes
        from ..io.results import check_not_being_written

        if not (resume or overwrite):
            raise InputError(final, "result exists; use --resume to continue it or --overwrite "
                                    "to replace it")
        check_not_being_written(final)    # another run is writing it
    first = config.init.previous_pass_start
    say(f"{passes} tracking passes (measurement.silhouette.plate_passes): the first learns the "
        "background plate by carving, each later one from the body the pass before tracked"
        + (f"; from pass {first} on a pass starts from the previous pass's body and pose "
           "(init.previous_pass_start)" if 0 < first <= passes else "")
        + (f"; {body_message}" if body_message else ""))
    # Every pass runs with the run's resume/overwrite: resuming, a complete pass only reads its
    # file; the passes are deterministic for a seed, so a pass tracked again is the same pass.
    # ``bodies`` counts the passes whose body the next pass learns from (a pass that saw the
    # person too rarely gives none: the next one then does what it did)
    previous, pass_config, bodies = None, config, 0
    for k in range(1, passes):
        folder = pass_folder(k)
        path = _result_paths(Path(out_dir), seq, folder)[0]
        say(f"tracking pass {k} of {passes} → {path}")
        _track_pass(seq, out_dir, folder=folder, config=pass_config, resume=resume,
                    overwrite=overwrite, recorder=None, masks=None, person_masks=None,
                    plate_from=previous, start_from_plate=_continues(config, bodies + 1),
                    **common)
        seen = _frames_with_person(path)
        if seen < MIN_BODY_FRAMES:
            say(f"warning: pass {k} saw the person in {seen} frame(s), fewer than the "
                f"{MIN_BODY_FRAMES} a plate from its body needs: the last pass tracks as it did")
            break
        previous, pass_config, bodies = path, body_config, k
    say(f"tracking pass {passes} of {passes} → {final}")
    return _track_pass(seq, out_dir, config=pass_config, resume=resume, overwrite=overwrite,
                       recorder=recorder, masks=None, person_masks=None, plate_from=previous,
                       start_from_plate=_continues(config, bodies + 1), **common)


def _continues(config, k: int) -> bool:
    """Whether the ``k``-th pass (counted along the bodies it learns from: after a pass that
    gave none, the next one counts as that one) starts from the previous pass's body and first
    pose (``[init] previous_pass_start``) rather than from the voxels."""
    first = config.init.previous_pass_start     # 0 (never) or >= 2: validated
    return first > 0 and k >= first


def _frames_with_person(path) -> int:
    """How many frames of a result saw the person (not flagged absent)."""
    from ..io.results import read_result

    result = read_result(path)
    return len(result) if result.observed is None else int(np.count_nonzero(result.observed))


def _track_pass(seq, out_dir, *, dataset_root, gt, selected, config, seed, resume, overwrite,
                progress, log, fps, recorder, masks, person_masks, plate_from, say,
                folder: str = "", start_from_plate: bool = False) -> TrackOutcome:
    """One tracking pass of ``seq`` (:func:`track_sequence`), its results under
    ``RUN/<subject>/<folder>/``. With ``start_from_plate`` the pass tracks with the body of
    ``plate_from`` and starts from its pose at the pass's first frame with the person (a pass
    continuing the previous one), not from the voxels — unless that frame starts from the
    ground truth, or the previous pass holds no pose there (then the start is searched from the
    voxels as usual, with that body, and the log says so)."""
    from ..io.results import ResultWriter

    plate_body = None if plate_from is None else tracked_body(plate_from, seq, gt)
    result_path, xml_path, bvh_path = _result_paths(Path(out_dir), seq, folder)
    model, model_source = body_model_for(seq, gt)
    # With neither a body file nor ground truth, the body is sized from the first frame's voxels
    # once they are measured (init.body = "voxels"); the tracker waits for it.
    size_from_voxels = (model_source.startswith("average")
                        and config.init.body in ("voxels", "fitted"))
    # init.body = "fitted": the lengths are fitted to the multi-start frames (voxelmocap.pose.body_size)
    fit_body = size_from_voxels and config.init.body == "fitted"
    fps = seq.frame_rate if fps is None else float(fps)
    if not (np.isfinite(fps) and fps > 0):
        raise InputError("fps", f"the frame rate must be a finite number > 0, got {fps!r}")
    if config.export.cutoff_hz is not None and config.export.formats:  # refuse before tracking
        from ..smoothing import check_filter

        check_filter(fps, config.export.cutoff_hz, config.export.order, "export.cutoff_hz")
    meta = {
        "config": config_to_toml(config), "seed": int(seed),
        "dataset": str(Path(dataset_root).resolve()),
        "subject": seq.subject, "action": seq.action, "trial": seq.trial,
        "cameras": ",".join(seq.camera_names), "body_model": model_source,
        "frames_requested": ",".join(str(int(f)) for f in selected), "frame_rate": fps,
        "person_masks": "" if masks is None else str(Path(masks).resolve()),
        "plate_from": "" if plate_body is None else plate_body.source,
    }
    continued = start_from_plate and plate_body is not None
    if continued:
        # The previous pass's body and its start: a later pass on a better plate would
        # otherwise search the start again, and may keep one facing backwards (the multi-start
        # judges 10 frames; the previous pass judged the whole sequence on its plate).
        from ..pose.body_size import dimensions_to_json

        model, model_source = plate_body.model, f"the body of {plate_body.source}"
        size_from_voxels = fit_body = False
        meta.update(body_model=model_source, body_height_mm=float(model.dimensions.height),
                    body_dimensions=dimensions_to_json(model.dimensions))
    tracker = None if size_from_voxels else BodyTracker(model, config, seed=seed)
    # Locks an existing result for the whole run (refused while another run writes it).
    with ResultWriter(result_path) as writer:
        previous = _previous_run(writer, meta, resume, overwrite)
        if previous is not None and previous.attrs["complete"]:
            say(f"{result_path} is already complete")
            if not (xml_path.exists() and bvh_path.exists()):  # interrupted after the h5
                _write_exports(xml_path, bvh_path, seq, gt, previous.frames, previous.endpoints,
                               fps)
            return TrackOutcome(result_path, xml_path, bvh_path, previous.frames,
                                str(previous.attrs.get("init_method")), len(previous),
                                float(np.mean(previous.seconds)),
                                _landmark_exports(result_path, config, previous))
        resumed_from = 0 if previous is None else len(previous)
        init_method = None
        if resumed_from:
            if tracker is None:  # the height measured by the interrupted run, as it used it
                height = float(previous.attrs["body_height_mm"])
                model, model_source = _sized_model(height, None)
                if "body_dimensions" in previous.attrs:  # a fitted body (init.body = "fitted")
                    model = _fitted_model(previous.attrs["body_dimensions"], result_path)
                    meta["body_dimensions"] = str(previous.attrs["body_dimensions"])
                meta["body_model"] = model_source = str(previous.attrs["body_model"])
                meta["body_height_mm"] = height
                tracker = BodyTracker(model, config, seed=seed)
            tracker.set_state(previous.checkpoint)
            init_method = str(previous.attrs.get("init_method"))
            say(f"resuming {seq.subject}/{seq.name} after frame {int(previous.frames[-1])} "
                f"({resumed_from} of {len(selected)} done)")

        stage = MeasurementRunner(seq, config, log=log, person_masks=person_masks,
                                  plate_body=plate_body)
        say(f"{seq.subject}/{seq.name}: {len(selected)} frames, cameras "
            f"{','.join(seq.camera_names)}, grid {stage.grid.shape} at "
            f"{stage.grid.voxel_size:g} mm, {config.filter.layers} layers × "
            f"{config.filter.particles} particles ({config.filter.strategy}); body: {model_source}")
        if resumed_from and stage.adaptive:
            # MOG2 learnt from frames 1..k before the interruption; replay them so that the
            # resumed run sees the same background model as an uninterrupted one.
            for _, images in seq.frames(selected[:resumed_from]):
                stage.masks(images)
        done = {"frames": [], "endpoints": [], "seconds": [], "observed": [], "absent": [],
                "notes": []}
        if previous is not None:
            for key in ("frames", "endpoints", "seconds"):
                done[key].extend(getattr(previous, key))
            done["observed"].extend(np.ones(len(previous), bool) if previous.observed is None
                                    else previous.observed)
        if not _kernels_cached():
            say("compiling the likelihood kernels (first run only, ~20 s)…")
        logger.debug("result %s, frames %s, seed %d, frame rate %g Hz", result_path,
                     meta["frames_requested"], seed, fps)
        if recorder is not None:
            recorder.start(seq, stage.grid)
        bar = _progress(len(selected), resumed_from, progress,
                        f"{seq.subject}/{seq.name}" + (f" ({folder})" if folder else ""))
        starts = None  # a MultiStart while its first frames run
        start_observations = []  # its frames' measurements, when the body is fitted on them
        waiting = []  # flagged records of the frames without a person before the start
        try:
            for frame_number, images in seq.frames(selected[resumed_from:]):
                t0 = time.perf_counter()
                measurement = stage.measure(images, frame=frame_number)
                if recorder is not None:
                    recorder.observe(frame_number, images, measurement)
                if (config.recovery.enabled and starts is None
                        and (tracker is None or not tracker.initialised)
                        and not _starts_from_ground_truth(config, gt, frame_number)
                        and _absent(measurement, model, config)):
                    # Nobody in view yet: flagged, nothing to start from (a ground-truth start
                    # needs no voxels; the tracker then flags the frame). Written with the
                    # first tracked frame (whose body size the file's attributes record),
                    # without a checkpoint: a run killed before that starts again.
                    waiting.append(_absent_record(model, measurement, frame_number, config,
                                                  time.perf_counter() - t0))
                    if bar is not None:
                        bar.update(1)
                    continue
                if tracker is None:
                    model, model_source = _sized_model(_voxel_height(measurement, frame_number),
                                                       frame_number)
                    meta["body_model"] = model_source
                    meta["body_height_mm"] = float(model.dimensions.height)
                    say(f"body: {model_source}")
                    tracker = BodyTracker(model, config, seed=seed)
                if (continued and not tracker.initialised and starts is None
                        and not _starts_from_ground_truth(config, gt, frame_number)):
                    # (a start from the ground truth, when the run has it, stays exact)
                    if frame_number in plate_body.frames:
                        k = int(np.searchsorted(plate_body.frames, frame_number))
                        phrase = f"the pose of {plate_body.source} at frame {frame_number}"
                        state = plate_body.states[k]
                        if config.init.limb_sweep:
                            # The arms only, on this pass's better silhouettes: a start whose arm
                            # the previous pass had wrong keeps it for frames otherwise; the legs
                            # searched too lost the demo's standing leg (docs/benchmarks.md)
                            swept, moved = tracker.searched_starts(measurement, state[None],
                                                                   limbs=CONTINUED_SEARCH)
                            state = swept[0]
                            phrase += f"; arms searched over their ranges ({moved} moved)"
                        init_method = tracker.start(phrase, state)
                        say(f"initialised from {init_method}")
                    else:
                        say(f"note: {plate_body.source} has no pose at frame {frame_number}: "
                            "the start is searched from the voxels, with its body")
                    continued = False
                if not tracker.initialised and starts is None:
                    init_method, states = tracker.initial_state(
                        measurement, ground_truth_landmarks(gt, frame_number), frame=frame_number)
                    n_multi = config.init.multistart_frames
                    if n_multi > 0 and np.ndim(states) == 2 and len(states) > 1:
                        starts = MultiStart(model, config, seed, states, n_multi)
                    else:
                        tracker.start(init_method, states)
                    say(f"initialised from {init_method}")
                if starts is not None:
                    # Nothing is written until the start is chosen: a run killed before that
                    # simply starts again.
                    records = starts.step(measurement, frame=frame_number)
                    if fit_body:
                        start_observations.append(measurement)
                    if bar is not None:
                        bar.update(1)
                    if records is None:
                        continue
                    tracker, chosen_phrase = _chosen(starts, say)
                    init_method += chosen_phrase
                    checkpoints, starts = starts.checkpoints[starts.chosen], None
                    if fit_body:
                        tracker, records, checkpoints, model = _fit_body(
                            tracker, start_observations, records, config, seed, meta, say)
                        start_observations = []
                    _replay(recorder, records)
                else:
                    # The file's seconds are the whole frame's: measurement, start and filter.
                    if recorder is not None and recorder not in tracker.observers:
                        tracker.observers.append(recorder)
                    record = (tracker.observe(measurement, frame=frame_number)
                              if config.recovery.enabled
                              else tracker.step(measurement, frame=frame_number))
                    records = [dataclasses.replace(record, seconds=time.perf_counter() - t0)]
                    checkpoints = [None]
                    if bar is not None:
                        bar.update(1)
                records = waiting + list(records)
                checkpoints = [_NO_CHECKPOINT] * len(waiting) + list(checkpoints)
                waiting = []
                _append(writer, records, checkpoints, tracker, done, len(selected), previous,
                        dict(meta, init_method=init_method), model, resume or overwrite, bar)
            if starts is not None:  # the sequence ended before the start was chosen
                starts.finish()
                tracker, chosen_phrase = _chosen(starts, say)
                records, checkpoints = (starts.records[starts.chosen],
                                        starts.checkpoints[starts.chosen])
                if fit_body:
                    tracker, records, checkpoints, model = _fit_body(
                        tracker, start_observations, records, config, seed, meta, say)
                _replay(recorder, records)
                init_method += chosen_phrase
                _append(writer, waiting + records,
                        [_NO_CHECKPOINT] * len(waiting) + checkpoints,
                        tracker, done, len(selected), previous,
                        dict(meta, init_method=init_method), model, resume or overwrite, bar)
                waiting = []
            if waiting:  # nobody in view in any frame
                _append(writer, waiting, [_NO_CHECKPOINT] * len(waiting), tracker, done,
                        len(selected), previous, dict(meta, init_method=init_method), model,
                        resume or overwrite, bar)
        finally:
            if bar is not None:
                bar.close()

    frames_done = np.array(done["frames"])
    _write_exports(xml_path, bvh_path, seq, gt, frames_done, np.array(done["endpoints"]), fps,
                   np.array(done["observed"], bool))
    for frame, note in done["notes"]:
        say(f"frame {frame}: {note}")
    if done["absent"]:
        say(f"{len(done['absent'])} frame(s) flagged without a person (not tracked, skipped by "
            f"'voxelmocap evaluate'): {_frame_list(done['absent'])}")
    return TrackOutcome(result_path, xml_path, bvh_path, frames_done, init_method,
                        resumed_from, float(np.mean(done["seconds"])),
                        _landmark_exports(result_path, config), done["absent"], done["notes"])


def _starts_from_ground_truth(config, gt, frame) -> bool:
    """Whether ``BodyTracker.initial_state`` would start this frame from the ground truth."""
    return (config.init.method in ("ground_truth", "auto")
            and ground_truth_landmarks(gt, frame) is not None)


def _absent(measurement, model, config) -> bool:
    """Whether a frame has no person (``voxelmocap.pose.recovery.person_presence``)."""
    from ..body import BodyModel
    from ..pose.recovery import person_presence

    return not person_presence(measurement.occupancy, measurement.grid, model or BodyModel(),
                               min_share=config.recovery.min_volume_share).present


def _absent_record(model, measurement, frame, config, seconds):
    """The flagged record of a frame without a person before the track started."""
    from ..body import BodyModel
    from ..pose.tracker import absent_record, annealing_layers

    model = model or BodyModel()
    return absent_record(model, measurement, model.default_state(), frame=frame,
                         n_layers=annealing_layers(config),
                         variances=config.likelihood.variances, seconds=seconds)


def _frame_list(frames, n: int = 10) -> str:
    shown = ", ".join(str(int(f)) for f in frames[:n])
    return shown + (f" … ({len(frames) - n} more)" if len(frames) > n else "")


#: ``_append``: this record has no filter state to store (flagged before the track started)
_NO_CHECKPOINT = object()


def _replay(recorder, records) -> None:
    """The kept start's first records to the recorder (their particles are gone: no tracker)."""
    if recorder is not None:
        for record in records:
            recorder(record, None)


def _fit_body(tracker, observations, records, config, seed, meta, say):
    """``voxelmocap.pose.body_size.refit_start`` on the chosen start's frames; the new tracker, its
    records and checkpoints of those frames, and the fitted model (``meta`` records it)."""
    from ..pose.body_size import dimensions_to_json, refit_start

    t0 = time.perf_counter()
    tracker, records, checkpoints, fit = refit_start(tracker, observations, records, config,
                                                     seed)
    seconds = time.perf_counter() - t0
    dims = fit.dimensions
    meta["body_model"] = (f"{meta['body_model']}; lengths fitted to {len(records)} frames "
                          f"(height {dims.height:.0f} mm; summed log-likelihood of "
                          f"{len(fit.states)} frames {fit.start_log_likelihood:.1f} → "
                          f"{fit.log_likelihood:.1f})")
    meta["body_height_mm"] = float(dims.height)
    meta["body_dimensions"] = dimensions_to_json(dims)
    say(f"body: {meta['body_model']} (fit and re-tracking: {seconds:.1f} s)")
    return tracker, records, checkpoints, tracker.model


def _fitted_model(text, path):
    """The body of a result file's ``body_dimensions`` attribute."""
    from ..body import BodyModel
    from ..pose.body_size import dimensions_from_json

    return BodyModel(dimensions_from_json(text, source=f"{path}: body_dimensions"))


def _chosen(starts, say) -> tuple[BodyTracker, str]:
    """The kept start's tracker (``starts`` has chosen) and the phrase for ``init_method``."""
    n_frames, n_starts = len(starts.records[0]), len(starts.trackers)
    say(f"kept start {starts.chosen + 1} of {n_starts} after {n_frames} frames (summed "
        f"log-likelihoods {', '.join(f'{t:.1f}' for t in starts.totals)})")
    return starts.tracker, f"; the likeliest of {n_starts} starts after {n_frames} frames"


def _append(writer, records, checkpoints, tracker, done, n_selected, previous, attrs, model,
            replace, bar) -> None:
    """Write records, each with the filter state after its frame (None: the tracker's now;
    ``_NO_CHECKPOINT``: none)."""
    for record, checkpoint in zip(records, checkpoints, strict=True):
        if not writer.started:
            writer.start(record, attrs=attrs, state_names=model.state_names,
                         part_names=model.part_names, previous=previous, replace=replace)
            run_started()  # the result exists: the run's log file is written from now on
        for key, value in (("frames", record.frame), ("endpoints", record.endpoints),
                           ("seconds", record.seconds), ("observed", record.observed)):
            done[key].append(value)
        if not record.observed:
            done["absent"].append(int(record.frame))
        if record.note and record.observed:
            done["notes"].append((int(record.frame), record.note))
        if checkpoint is _NO_CHECKPOINT:
            checkpoint = None
        elif checkpoint is None:
            checkpoint = tracker.get_state()
        writer.append(record, checkpoint, complete=len(done["frames"]) == n_selected)
        logger.debug("frame %d: log-likelihood %.2f, ESS per layer %s, %.3f s", record.frame,
                     record.log_likelihood, " ".join(f"{e:.0f}" for e in record.ess),
                     record.seconds)
    if bar is not None and tracker is not None and tracker.initialised:
        bar.set_postfix(loglik=f"{tracker.filter.mean_log_likelihood:.2f}",
                        fps=f"{1.0 / max(records[-1].seconds, 1e-9):.2f}")


def _select_frames(seq, gt, frames: str | None) -> np.ndarray:
    """The frames to track: ``frames`` parsed, else every frame with ground truth, else all."""
    available = seq.frame_numbers
    if frames is not None:
        selected = parse_frame_range(frames, available)
    elif gt is not None and len(np.intersect1d(available, gt.frames)):
        selected = np.intersect1d(available, gt.frames)
    else:
        selected = available
    if len(selected) == 0:
        raise InputError(f"{seq.subject}/{seq.name}", "no frames to track")
    return selected


#: the limbs a pass continuing the previous one searches on its first frame (``init.limb_sweep``)
CONTINUED_SEARCH = ("l_arm", "r_arm")
#: Attributes a resumed run must share with the file it continues.
_RESUME_KEYS = ("config", "seed", "subject", "action", "trial", "cameras", "frames_requested",
                "person_masks", "plate_from")


def result_body_model(seq, result, gt=None):
    """The body model a result was tracked with, as its file records it.

    A run without body file or ground truth sizes the body itself; the result file records how
    (``body_dimensions``: every length, JSON, when they were fitted; ``body_height_mm``: the
    average adult scaled to that height). Drawing :func:`~voxelmocap.run.pipeline.body_model_for`'s
    unscaled average adult instead would show cones the tracker never used.

    Parameters
    ----------
    seq : Sequence
        The tracked sequence (its body file, when the result used one).
    result : voxelmocap.io.results.Result
        The result read back (its ``attrs``).
    gt : GroundTruth, optional
        The sequence's ground truth.

    Returns
    -------
    BodyModel
    """
    import json

    from ..body import BodyDimensions, BodyModel

    attrs = result.attrs
    if attrs.get("body_dimensions"):
        try:
            data = json.loads(str(attrs["body_dimensions"]))
            return BodyModel(BodyDimensions(**{
                k: tuple(float(x) for x in v) if isinstance(v, list) else float(v)
                for k, v in data.items()}))
        except (ValueError, TypeError) as exc:
            raise InputError("result", f"body_dimensions is not a body's dimensions ({exc})") \
                from None
    height = attrs.get("body_height_mm")
    if height is not None and str(attrs.get("body_model", "")).startswith("average adult scaled"):
        return BodyModel.scaled(float(height))
    return body_model_for(seq, gt)[0]


def tracked_body(run, seq, gt=None):
    """The body a previous run tracked in ``seq``: its model and states where it saw the person.

    Parameters
    ----------
    run : str or os.PathLike
        The run folder (its result of ``seq`` is ``RUN/<subject>/<name>.h5``) or the result file.
    seq : Sequence
        The sequence about to be tracked.
    gt : GroundTruth, optional
        Its ground truth: a run that measured its body on it recorded no dimensions.

    Returns
    -------
    voxelmocap.pose.body_cover.TrackedBody

    Raises
    ------
    InputError
        No such result, a result of another sequence, or fewer than 2 frames with the person.
    """
    from ..io.results import read_result
    from ..pose.body_cover import TrackedBody

    run = Path(run)
    path = run if run.is_file() or run.suffix == ".h5" else _result_paths(run, seq)[0]
    if not path.is_file() and (run / path.name).is_file():   # a pass folder: RUN/<trial>/pass1
        path = run / path.name
    if not path.is_file():
        raise InputError(path, f"no result of {seq.subject}/{seq.name} here (--plate-from takes a "
                               "run folder of this sequence or its .h5 result)")
    result = read_result(path)
    for key, mine in (("subject", seq.subject), ("action", seq.action), ("trial", seq.trial)):
        theirs = result.attrs.get(key)
        if theirs is not None and str(theirs) != str(mine):
            raise InputError(path, f"a result of {key} {theirs!r}, not of this run's {mine!r}")
    keep = np.asarray(result.observed, bool) & np.isin(result.frames, seq.frame_numbers)
    if keep.sum() < 2:
        raise InputError(path, f"{int(keep.sum())} frame(s) of this sequence with the person "
                               "tracked: a plate needs at least 2")
    try:
        model = result_body_model(seq, result, gt)
    except InputError as exc:
        raise InputError(path, exc.problem) from None
    states = np.asarray(result.state, float)
    if states.ndim != 2 or states.shape[1] != model.n_dims:
        raise InputError(path, f"states of {states.shape[-1]} parameters, the body model has "
                               f"{model.n_dims}")
    frames = np.asarray(result.frames)[keep]
    order = np.argsort(frames)
    return TrackedBody(model, frames[order], states[keep][order], str(path.resolve()))


def _previous_run(writer, meta: dict, resume: bool, overwrite: bool):
    """The result a run continues (None for a fresh start), after checking it may.

    Raises
    ------
    InputError
        The result exists and neither ``resume`` nor ``overwrite`` is set, or it was made with
        other settings, or it has frames but no checkpoint.
    """
    path = writer.path
    previous = writer.read_existing() if path.exists() else None
    if previous is None:
        return None
    if not resume and not overwrite:
        raise InputError(path, "result exists; use --resume to continue it or --overwrite to "
                               "replace it")
    if not resume:
        return None
    for key in _RESUME_KEYS:
        # a result written before masks could be given was made without them
        old = previous.attrs.get(key, "" if key in ("person_masks", "plate_from") else None)
        new = meta[key]
        if key == "config":  # the [export] table is not tracking: a resumed run may change it
            old, new = _tracking_config(old), _tracking_config(new)
        if str(old) != str(new):
            raise InputError(path, f"cannot resume: its {key} differs from this run's "
                                   "(use --overwrite to start again)")
    if len(previous) and previous.checkpoint is None:
        if previous.observed is not None and not previous.observed.any():
            return None  # only frames without a person, before any start: start again
        raise InputError(path, "cannot resume: the file has no checkpoint")
    return previous if len(previous) else None  # killed before its first frame: start afresh


def _tracking_config(text) -> str:
    """A stored config's TOML without its ``[export]`` table (unparsable text: unchanged)."""
    from ..io.toml import dumps_toml, parse_toml

    try:
        data = parse_toml(str(text), "config")
    except InputError:
        return str(text)
    data.pop("export", None)
    return dumps_toml(data)


def _kernels_cached() -> bool:
    """Whether numba's on-disk cache holds the likelihood kernel (else the first frame compiles).

    Looks at the dispatcher's cache index without importing numba here; any surprise in numba's
    internals counts as cached (the message is a courtesy).
    """
    from ..score import _raster_kernels

    try:
        kernel = _raster_kernels.part_counts
        if kernel.signatures:  # compiled in this process already
            return True
        return Path(kernel._cache._cache_file._index_path).exists()
    except AttributeError:
        return True


def _write_exports(xml_path, bvh_path, seq, gt, frames, endpoints, fps, observed=None) -> None:
    """The body_pose XML (HUMANEVA.md §6) and the BVH of tracked poses.

    Frames flagged without a person (``observed`` False) have every endpoint disabled in the
    XML; the BVH holds the repeated last estimate there (a BVH has no flags).
    """
    from ..io.body_pose_xml import write_body_pose_xml
    from ..io.bvh_writer import write_landmarks_bvh
    from ..joints import endpoints_to_landmarks

    source = gt.attributes if gt is not None else {}
    attributes = {"DatasetName": source.get("DatasetName", "HumanEvaI"),
                  "DatasetBasePath": source.get("DatasetBasePath", "../"),
                  "SubjectName": seq.subject, "ActionType": seq.action, "Trial": seq.trial,
                  "FrameStart": int(frames[0]), "FrameEnd": int(frames[-1]),
                  "Partition": source.get("Partition", "Validate")}
    enabled = None if observed is None else np.repeat(np.asarray(observed, bool)[:, None], 20,
                                                      axis=1)
    write_body_pose_xml(xml_path, frames, endpoints, enabled, attributes=attributes)
    write_landmarks_bvh(bvh_path, endpoints_to_landmarks(endpoints), fps)


def _landmark_exports(result_path, config: TrackConfig, result=None) -> list[Path]:
    """The TRC / C3D / CSV files of ``config.export``, from the finished result file."""
    from ..io.exports import export_result

    ex = config.export
    return export_result(result_path, ex.formats, cutoff_hz=ex.cutoff_hz, order=ex.order,
                         axes=ex.axes, result=result)


def _progress(total: int, initial: int, enabled: bool, desc: str):
    if not enabled:
        return None
    from tqdm.auto import tqdm

    return tqdm(total=total, initial=initial, desc=desc, unit="frame", dynamic_ncols=True)
