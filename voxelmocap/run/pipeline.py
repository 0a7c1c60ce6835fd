"""``voxelmocap track``: from a sequence on disk to tracking results on disk.

:func:`track_sequence` opens the sequence (:func:`voxelmocap.io.sequence.open_sequence`), builds
the run's plan (:func:`voxelmocap.run.plan.plan_passes`: how many passes, where each one's plate
and start come from), logs it, and runs it: one :class:`~voxelmocap.run.frame_loop.PassRun` per
pass, each handing the next the body it tracked, in memory. Each pass writes

* ``RUN/<Subject>/[pass<k>/]<Action>_<Trial>.h5`` (:mod:`voxelmocap.io.results`), one frame
  appended and committed at a time together with the filter's checkpoint, so an interrupted run
  (even by ``kill -9``) resumes exactly; the file is locked while a run writes it;
* ``….xml``: the estimates as body_pose XML (``HUMANEVA.md`` §6); ``….bvh``: the tracked
  skeleton at the sequence's frame rate;
* the landmark exports of ``config.export`` (TRC and CSV by default, C3D on request;
  :mod:`voxelmocap.io.exports`, ``docs/outputs.md``).

The last pass's results are the run's (``RUN/<Subject>/<Action>_<Trial>.*``). A pass that gives
no body to learn the next plate from (the person in fewer than ``MIN_BODY_FRAMES`` frames), or
whose plate found the person in fewer than ``LOST_SHARE`` of the frames the pass before did,
ends the passes: the last pass repeats that pass, or the one before.
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..frames import parse_frame_range
from ..logs import emit
from .request import TrackOutcome, TrackRequest

__all__ = ["TrackOutcome", "TrackRequest", "track", "track_sequence"]

logger = logging.getLogger(__name__)


def track_sequence(dataset_root, subject: str | None, sequence: str | None, out_dir,
                   **options) -> TrackOutcome:
    """Track one sequence and write its results (see the module docstring).

    Parameters
    ----------
    dataset_root : str or os.PathLike
        HumanEva-layout data set, or a Pose2Sim / anipose / EasyMocap project.
    subject, sequence : str or None
        E.g. ``"S1"``, ``"Walking_1"`` (for a project either may name the trial).
    out_dir : str or os.PathLike
        The run folder ``RUN``.
    **options
        The other fields of :class:`~voxelmocap.run.request.TrackRequest` (``config``,
        ``frames``, ``cameras``, ``seed``, ``resume``, ``overwrite``, ``progress``, ``log``,
        ``fps``, ``recorder``, ``trial``, ``calibration``, ``masks``, ``plate_from``,
        ``cues_given``).

    Returns
    -------
    TrackOutcome
        Of the last pass.
    """
    return track(TrackRequest(dataset_root, subject, sequence, out_dir, **options))


def track(request: TrackRequest) -> TrackOutcome:
    """Run a :class:`TrackRequest`: open, plan, run the passes (see the module docstring)."""
    from ..io.masks import PersonMasks
    from ..io.sequence import open_sequence
    from ..io.working_size import AtMostSide, at_most_side
    from .bodies import tracked_body
    from .frame_loop import PassRun
    from .memory import release_freed_memory, resident_mib
    from .plan import LOST_SHARE, MIN_BODY_FRAMES, plan_passes

    def say(message: str, level: int = logging.INFO) -> None:
        emit(logger, request.log, message, level)

    seq = open_sequence(request.dataset_root, request.subject, request.sequence,
                        trial=request.trial, cameras=request.cameras,
                        calibration=request.calibration)
    _ = seq.rig  # reads the calibration and reconciles image sizes (notes below)
    for problem in seq.problems:  # cameras the data set has but this run cannot use
        say(problem, logging.WARNING)
    for note in seq.notes:  # what was assumed in reading a project
        say(f"note: {note}")
    seq = at_most_side(seq, request.config.measurement.max_image_side)
    if isinstance(seq, AtMostSide):
        say(seq.summary)
    if request.masks is not None and request.plate_from is not None:
        raise InputError("--plate-from", "not with --masks (given masks need no plate)")
    person_masks = None if request.masks is None else PersonMasks(request.masks, seq)
    gt = seq.ground_truth()
    selected = _select_frames(seq, gt, request.frames)
    plan = plan_passes(seq, request.config, masks=request.masks,
                       plate_from=request.plate_from, n_frames=len(selected),
                       cues_given=request.cues_given)
    for line in plan.describe():
        say(line)
    passes = plan.passes
    final = request.result_paths(seq)[0]
    if len(passes) > 1 and final.exists():  # refused now, not after the first passes
        from ..io.results import check_not_being_written

        if not (request.resume or request.overwrite):
            raise InputError(final, "result exists; use --resume to continue it or --overwrite "
                                    "to replace it")
        check_not_being_written(final)    # another run is writing it
    body = None if request.plate_from is None else tracked_body(request.plate_from, seq, gt)
    # Every pass runs with the run's resume/overwrite: resuming, a complete pass only reads its
    # file; the passes are deterministic for a seed, so a pass tracked again is the same pass.
    k = 0
    before = None                 # the pass before: (plan, the body it learnt from, frames seen)
    while True:
        p = passes[k]
        if len(passes) > 1:
            say(f"tracking pass {p.number} of {p.of} → {request.result_paths(seq, p.folder)[0]}")
        # What the pass before (or the sequence before, in a batch) freed goes back to the
        # system before this pass's plate learning takes its frames: the run's peak memory
        # otherwise holds both (.memory)
        resident = resident_mib()
        if release_freed_memory() and resident is not None:
            say(f"memory before pass {p.number}: {resident:.0f} MiB resident, "
                f"{resident_mib():.0f} MiB once the freed memory was returned", logging.DEBUG)
        outcome = PassRun(request, seq, gt, selected, p, body, say).run(person_masks)
        if p.last:
            return outcome
        seen = outcome.frames_with_person
        if seen < MIN_BODY_FRAMES or outcome.tracked is None:
            # No body to learn the next plate from: the last pass repeats this one.
            say(f"warning: pass {p.number} saw the person in {seen} frame(s), fewer than the "
                f"{MIN_BODY_FRAMES} a plate from its body needs: the last pass tracks as it did")
            passes = passes[:k + 1] + (p.as_last(),)
        elif before is not None and seen < LOST_SHARE * before[2]:
            # Its plate, learnt around the previous body, lost the person where the previous
            # plate had them: that body was a poor cover, and a plate around this one's would
            # be worse. The last pass repeats the pass before.
            plan_before, body_before, seen_before = before
            say(f"warning: pass {p.number} saw the person in {seen} frame(s), pass "
                f"{plan_before.number} in {seen_before}: the last pass tracks as pass "
                f"{plan_before.number} did")
            passes = passes[:k + 1] + (plan_before.as_last(),)
            body = body_before
        else:
            before = (p, body, seen)
            body = outcome.tracked
        k += 1


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


def result_paths(out_dir, seq, folder: str = "") -> tuple[Path, Path, Path]:
    """``(h5, xml, bvh)`` of ``seq`` under ``RUN/<subject>/<folder>/``."""
    return TrackRequest(None, None, None, out_dir).result_paths(seq, folder)
