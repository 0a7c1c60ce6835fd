"""Batch tracking: every sequence of a data set, as Dask tasks, finished ones skipped.

``voxelmocap track DATASET --all --out RUN`` plans one :class:`BatchItem` per sequence
(:func:`dataset_items`: every subject's sequences that have videos), drops those whose result
``RUN/<Subject>/<Action>_<Trial>.h5`` is complete and was made with the same configuration and
seed (:func:`result_is_done`), and runs the rest through :func:`voxelmocap.run.tasks.run_tasks` —
the engine ``voxelmocap sweep`` uses — on a Dask cluster (``scheduler``), a local cluster of
``n_workers`` processes, or one after another in this process. Each task is
:func:`track_item`: :func:`voxelmocap.run.pipeline.track_sequence` with ``resume=True``, so an
interrupted sequence continues where it stopped. A failing sequence is recorded with its
one-line reason and the others go on; :class:`BatchSummary` says what was done, skipped and
failed.

Items are plain (subject, sequence) pairs, so other sources of sequences (a project folder's
trials) can be listed into the same loop.

>>> summary = run_batch("data", "run", n_workers=2)              # doctest: +SKIP
>>> summary.describe()                                           # doctest: +SKIP
'3 done, 0 skipped, 0 failed'
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from pathlib import Path

from ..config import TrackConfig, config_from_toml, config_to_toml
from ..errors import InputError
from ..logs import emit, run_started

__all__ = ["BatchItem", "BatchSummary", "dataset_items", "result_is_done", "run_batch",
           "track_item"]

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class BatchItem:
    """One sequence of a batch."""

    subject: str
    sequence: str  #: ``<Action>_<Trial>``

    @property
    def key(self) -> str:
        return f"{self.subject}/{self.sequence}"

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


def dataset_items(dataset_root) -> list[BatchItem]:
    """Every sequence of a HumanEva-layout data set that has videos, subject by subject.

    A sequence that cannot even be opened (no sync files, an unreadable ``.ofs``) is listed too:
    its task fails with the reason, which the summary reports, rather than vanishing.
    """
    from ..io.humaneva import Dataset, Sequence

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
    (:func:`voxelmocap.run.plan.final_config`: the silhouette cue added), which counts as this
    one (``cues_given``: the cues were chosen, as ``track --cues``).
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
    if not str(attrs.get("plate_from", "")):
        return False
    from .plan import final_config

    final = final_config(config_from_toml(config_toml), cues_given)[0]
    return str(attrs.get("config")) == config_to_toml(final)


def track_item(item: BatchItem, dataset, out_dir, config_toml: str, frames=None, cameras=None,
               seed: int = 0, overwrite: bool = False, progress: bool = False,
               cues_given: bool = False) -> dict:
    """Track one item (runs in a Dask worker or here); a short description of its result.

    The run's messages are appended to ``RUN/voxelmocap.log``, each prefixed with the item's
    key (in a Dask worker; in the command's own process its run log already holds them).
    """
    from ..logs import task_log
    from .pipeline import track_sequence

    with task_log(Path(out_dir) / "voxelmocap.log", item.key):
        outcome = track_sequence(dataset, item.subject, item.sequence, out_dir,
                                 config=config_from_toml(config_toml), frames=frames,
                                 cameras=cameras, seed=seed, resume=not overwrite,
                                 overwrite=overwrite, progress=progress,
                                 cues_given=cues_given)
    return {"result": str(outcome.result_path), "frames": len(outcome.frames),
            "seconds_per_frame": outcome.seconds_per_frame,
            "resumed_from": outcome.resumed_from}


def run_batch(dataset, out_dir, *, config: TrackConfig | None = None, frames=None,
              cameras=None, seed: int = 0, overwrite: bool = False, scheduler: str | None = None,
              n_workers: int | None = None, progress: bool = True, items=None,
              log=None, cues_given: bool = False) -> BatchSummary:
    """Track every item (default: :func:`dataset_items`) into ``out_dir``; what happened.

    Parameters
    ----------
    dataset : str or os.PathLike
        HumanEva-layout data set.
    out_dir : str or os.PathLike
        The run folder ``RUN`` (results under ``RUN/<Subject>/``).
    config : TrackConfig, optional
        Settings of every sequence.
    frames : str, optional
        ``"a:b"`` applied to every sequence (default: each one's frames with ground truth).
    cameras : list of str, optional
        Cameras of every sequence (default: each one's all).
    seed : int
        Seed of every sequence's filter.
    overwrite : bool
        Track complete results again, replacing them.
    scheduler : str, optional
        Address of a running Dask scheduler.
    n_workers : int, optional
        Worker processes of a local Dask cluster. Without ``scheduler`` or ``n_workers`` the
        sequences run one after another in this process.
    progress : bool
        Progress bars (per frame when running here, per sequence on Dask).
    items : list of BatchItem, optional
        The sequences (default: every sequence with videos in ``dataset``).
    log : callable, optional
        Also receives the ``voxelmocap.run.batch`` logger's messages.
    cues_given : bool
        The cues were chosen (``track --all --cues``): a later tracking pass keeps them.
    """
    from ..io._atomic import ensure_output_dir
    from .tasks import run_tasks

    if n_workers is not None and n_workers < 1:  # before anything is created
        raise InputError("--workers", f"must be at least 1, got {n_workers}")
    config = config or TrackConfig()
    items = dataset_items(dataset) if items is None else list(items)
    config_toml = config_to_toml(config)
    out_dir = Path(out_dir)
    ensure_output_dir(out_dir)
    summary = BatchSummary()
    todo = []
    for item in items:
        if not overwrite and result_is_done(item.result_path(out_dir), config_toml, seed,
                                            cues_given):
            summary.skipped.append(item.key)
        else:
            todo.append(item)
    emit(logger, log, f"{len(items)} sequences, {len(summary.skipped)} already done, "
                      f"{len(todo)} to track")
    if todo:
        run_started()
    here = scheduler is None and n_workers is None
    root, out = str(Path(dataset).resolve()), str(out_dir.resolve())
    tasks = [(f"track-{item.subject}-{item.sequence}", track_item,
              (item, root, out, config_toml, frames, cameras, seed, overwrite,
               progress and here, cues_given)) for item in todo]
    by_key = {task[0]: item for task, item in zip(tasks, todo, strict=True)}

    def finished(outcome) -> None:  # as each sequence ends, not when all have
        item = by_key[outcome.key]
        if outcome.ok:
            summary.done.append(item.key)
            emit(logger, log, f"{item.key}: {outcome.value['frames']} frames, "
                              f"{1.0 / outcome.value['seconds_per_frame']:.2f} frames/s → "
                              f"{outcome.value['result']}")
        else:
            summary.failed.append((item.key, outcome.error))
            emit(logger, log, f"{item.key} failed: {outcome.error}", logging.WARNING)

    run_tasks(tasks, scheduler=scheduler, n_workers=n_workers, local=True,
              progress=progress and not here, desc="sequences", on_outcome=finished)
    order = {item.key: i for i, item in enumerate(items)}  # summaries in data set order
    summary.done.sort(key=order.get)
    summary.failed.sort(key=lambda kf: order[kf[0]])
    return summary
