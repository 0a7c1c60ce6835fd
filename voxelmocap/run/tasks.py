"""Independent tasks on Dask, the engine of ``voxelmocap sweep`` and ``voxelmocap track --all``.

A caller plans its tasks, drops those already finished (it knows how: a sweep cell's score file,
a sequence's complete result) and hands the rest to :func:`run_tasks`: one Dask task each, on an
existing cluster (``scheduler``: its address) or on a local cluster of single-threaded worker
processes started for the call and closed after it; or one after another in this process when
neither is given and ``local=True``. Results come back as they finish, under a progress bar;
each task's outcome is a :class:`TaskOutcome` (its value, or the one-line reason it failed), so
one failing task does not stop the others unless ``stop_on_error``.

``dask[distributed]`` is the optional ``distributed`` extra.

>>> outcomes = run_tasks([("a", pow, (2, 3)), ("b", pow, (2, "x"))], n_workers=2)  # doctest: +SKIP
>>> [(o.key, o.ok, o.value) for o in outcomes]                                  # doctest: +SKIP
[('a', True, 8), ('b', False, None)]
"""

from __future__ import annotations

import functools
import logging
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from ..errors import InputError

__all__ = ["TaskOutcome", "run_tasks"]

logger = logging.getLogger(__name__)

#: (key, function, positional arguments): one task.
Task = tuple[str, Callable[..., Any], tuple]


@dataclass(frozen=True)
class TaskOutcome:
    """How one task ended."""

    key: str
    ok: bool
    value: Any = None  #: the function's return value (when ``ok``)
    error: str | None = None  #: one line: the exception's type (unless a user error) and text


def _one_line(exc: BaseException) -> str:
    from ..errors import VoxelmocapError

    text = " ".join(str(exc).split()) or type(exc).__name__
    return text if isinstance(exc, VoxelmocapError) else f"{type(exc).__name__}: {text}"


def _guarded(function, *args) -> tuple[bool, Any, bool]:
    """Run one task where it is scheduled: ``(ok, value or one-line error, user error?)``.

    The error crosses back as text: an exception object would need to unpickle on the client
    (``InputError``'s two-argument constructor does not) and its traceback is the worker's.
    """
    from ..errors import VoxelmocapError

    try:
        return True, function(*args), False
    except Exception as exc:
        logger.debug("task failed", exc_info=True)
        return False, _one_line(exc), isinstance(exc, VoxelmocapError)


def _outcome(key: str, returned, stop_on_error: bool) -> TaskOutcome:
    ok, value, user_error = returned
    if ok:
        return TaskOutcome(key, True, value)
    if stop_on_error:
        raise InputError(key, value) if user_error else RuntimeError(f"{key}: {value}")
    return TaskOutcome(key, False, error=value)


def run_tasks(tasks: Sequence[Task], *, scheduler: str | None = None,
              n_workers: int | None = None, local: bool = False, stop_on_error: bool = False,
              progress: bool = True, desc: str = "tasks",
              on_outcome: Callable[[TaskOutcome], None] | None = None) -> list[TaskOutcome]:
    """Run every task; their outcomes in the order they finished.

    Parameters
    ----------
    tasks : sequence of (str, callable, tuple)
        A unique key, a function importable by the workers (module level) and its arguments.
    scheduler : str, optional
        Address of a running Dask scheduler (``tcp://host:8786``).
    n_workers : int, optional
        Worker processes of the local cluster (default: one per core, at most one per task).
    local : bool
        Without ``scheduler`` and ``n_workers``, run the tasks one after another in this
        process instead of starting a local cluster.
    stop_on_error : bool
        Re-raise the first task's exception (the others are cancelled) instead of recording it.
    progress : bool
        A progress bar over the tasks.
    desc : str
        The bar's label.
    on_outcome : callable, optional
        Called with each :class:`TaskOutcome` as soon as its task ends.

    Raises
    ------
    InputError
        Dask is needed and not installed, or ``n_workers`` < 1.
    """
    if not tasks:
        return []
    if n_workers is not None and n_workers < 1:
        raise InputError("--workers", f"must be at least 1, got {n_workers}")
    bar = _bar(len(tasks), progress, desc)
    report = functools.partial(_report, bar=bar, on_outcome=on_outcome)
    try:
        if local and scheduler is None and n_workers is None:
            return _run_here(tasks, stop_on_error, report)
        return _run_on_dask(tasks, scheduler, n_workers, stop_on_error, report)
    finally:
        if bar is not None:
            bar.close()


def _run_here(tasks, stop_on_error, report) -> list[TaskOutcome]:
    outcomes = []
    for key, function, args in tasks:
        if stop_on_error:  # the exception itself, with its traceback
            outcome = TaskOutcome(key, True, function(*args))
        else:
            outcome = _outcome(key, _guarded(function, *args), False)
        outcomes.append(report(outcome))
    return outcomes


def _run_on_dask(tasks, scheduler, n_workers, stop_on_error, report) -> list[TaskOutcome]:
    try:
        from dask.distributed import Client, LocalCluster, as_completed
    except ImportError:  # pragma: no cover - depends on the optional extra
        raise InputError("dask", "needs dask[distributed]: pip install 'voxelmocap[distributed]'"
                         ) from None
    cluster = None
    if scheduler:
        logger.info("submitting %d tasks to the Dask scheduler at %s", len(tasks), scheduler)
        client = Client(scheduler)
    else:
        workers = n_workers or max(1, min(len(tasks), os.cpu_count() or 1))
        logger.info("starting a local Dask cluster of %d worker process(es)", workers)
        # the dashboard on any free port: None still binds the default 8787 (and warns, or
        # fails under warnings-as-errors, when another Dask session already holds it)
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                               dashboard_address=":0")
        client = Client(cluster)
    outcomes = []
    try:
        futures = {client.submit(_guarded, function, *args, key=key, pure=False): key
                   for key, function, args in tasks}
        for future in as_completed(futures):
            key = futures[future]
            try:
                returned = future.result()
            except Exception as exc:  # the task never returned: its worker died, a lost key…
                if stop_on_error:
                    raise
                returned = (False, _one_line(exc), False)
            outcomes.append(report(_outcome(key, returned, stop_on_error)))
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    return outcomes


def _report(outcome: TaskOutcome, *, bar, on_outcome) -> TaskOutcome:
    if outcome.ok:
        logger.debug("%s: done", outcome.key)
    else:  # the caller reports it, in its own words
        logger.debug("%s failed: %s", outcome.key, outcome.error)
    if on_outcome is not None:
        on_outcome(outcome)
    if bar is not None:
        bar.update(1)
    return outcome


def _bar(total: int, enabled: bool, desc: str):
    if not enabled:
        return None
    from tqdm.auto import tqdm

    return tqdm(total=total, desc=desc, unit="task", dynamic_ncols=True)
