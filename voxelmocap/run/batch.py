"""Batch tracking: every sequence of a data set or project, as Dask tasks, finished ones skipped.

``voxelmocap track DATASET --all --out RUN`` plans one :class:`BatchItem` per sequence
(:func:`dataset_items`: on the HumanEva-I layout every subject's sequences that have videos; in a
Pose2Sim, anipose, EasyMocap or FreeMoCap project every trial, Pose2Sim's ``exclude_from_batch``
left out, each with its own cascading ``Config.toml``), drops those whose result
``RUN/<Subject>/<Action>_<Trial>.h5`` (a project's: ``RUN/<trial>/<trial>.h5``) is complete and
was made with the same configuration and seed (:func:`result_is_done`), and runs the rest through
:func:`voxelmocap.run.tasks.run_tasks` —
the engine ``voxelmocap sweep`` uses — on a Dask cluster (``scheduler``), a local cluster of
``n_workers`` processes, or one after another in this process. Each task is
:func:`track_item`: :func:`voxelmocap.run.pipeline.track_sequence` with ``resume=True``, so an
interrupted sequence continues where it stopped. A failing sequence is recorded with its
one-line reason and the others go on; :class:`BatchSummary` says what was done, skipped and
failed.

Items are plain (subject, sequence) pairs — a project's trial is (trial, trial), as
:func:`voxelmocap.io.sequence.open_sequence` names it — so every layout runs through one loop.

>>> summary = run_batch(BatchRequest("data", "run"), n_workers=2)   # doctest: +SKIP
>>> summary.describe()                                           # doctest: +SKIP
'3 done, 0 skipped, 0 failed'
"""

from __future__ import annotations

import dataclasses
import logging
import time
from dataclasses import dataclass, field
from pathlib import Path

from ..config import TrackConfig, config_from_toml, config_to_toml
from ..errors import InputError
from ..logs import duration, emit, run_started

__all__ = ["BatchItem", "BatchRequest", "BatchSummary", "dataset_items", "result_is_done", "run_batch",
           "track_item"]

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class BatchItem:
    """One sequence of a batch."""

    subject: str  #: a project's trial: its name
    sequence: str  #: ``<Action>_<Trial>``; a project's trial: its name again

    @property
    def key(self) -> str:
        """``<Subject>/<Action>_<Trial>``, or a project trial's name."""
        return self.subject if self.subject == self.sequence else f"{self.subject}/{self.sequence}"

    def result_path(self, out_dir) -> Path:
        """Where :func:`voxelmocap.run.pipeline.track_sequence` writes its HDF5 result."""
        return Path(out_dir) / self.subject / f"{self.sequence}.h5"


@dataclass
class BatchSummary:
    """What a batch did: the keys done and skipped, and ``(key, reason)`` of the failed."""

    done: list[str] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)
    failed: list[tuple[str, str]] = field(default_factory=list)

    def describe(self) -> str:
        return f"{len(self.done)} done, {len(self.skipped)} skipped, {len(self.failed)} failed"


def dataset_items(dataset_root, calibration=None, left_out: list[str] | None = None
                  ) -> list[BatchItem]:
    """Every sequence of a data set or project: what ``track --all`` tracks.

    HumanEva-I layout: every sequence that has videos, subject by subject. A sequence that cannot
    even be opened (no sync files, an unreadable ``.ofs``) is listed too: its task fails with the
    reason, which the summary reports, rather than vanishing.

    Project (:class:`voxelmocap.io.project.Project`): every trial in natural order, except those
    Pose2Sim's ``[project] exclude_from_batch`` names (their names are appended to
    ``left_out``).

    Parameters
    ----------
    dataset_root : str or os.PathLike
        The data set or project folder.
    calibration : str or os.PathLike, optional
        Project only: a calibration file for every trial instead of the project's own.
    left_out : list of str, optional
        Receives the names of the trials a project leaves out of a batch.
    """
    from ..io.humaneva import Dataset, Sequence
    from ..io.sequence import detect_layout

    if detect_layout(dataset_root) != "humaneva":
        from ..io.project import Project

        trials, excluded = Project(dataset_root, calibration=calibration).batch_trials()
        if left_out is not None:
            left_out.extend(excluded)
        if not trials:
            raise InputError(dataset_root, "every trial is excluded from batch analysis "
                                           "([project] exclude_from_batch)")
        return [BatchItem(trial.name, trial.name) for trial in trials]
    if calibration is not None:
        raise InputError("--calibration", "a HumanEva-layout data set reads "
                                          "<Subject>/Calibration_Data")
    dataset = Dataset(dataset_root)
    items = []
    for subject in dataset.subjects:
        for name in dataset.sequences(subject):
            try:
                # The listing reads file names only; a sequence of sync files alone is no work.
                has_video = bool(Sequence(dataset, dataset.subject_dir(subject).name, name)
                                 ._video_cameras())
            except InputError:
                has_video = True
            if has_video:
                items.append(BatchItem(dataset.subject_dir(subject).name, name))
    if not items:
        raise InputError(dataset_root, "no sequence with videos in this data set")
    return items


