"""One tracking pass over a sequence's frames: measure, start, track, write — frame by frame.

:class:`PassRun` is the loop of one :class:`~voxelmocap.run.plan.PassPlan`. Per frame it measures
the images (:class:`~voxelmocap.run.measurement.MeasurementRunner`), then, until the track has
started, decides what to do with the frame:

1. nobody in view yet (``[recovery]``): a flagged record waits for the first tracked frame;
2. no body yet (no body file, no ground truth): the average adult sized from the voxels;
3. a pass continuing the previous one: its body and its pose at this frame (arms searched again);
4. otherwise the start the tracker searches (ground truth, voxels, a multi-start whose first
   frames are tracked side by side before one is kept, and the body fitted on them);

after that every frame is one :meth:`BodyTracker.observe <voxelmocap.pose.tracker.BodyTracker.observe>`.
Each record is appended to the result with the filter's checkpoint
(:class:`~voxelmocap.io.results.ResultWriter`), so the pass resumes exactly after a kill.
"""

from __future__ import annotations

import dataclasses
import logging
import time
from pathlib import Path

import numpy as np

from ..config import config_to_toml
from ..errors import InputError
from ..logs import run_started
from ..pose.filter_setup import REFERENCE_RATE
from ..pose.multistart import MultiStart
from ..pose.starts import ground_truth_landmarks
from ..pose.tracker import BodyTracker
from .bodies import body_model_for, dimensions_json, model_from_attrs, sized_model, voxel_height
from .outputs import frame_list, kernels_cached, landmark_exports, write_exports
from .plan import CONTINUED_SEARCH
from .request import TrackOutcome
from .resume import previous_run

__all__ = ["PassRun"]

logger = logging.getLogger(__name__)

#: a record with no filter state to store (flagged before the track started)
_NO_CHECKPOINT = object()