def result_is_done(path, config_toml: str, seed: int, cues_given: bool = False) -> bool:
    """Whether ``path`` is a complete result of this configuration and seed.

    A complete result of other settings is not "done": tracking it again is refused by
    :func:`~voxelmocap.run.pipeline.track_sequence` with the reason (unless ``overwrite``). The
    last of several tracking passes records the config it tracked with
    (:func:`voxelmocap.run.plan.final_config`: the silhouette cue added), and a run whose last
    pass learnt its plate by carving records that pass's
    (:func:`voxelmocap.run.plan.carving_config`); either counts as this one (``cues_given``:
    the cues were chosen, as ``track --cues``).
    """
    from ..io.results import read_result

    path = Path(path)
    if not path.exists():
        return False
    try:
        result = read_result(path)
    except InputError:  # unreadable, being written, older format: let the task say why
        return False
    attrs = result.attrs
    if not (attrs.get("complete") and str(attrs.get("seed")) == str(int(seed))):
        return False
    if str(attrs.get("config")) == config_toml:
        return True
    from .plan import carving_config, final_config

    config = config_from_toml(config_toml)
    if not str(attrs.get("plate_from", "")):
        return str(attrs.get("config")) == config_to_toml(carving_config(config))
    return str(attrs.get("config")) == config_to_toml(final_config(config, cues_given)[0])


@dataclass(frozen=True)
class BatchRequest:
    """What every item of a batch shares (see :func:`run_batch`).

    Attributes
    ----------
    dataset : str or os.PathLike
        HumanEva-layout data set, or a Pose2Sim, anipose, EasyMocap or FreeMoCap project.
    out_dir : str or os.PathLike
        The run folder ``RUN`` (results under ``RUN/<Subject>/``, a project's under
        ``RUN/<trial>/``).
    config : TrackConfig
        Settings of every sequence.
    frames : str or None
        ``"a:b"`` applied to every sequence (default: each one's frames with ground truth, or
        all of them; a Pose2Sim trial's: its ``[project] frame_range``).
    cameras : list of str or None
        Cameras of every sequence (default: each one's all).
    seed : int
        Seed of every sequence's filter.
    overwrite : bool
        Track complete results again, replacing them.
    cues_given : bool
        The cues were chosen (``track --all --cues``): a later tracking pass keeps them.
    calibration : str or os.PathLike or None
        Project only: a calibration file for every trial instead of the project's own.
    """

    dataset: object
    out_dir: object
    config: TrackConfig = field(default_factory=TrackConfig)
    frames: str | None = None
    cameras: list | None = None
    seed: int = 0
    overwrite: bool = False
    cues_given: bool = False
    calibration: object = None

    def __post_init__(self):
        if self.config is None:
            object.__setattr__(self, "config", TrackConfig())


def track_item(item: BatchItem, request: BatchRequest, progress: bool = False) -> dict:
    """Track one item (runs in a Dask worker or here); a short description of its result.

    The run's messages are appended to ``RUN/voxelmocap.log``, each prefixed with the item's
    key (in a Dask worker; in the command's own process its run log already holds them).
    """
    from ..logs import task_log
    from .pipeline import track_sequence

    r = request
    started = time.perf_counter()
    with task_log(Path(r.out_dir) / "voxelmocap.log", item.key):
        outcome = track_sequence(r.dataset, item.subject, item.sequence, r.out_dir,
                                 config=r.config, frames=r.frames, cameras=r.cameras,
                                 seed=r.seed, resume=not r.overwrite, overwrite=r.overwrite,
                                 progress=progress, cues_given=r.cues_given,
                                 calibration=r.calibration)
    return {"result": str(outcome.result_path), "frames": len(outcome.frames),
            "seconds_per_frame": outcome.seconds_per_frame,
            "resumed_from": outcome.resumed_from, "wall_seconds": time.perf_counter() - started}


def run_batch(request: BatchRequest, *, scheduler: str | None = None,
              n_workers: int | None = None, progress: bool = True, items=None,
              log=None) -> BatchSummary:
    """Track every item (default: :func:`dataset_items`) into ``request.out_dir``; what happened.

    Parameters
    ----------
    request : BatchRequest
        The data, the run folder and the settings every sequence shares.
    scheduler : str, optional
        Address of a running Dask scheduler.
    n_workers : int, optional
        Worker processes of a local Dask cluster. Without ``scheduler`` or ``n_workers`` the
        sequences run one after another in this process.
    progress : bool
        Progress bars (per frame when running here, per sequence on Dask).
    items : list of BatchItem, optional
        The sequences (default: every sequence with videos in ``request.dataset``).
    log : callable, optional
        Also receives the ``voxelmocap.run.batch`` logger's messages.
    """
    from ..io._atomic import ensure_output_dir
    from .tasks import run_tasks

    if n_workers is not None and n_workers < 1:  # before anything is created
        raise InputError("--workers", f"must be at least 1, got {n_workers}")
    r = request
    left_out: list[str] = []
    items = dataset_items(r.dataset, r.calibration, left_out) if items is None else list(items)
    if left_out:
        emit(logger, log, f"left out ([project] exclude_from_batch): {', '.join(left_out)}")
    config_toml = config_to_toml(r.config)
    out_dir = Path(r.out_dir)
    ensure_output_dir(out_dir)
    summary = BatchSummary()
    todo = []
    for item in items:
        if not r.overwrite and result_is_done(item.result_path(out_dir), config_toml, r.seed,
                                              r.cues_given):
            summary.skipped.append(item.key)
        else:
            todo.append(item)
    emit(logger, log, f"{len(items)} sequences, {len(summary.skipped)} already done, "
                      f"{len(todo)} to track")
    if todo:
        run_started()
    here = scheduler is None and n_workers is None
    # the workers see absolute paths and the configuration read back from its TOML text (what
    # the result records and result_is_done compares): a worker may run in another folder
    resolved = dataclasses.replace(
        r, dataset=str(Path(r.dataset).resolve()), out_dir=str(out_dir.resolve()),
        config=config_from_toml(config_toml),
        calibration=None if r.calibration is None else str(Path(r.calibration).resolve()))
    tasks = [(f"track-{item.subject}-{item.sequence}", track_item,
              (item, resolved, progress and here)) for item in todo]
    by_key = {task[0]: item for task, item in zip(tasks, todo, strict=True)}

    def finished(outcome) -> None:  # as each sequence ends, not when all have
        item = by_key[outcome.key]
        if outcome.ok:
            summary.done.append(item.key)
            v = outcome.value
            tracked = v["frames"] - v["resumed_from"]
            emit(logger, log, f"{item.key}: {tracked} frames in {duration(v['wall_seconds'])} "
                              f"({tracked / v['wall_seconds']:.2f} frames/s for the whole "
                              f"sequence; its last pass's frame loop "
                              f"{1.0 / v['seconds_per_frame']:.2f} frames/s) → {v['result']}")
        else:
            summary.failed.append((item.key, outcome.error))
            emit(logger, log, f"{item.key} failed: {outcome.error}", logging.WARNING)

    run_tasks(tasks, scheduler=scheduler, n_workers=n_workers, local=True,
              progress=progress and not here, desc="sequences", on_outcome=finished)
    order = {item.key: i for i, item in enumerate(items)}  # summaries in data set order
    summary.done.sort(key=order.get)
    summary.failed.sort(key=lambda kf: order[kf[0]])
    return summary