class PassRun:
    """One pass of a run (see the module docstring).

    Parameters
    ----------
    request : TrackRequest
    seq : Sequence
        The opened sequence.
    gt : GroundTruth or None
    selected : (F,) int ndarray
        The frames to track.
    plan : PassPlan
        Its config, folder and start.
    plate_body : TrackedBody or None
        The body a previous pass (or ``--plate-from``) tracked: the plate's cover, and with
        ``plan.continues`` the body and first pose of this pass.
    say : callable
        ``say(message, level)`` for the run's log.
    """

    def __init__(self, request, seq, gt, selected, plan, plate_body, say):
        self.request, self.seq, self.gt, self.selected = request, seq, gt, selected
        self.config = plan.config
        self.folder = plan.folder
        self.plate_body = plate_body
        self.say = say
        self.paths = request.result_paths(seq, self.folder)
        self.model, self.model_source = body_model_for(seq, gt)
        # With neither a body file nor ground truth, the body is sized from the first frame's
        # voxels once they are measured (init.body = "voxels"); the tracker waits for it, and
        # with init.body = "fitted" its lengths are fitted to the multi-start frames.
        self.size_from_voxels = (self.model_source.startswith("average")
                                 and self.config.init.body in ("voxels", "fitted"))
        self.fit_body = self.size_from_voxels and self.config.init.body == "fitted"
        fps = seq.frame_rate if request.fps is None else float(request.fps)
        if not (np.isfinite(fps) and fps > 0):
            raise InputError("fps", f"the frame rate must be a finite number > 0, got {fps!r}")
        self.fps = fps
        # The filter's noise follows the frame rate the data state; an assumed one (image
        # folders stating none) would change the search on a guess: the noise stays per frame
        self.noise_rate = (REFERENCE_RATE if request.fps is None
                           and getattr(seq, "frame_rate_assumed", False) else fps)
        ex = self.config.export
        if ex.cutoff_hz is not None and ex.formats:  # refuse before tracking
            from ..smoothing import check_filter

            check_filter(fps, ex.cutoff_hz, ex.order, "export.cutoff_hz")
        self.meta = {
            "config": config_to_toml(self.config), "seed": int(request.seed),
            "dataset": str(Path(request.dataset_root).resolve()),
            "subject": seq.subject, "action": seq.action, "trial": seq.trial,
            "cameras": ",".join(seq.camera_names), "body_model": self.model_source,
            "frames_requested": ",".join(str(int(f)) for f in selected), "frame_rate": fps,
            "person_masks": "" if request.masks is None else str(Path(request.masks).resolve()),
            "plate_from": "" if plate_body is None else plate_body.source,
        }
        #: the start still to take from the previous pass (cleared once decided)
        self.continued = plan.continues and plate_body is not None
        if self.continued:
            # The previous pass's body and its start: a later pass on a better plate would
            # otherwise search the start again, and may keep one facing backwards (the
            # multi-start judges 10 frames; the previous pass judged the whole sequence).
            self.model, self.model_source = plate_body.model, f"the body of {plate_body.source}"
            self.size_from_voxels = self.fit_body = False
            self.meta.update(body_model=self.model_source,
                             body_height_mm=float(self.model.dimensions.height),
                             body_dimensions=dimensions_json(self.model))
        self.tracker = None if self.size_from_voxels else BodyTracker(
            self.model, self.config, seed=request.seed, frame_rate=self.noise_rate)
        self.init_method = None
        self.starts = None              # a MultiStart while its first frames run
        self.start_observations = []    # its frames' measurements, when the body is fitted
        self.waiting = []               # flagged records of frames without a person, pre-start
        self.done = {"frames": [], "endpoints": [], "states": [], "seconds": [], "observed": [],
                     "absent": [], "notes": []}
        self.writer = self.previous = self.bar = None

    # ------------------------------------------------------------------ the pass
    def run(self, person_masks=None) -> TrackOutcome:
        """Track the pass's frames (resuming or skipping what its result already holds)."""
        from ..io.results import ResultWriter
        from .measurement import MeasurementRunner

        request, seq = self.request, self.seq
        result_path = self.paths[0]
        # Locks an existing result for the whole run (refused while another run writes it).
        with ResultWriter(result_path) as writer:
            self.writer = writer
            previous = previous_run(writer, self.meta, request.resume, request.overwrite)
            if previous is not None and previous.attrs["complete"]:
                return self._complete(previous)
            resumed_from = 0 if previous is None else len(previous)
            if resumed_from:
                self._resume(previous)
            self.previous = previous
            stage = MeasurementRunner(seq, self.config, log=request.log,
                                      person_masks=person_masks, plate_body=self.plate_body)
            fc = self.config.filter
            self.say(f"{seq.subject}/{seq.name}: {len(self.selected)} frames, cameras "
                     f"{','.join(seq.camera_names)}, grid {stage.grid.shape} at "
                     f"{stage.grid.voxel_size:g} mm, {fc.layers} layers × {fc.particles} "
                     f"particles ({fc.strategy}); body: {self.model_source}")
            if resumed_from and stage.adaptive:
                # MOG2 learnt from frames 1..k before the interruption; replay them so that the
                # resumed run sees the same background model as an uninterrupted one.
                for _, images in seq.frames(self.selected[:resumed_from]):
                    stage.masks(images)
            if not kernels_cached():
                self.say("compiling the likelihood kernels (first run only, ~20 s)…")
            logger.debug("result %s, frames %s, seed %d, frame rate %g Hz", result_path,
                         self.meta["frames_requested"], request.seed, self.fps)
            recorder = request.recorder if self.folder == "" else None
            if recorder is not None:
                recorder.start(seq, stage.grid)
            self.bar = _progress(len(self.selected), resumed_from, request.progress,
                                 f"{seq.subject}/{seq.name}"
                                 + (f" ({self.folder})" if self.folder else ""))
            try:
                for frame_number, images in seq.frames(self.selected[resumed_from:]):
                    t0 = time.perf_counter()
                    measurement = stage.measure(images, frame=frame_number)
                    if recorder is not None:
                        recorder.observe(frame_number, images, measurement)
                    self._frame(measurement, frame_number, t0, recorder)
                self._end(recorder)
            finally:
                if self.bar is not None:
                    self.bar.close()
        return self._finished(resumed_from)

    def _complete(self, previous) -> TrackOutcome:
        """The outcome of a result that is already complete (its exports mended if missing)."""
        result_path, xml_path, bvh_path = self.paths
        self.say(f"{result_path} is already complete")
        if not (xml_path.exists() and bvh_path.exists()):  # interrupted after the h5
            write_exports(xml_path, bvh_path, self.seq, self.gt, previous.frames,
                          previous.endpoints, self.fps)
        return TrackOutcome(result_path, xml_path, bvh_path, previous.frames,
                            str(previous.attrs.get("init_method")), len(previous),
                            float(np.mean(previous.seconds)),
                            landmark_exports(result_path, self.config, previous),
                            tracked=self._tracked(previous.frames, previous.state,
                                                  previous.observed, previous.attrs),
                            frames_with_person=_with_person(previous.observed, len(previous)))

    def _resume(self, previous) -> None:
        """Continue from the filter state of an interrupted result."""
        if self.tracker is None:  # the body measured by the interrupted run, as it used it
            attrs = previous.attrs
            height = float(attrs["body_height_mm"])
            self.model, _ = sized_model(height, None)
            if "body_dimensions" in attrs:  # a fitted body (init.body = "fitted")
                self.model = model_from_attrs(attrs, self.seq, self.gt,
                                              source=f"{self.paths[0]}: body_dimensions")
                self.meta["body_dimensions"] = str(attrs["body_dimensions"])
            self.meta["body_model"] = self.model_source = str(attrs["body_model"])
            self.meta["body_height_mm"] = height
            self.tracker = BodyTracker(self.model, self.config, seed=self.request.seed,
                                   frame_rate=self.noise_rate)
        self.tracker.set_state(previous.checkpoint)
        self.init_method = str(previous.attrs.get("init_method"))
        for key, name in (("frames", "frames"), ("endpoints", "endpoints"),
                          ("states", "state"), ("seconds", "seconds")):
            self.done[key].extend(getattr(previous, name))
        self.done["observed"].extend(np.ones(len(previous), bool) if previous.observed is None
                                     else previous.observed)
        self.say(f"resuming {self.seq.subject}/{self.seq.name} after frame "
                 f"{int(previous.frames[-1])} ({len(previous)} of {len(self.selected)} done)")

    # ------------------------------------------------------------------ one frame
    def _frame(self, measurement, frame_number, t0, recorder) -> None:
        config, tracker = self.config, self.tracker
        starting = tracker is None or not tracker.initialised
        if (config.recovery.enabled and self.starts is None and starting
                and not self._starts_from_ground_truth(frame_number)
                and _absent(measurement, self.model, config)):
            # Nobody in view yet: flagged, nothing to start from (a ground-truth start needs no
            # voxels; the tracker then flags the frame). Written with the first tracked frame
            # (whose body size the file's attributes record), without a checkpoint: a run
            # killed before that starts again.
            self.waiting.append(_absent_record(self.model, measurement, frame_number, config,
                                               time.perf_counter() - t0))
            self._tick()
            return
        if self.tracker is None:
            self._size_body(measurement, frame_number)
        if self.continued and not self.tracker.initialised and self.starts is None \
                and not self._starts_from_ground_truth(frame_number):
            # (a start from the ground truth, when the run has it, stays exact)
            self._continue_start(measurement, frame_number)
        if not self.tracker.initialised and self.starts is None:
            self._search_start(measurement, frame_number)
        if self.starts is not None:
            # Nothing is written until the start is chosen: a run killed before that simply
            # starts again.
            records = self.starts.step(measurement, frame=frame_number)
            if self.fit_body:
                self.start_observations.append(measurement)
            self._tick()
            if records is None:
                return
            records, checkpoints = self._keep_start(recorder)
        else:
            # The file's seconds are the whole frame's: measurement, start and filter.
            tracker = self.tracker
            if recorder is not None and recorder not in tracker.observers:
                tracker.observers.append(recorder)
            record = (tracker.observe(measurement, frame=frame_number)
                      if config.recovery.enabled else tracker.step(measurement, frame=frame_number))
            records = [dataclasses.replace(record, seconds=time.perf_counter() - t0)]
            checkpoints = [None]
            self._tick()
        self._append(records, checkpoints)

    def _size_body(self, measurement, frame_number) -> None:
        """The average adult scaled to this frame's voxels (no body file, no ground truth)."""
        self.model, self.model_source = sized_model(voxel_height(measurement, frame_number),
                                                    frame_number)
        self.meta["body_model"] = self.model_source
        self.meta["body_height_mm"] = float(self.model.dimensions.height)
        self.say(f"body: {self.model_source}")
        self.tracker = BodyTracker(self.model, self.config, seed=self.request.seed,
                                   frame_rate=self.noise_rate)

    def _continue_start(self, measurement, frame_number) -> None:
        """Start from the previous pass's pose at this frame (its arms searched again)."""
        body = self.plate_body
        state = body.state_at(frame_number)
        if state is not None:
            phrase = f"the pose of {body.source} at frame {frame_number}"
            if self.config.init.limb_sweep:
                # The arms only, on this pass's better silhouettes: a start whose arm the
                # previous pass had wrong keeps it for frames otherwise; the legs searched too
                # lost the demo's standing leg (docs/benchmarks.md)
                swept, moved = self.tracker.searched_starts(measurement, state[None],
                                                            limbs=CONTINUED_SEARCH)
                state = swept[0]
                phrase += f"; arms searched over their ranges ({moved} moved)"
            self.init_method = self.tracker.start(phrase, state)
            self.say(f"initialised from {self.init_method}")
        else:
            self.say(f"note: {body.source} has no pose at frame {frame_number}: the start is "
                     "searched from the voxels, with its body")
        self.continued = False

    def _search_start(self, measurement, frame_number) -> None:
        """The tracker's own start: the ground truth, or hypotheses from the voxels (several
        of them tracked side by side first: ``[init] multistart_frames``)."""
        self.init_method, states = self.tracker.initial_state(
            measurement, ground_truth_landmarks(self.gt, frame_number), frame=frame_number)
        n_multi = self.config.init.multistart_frames
        if n_multi > 0 and np.ndim(states) == 2 and len(states) > 1:
            states = self._with_previous_pose(measurement, frame_number, states)
            self.starts = MultiStart(self.model, self.config, self.request.seed, states, n_multi,
                                     frame_rate=self.noise_rate)
        else:
            self.tracker.start(self.init_method, states)
        self.say(f"initialised from {self.init_method}")

    def _with_previous_pose(self, measurement, frame_number, states):
        """The starts plus the previous pass's pose at this frame, its four limbs searched again
        (``[init] previous_pass_hypothesis``): a pass that searches its start from the voxels
        can otherwise lose a facing the pass before had right (docs/benchmarks.md, seed 4),
        while the likelihood of the frames that follow prefers it."""
        body = self.plate_body
        state = None if body is None else body.state_at(frame_number)
        if state is None or not self.config.init.previous_pass_hypothesis:
            return states
        if self.config.init.limb_sweep:
            state = self.tracker.searched_starts(measurement, state[None])[0][0]
        self.init_method += f" and the pose of {body.source} at frame {frame_number}"
        return np.concatenate([states, state[None]])

    def _keep_start(self, recorder):
        """The multi-start has chosen: its tracker goes on, its records and checkpoints are
        written (after the body is fitted on its frames, ``init.body = "fitted"``)."""
        starts = self.starts
        n_frames, n_starts = len(starts.records[0]), len(starts.trackers)
        self.say(f"kept start {starts.chosen + 1} of {n_starts} after {n_frames} frames (summed "
                 f"log-likelihoods {', '.join(f'{t:.1f}' for t in starts.totals)})")
        self.tracker = starts.tracker
        self.init_method += f"; the likeliest of {n_starts} starts after {n_frames} frames"
        records, checkpoints = starts.records[starts.chosen], starts.checkpoints[starts.chosen]
        self.starts = None
        if self.fit_body:
            records, checkpoints = self._fit_body(records)
            self.start_observations = []
        if recorder is not None:  # the kept start's first records (their particles are gone)
            for record in records:
                recorder(record, None)
        return records, checkpoints

    def _fit_body(self, records):
        """:func:`voxelmocap.pose.body_size.refit_start` on the kept start's frames: the new
        tracker, its records and checkpoints of those frames (``meta`` records the body)."""
        from ..pose.body_size import dimensions_to_json, refit_start

        t0 = time.perf_counter()
        tracker, records, checkpoints, fit = refit_start(
            self.tracker, self.start_observations, records, self.config, self.request.seed)
        seconds = time.perf_counter() - t0
        dims = fit.dimensions
        meta = self.meta
        height = f"height {dims.height:.0f} mm"
        if fit.other is not None:   # frame 1's voxel height and the poses' both tried
            height += (f", the better of fits at {dims.height:.0f} and "
                       f"{fit.other.dimensions.height:.0f} mm: {fit.log_likelihood:.1f} against "
                       f"{fit.other.log_likelihood:.1f}")
        meta["body_model"] = (f"{meta['body_model']}; lengths fitted to {len(records)} frames "
                              f"({height}; summed log-likelihood of "
                              f"{len(fit.states)} frames {fit.start_log_likelihood:.1f} → "
                              f"{fit.log_likelihood:.1f})")
        meta["body_height_mm"] = float(dims.height)
        meta["body_dimensions"] = dimensions_to_json(dims)
        self.say(f"body: {meta['body_model']} (fit and re-tracking: {seconds:.1f} s)")
        self.tracker, self.model = tracker, tracker.model
        return records, checkpoints

    def _end(self, recorder) -> None:
        """After the last frame: a multi-start still running chooses now; flagged frames that
        never met a tracked one are written."""
        if self.starts is not None:  # the sequence ended before the start was chosen
            self.starts.finish()
            records, checkpoints = self._keep_start(recorder)
            self._append(records, checkpoints)
        if self.waiting:  # nobody in view in any frame
            self._append([], [])

    # ------------------------------------------------------------------ writing
    def _append(self, records, checkpoints) -> None:
        """Write the waiting flagged records, then ``records``, each with the filter state after
        its frame (None: the tracker's now; ``_NO_CHECKPOINT``: none)."""
        records = self.waiting + list(records)
        checkpoints = [_NO_CHECKPOINT] * len(self.waiting) + list(checkpoints)
        self.waiting = []
        writer, done, tracker = self.writer, self.done, self.tracker
        request = self.request
        attrs = dict(self.meta, init_method=self.init_method)
        for record, checkpoint in zip(records, checkpoints, strict=True):
            if not writer.started:
                writer.start(record, attrs=attrs, state_names=self.model.state_names,
                             part_names=self.model.part_names, previous=self.previous,
                             replace=request.resume or request.overwrite)
                run_started()  # the result exists: the run's log file is written from now on
            for key, value in (("frames", record.frame), ("endpoints", record.endpoints),
                               ("states", record.state), ("seconds", record.seconds),
                               ("observed", record.observed)):
                done[key].append(value)
            if not record.observed:
                done["absent"].append(int(record.frame))
            if record.note and record.observed:
                done["notes"].append((int(record.frame), record.note))
            if checkpoint is _NO_CHECKPOINT:
                checkpoint = None
            elif checkpoint is None:
                checkpoint = tracker.get_state()
            writer.append(record, checkpoint,
                          complete=len(done["frames"]) == len(self.selected))
            logger.debug("frame %d: log-likelihood %.2f, ESS per layer %s, %.3f s", record.frame,
                         record.log_likelihood, " ".join(f"{e:.0f}" for e in record.ess),
                         record.seconds)
        if self.bar is not None and tracker is not None and tracker.initialised and records:
            self.bar.set_postfix(loglik=f"{tracker.filter.mean_log_likelihood:.2f}",
                                 fps=f"{1.0 / max(records[-1].seconds, 1e-9):.2f}")

    def _finished(self, resumed_from) -> TrackOutcome:
        """The exports, the closing messages and the outcome (with the body for a next pass)."""
        result_path, xml_path, bvh_path = self.paths
        done = self.done
        frames_done = np.array(done["frames"])
        observed = np.array(done["observed"], bool)
        write_exports(xml_path, bvh_path, self.seq, self.gt, frames_done,
                      np.array(done["endpoints"]), self.fps, observed)
        for frame, note in done["notes"]:
            self.say(f"frame {frame}: {note}")
        if done["absent"]:
            self.say(f"{len(done['absent'])} frame(s) flagged without a person (not tracked, "
                     f"skipped by 'voxelmocap evaluate'): {frame_list(done['absent'])}")
        return TrackOutcome(result_path, xml_path, bvh_path, frames_done, self.init_method,
                            resumed_from, float(np.mean(done["seconds"])),
                            landmark_exports(result_path, self.config), done["absent"],
                            done["notes"],
                            tracked=self._tracked(frames_done, np.array(done["states"]),
                                                  observed, self.meta),
                            frames_with_person=int(np.count_nonzero(observed)))

    def _tracked(self, frames, states, observed, attrs):
        """The body this pass tracked, for the next pass (None with fewer than 2 frames)."""
        from .bodies import tracked_in_memory

        try:
            model = model_from_attrs(attrs, self.seq, self.gt)
            return tracked_in_memory(model, frames, states, observed, self.seq, self.paths[0])
        except InputError:
            return None

    # ------------------------------------------------------------------ helpers
    def _starts_from_ground_truth(self, frame) -> bool:
        """Whether ``BodyTracker.initial_state`` would start this frame from the ground truth."""
        return (self.config.init.method in ("ground_truth", "auto")
                and ground_truth_landmarks(self.gt, frame) is not None)

    def _tick(self) -> None:
        if self.bar is not None:
            self.bar.update(1)


def _with_person(observed, n: int) -> int:
    return n if observed is None else int(np.count_nonzero(observed))


def _absent(measurement, model, config) -> bool:
    """Whether a frame has no person (``voxelmocap.pose.recovery.person_presence``)."""
    from ..body import BodyModel
    from ..pose.recovery import person_presence

    return not person_presence(measurement.occupancy, measurement.grid, model or BodyModel(),
                               min_share=config.recovery.min_volume_share).present


def _absent_record(model, measurement, frame, config, seconds):
    """The flagged record of a frame without a person before the track started."""
    from ..body import BodyModel
    from ..pose.filter_setup import annealing_layers
    from ..pose.records import absent_record

    model = model or BodyModel()
    return absent_record(model, measurement, model.default_state(), frame=frame,
                         n_layers=annealing_layers(config),
                         variances=config.likelihood.variances, seconds=seconds)


def _progress(total: int, initial: int, enabled: bool, desc: str):
    if not enabled:
        return None
    from tqdm.auto import tqdm

    return tqdm(total=total, initial=initial, desc=desc, unit="frame", dynamic_ncols=True)
