"""Logging of the ``voxelmocap`` command: console verbosity, the run folder's log file, tqdm.

Every module logs through ``logging.getLogger(__name__)``, so the loggers form the package
hierarchy ``voxelmocap.run.pipeline``, ``voxelmocap.run.measurement``, ``voxelmocap.run.sweep`` …
under ``voxelmocap``, which carries a :class:`logging.NullHandler`: a program importing the
package sees nothing unless it configures logging itself (the standard library's advice for
libraries). The command line calls :func:`configure` once:

* the console gets the messages at INFO and above (``-q``: WARNING and above, ``-v``: DEBUG)
  on standard output, exactly as the command printed them before, warnings prefixed
  ``warning:``; they are written through ``tqdm.write`` so that a progress bar on the terminal
  is cleared and redrawn around them instead of being broken;
* progress bars (tqdm, on standard error) are drawn only when standard error is a terminal
  (:func:`progress_to_terminal`; the command line turns them off otherwise, as
  ``--no-progress`` does): in a file, a pipe or a CI log they are lines of carriage returns;
* ``track``, ``dump`` and ``sweep`` append every message (DEBUG included, with a timestamp, the
  level and the logger) to ``RUN/voxelmocap.log``, after a line with the command line.

The log file follows the package's rule that a failed command leaves nothing behind: its lines
are kept in memory until the run has begun writing outputs that outlive a failure (``track``'s
resumable result, a sweep's settings: the runner calls :func:`run_started`) or the command ends
without an error, and are then appended. A command refused for bad input, or a ``dump`` whose
atomic output is discarded, writes no log file.

>>> import logging
>>> from voxelmocap.logs import configure
>>> handlers = configure(verbosity=0)                                     # doctest: +SKIP
>>> logging.getLogger("voxelmocap.run.pipeline").info("tracked")             # doctest: +SKIP
tracked
"""

from __future__ import annotations

import contextlib
import logging
import os
import shlex
import sys
import time
from pathlib import Path

__all__ = ["LOG_NAME", "NO_PROGRESS_HELP", "ConsoleHandler", "RunLogHandler", "configure",
           "duration", "emit", "finish", "progress_to_terminal", "run_started", "task_log",
           "unconfigure"]

#: The log file's name inside the run folder.
LOG_NAME = "voxelmocap.log"

#: The help of every command's ``--no-progress``.
NO_PROGRESS_HELP = "no progress bar (there is none anyway when standard error is not a terminal)"

#: The package's root logger.
PACKAGE = logging.getLogger("voxelmocap")
PACKAGE.addHandler(logging.NullHandler())

_FILE_FORMAT = "%(asctime)s.%(msecs)03d %(levelname)-7s %(name)s: %(message)s"
_DATE_FORMAT = "%Y-%m-%d %H:%M:%S"


class ConsoleHandler(logging.Handler):
    """Messages to standard output through ``tqdm.write`` (bars are redrawn below them).

    ``sys.stdout`` is looked up at every message, so a stream replaced after configuration
    (pytest's ``capsys``, a redirection in a notebook) receives them.
    """

    def __init__(self, level: int = logging.INFO):
        super().__init__(level)
        self.setFormatter(_ConsoleFormatter())

    def emit(self, record: logging.LogRecord) -> None:
        if getattr(record, "file_only", False):
            return
        try:
            from tqdm import tqdm

            tqdm.write(self.format(record), file=sys.stdout)
        except Exception:
            self.handleError(record)


class _ConsoleFormatter(logging.Formatter):
    """The message as the command used to print it; ``warning:`` / ``error:`` before others."""

    def format(self, record: logging.LogRecord) -> str:
        text = record.getMessage()
        if record.levelno >= logging.ERROR:
            return f"error: {text}"
        if record.levelno >= logging.WARNING:
            return f"warning: {text}"
        return text


class RunLogHandler(logging.Handler):
    """Appends to ``RUN/voxelmocap.log``; holds its lines in memory until :meth:`commit`.

    Parameters
    ----------
    path : str or os.PathLike
        The log file (its folder is created at :meth:`commit`).
    header : str
        The first line of this command's block (the command line).
    """

    def __init__(self, path, header: str):
        super().__init__(logging.DEBUG)
        self.path = Path(path)
        formatter = logging.Formatter(_FILE_FORMAT, _DATE_FORMAT)
        formatter.converter = time.gmtime  # UTC, as the result files' creation time
        self.setFormatter(formatter)
        now = time.time()
        self._pending: list[str] = [f"{time.strftime(_DATE_FORMAT, time.gmtime(now))}."
                                    f"{int(now % 1 * 1000):03d} START   {header}"]
        self._stream = None
        #: Set when a write failed (a full disk): later lines are dropped, not reported. The
        #: command's own outputs meet the same disk and report it as its one error line.
        self.failed: OSError | None = None

    @property
    def committed(self) -> bool:
        """Whether the lines go to the file (else they are still held in memory)."""
        return self._stream is not None

    def emit(self, record: logging.LogRecord) -> None:
        if self.failed is not None:
            return
        try:
            line = self.format(record)
            if self._stream is None:
                self._pending.append(line)
            else:
                self._stream.write(line + "\n")
                self._stream.flush()
        except OSError as exc:
            # logging's handleError would print a traceback before the command's error line
            self._fail(exc)
        except Exception:
            self.handleError(record)

    def _fail(self, exc: OSError) -> None:
        self.failed = exc
        stream, self._stream = self._stream, None
        if stream is not None:
            with contextlib.suppress(OSError):
                stream.close()

    def commit(self) -> None:
        """Write the held lines and append every later one directly (idempotent).

        Raises
        ------
        InputError
            The log file cannot be written (e.g. the disk is full); what this call appended
            is cut off again, so the file is as it was.
        """
        from .errors import InputError

        if self._stream is not None or self.failed is not None:
            return
        self.acquire()
        size = None
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            size = self.path.stat().st_size if self.path.exists() else None
            # Appended: one run folder keeps the history of every command run on it.
            self._stream = open(self.path, "a", encoding="utf-8")
            self._stream.write("".join(line + "\n" for line in self._pending))
            self._stream.flush()
            self._pending = []
        except OSError as exc:
            self._fail(exc)
            with contextlib.suppress(OSError):  # nothing half-written
                if size is None:
                    self.path.unlink(missing_ok=True)
                else:
                    os.truncate(self.path, size)
            raise InputError(self.path, f"cannot write the log ({exc.strerror or exc})") from None
        finally:
            self.release()

    def close(self) -> None:
        self.acquire()
        try:
            if self._stream is not None:
                with contextlib.suppress(OSError):
                    self._stream.close()
                self._stream = None
                self._pending = []
        finally:
            self.release()
        super().close()


def configure(verbosity: int = 0, log_dir=None, argv=None) -> list[logging.Handler]:
    """Set up the package logger for one command; returns the handlers it added.

    Parameters
    ----------
    verbosity : int
        ``-1`` (``-q``): warnings and errors only; ``0``: INFO and above; ``≥ 1`` (``-v``):
        DEBUG too.
    log_dir : str or os.PathLike, optional
        The run folder whose ``voxelmocap.log`` receives every message of the command.
    argv : list of str, optional
        The command line written at the head of the log file's block.
    """
    unconfigure()
    level = logging.WARNING if verbosity < 0 else logging.DEBUG if verbosity > 0 else logging.INFO
    handlers: list[logging.Handler] = [ConsoleHandler(level)]
    if log_dir is not None:
        words = ["voxelmocap", *(sys.argv[1:] if argv is None else argv)]
        header = f"{shlex.join(words)}  (pid {os.getpid()}, cwd {os.getcwd()})"
        handlers.append(RunLogHandler(Path(log_dir) / LOG_NAME, header))
    PACKAGE.setLevel(logging.DEBUG)
    for handler in handlers:
        handler._voxelmocap_cli = True
        PACKAGE.addHandler(handler)
    # The command's messages are its output: not duplicated by a root handler someone set up.
    PACKAGE.propagate = False
    return handlers


def unconfigure() -> None:
    """Remove and close the handlers :func:`configure` added (the package is silent again)."""
    for handler in list(PACKAGE.handlers):
        if getattr(handler, "_voxelmocap_cli", False):
            PACKAGE.removeHandler(handler)
            handler.close()
    PACKAGE.setLevel(logging.NOTSET)
    PACKAGE.propagate = True


def progress_to_terminal(stream=None) -> bool:
    """Whether progress bars would reach a terminal: ``stream`` (default standard error, where
    tqdm draws) is one.

    A bar redraws itself with carriage returns: on a terminal it stays one line, in a file, a
    pipe, a CI log or a notebook's captured output it is a heap of partial lines.
    """
    stream = sys.stderr if stream is None else stream
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError, OSError):  # no isatty, or a closed stream
        return False


def run_started() -> None:
    """Called by a runner once it has begun writing outputs: the log file is written from now on.

    A no-op when no command configured a run log (library use, a Dask worker).
    """
    for handler in PACKAGE.handlers:
        if isinstance(handler, RunLogHandler):
            handler.commit()


def finish(committed: bool) -> None:
    """End of a command: write the held log lines when ``committed``, then close every handler.

    Raises
    ------
    InputError
        The held lines cannot be written (the handlers are closed all the same).
    """
    try:
        if committed:
            run_started()
    finally:
        unconfigure()


@contextlib.contextmanager
def task_log(path, prefix: str):
    """Append the package's messages to ``path`` while one task runs, each line after ``prefix``.

    For a task in a Dask worker process, where the command's :class:`RunLogHandler` does not
    exist; a no-op where one already writes ``path`` (the task runs in the command's process).
    Lines are appended one ``write`` each, so workers sharing the file do not cut into each
    other's lines.
    """
    path = Path(path)
    if any(isinstance(h, RunLogHandler) and h.path.resolve() == path.resolve()
           for h in PACKAGE.handlers):
        yield
        return
    handler = logging.FileHandler(path, mode="a", encoding="utf-8")
    handler.setLevel(logging.DEBUG)
    formatter = logging.Formatter(
        _FILE_FORMAT.replace("%(message)s", f"[{prefix}] %(message)s"), _DATE_FORMAT)
    formatter.converter = time.gmtime
    handler.setFormatter(formatter)
    level = PACKAGE.level
    PACKAGE.addHandler(handler)
    PACKAGE.setLevel(logging.DEBUG)
    try:
        yield
    finally:
        PACKAGE.removeHandler(handler)
        PACKAGE.setLevel(level)
        handler.close()


def emit(logger: logging.Logger, callback, message: str, level: int = logging.INFO) -> None:
    """Log ``message`` and hand it to an optional old-style ``log`` callback as well.

    The runners used to take ``log=print``; a caller that still passes a callable (to collect
    the messages, or to silence them with ``lambda *_: None`` — now the default) keeps getting
    the same text, warnings prefixed ``warning:`` as they were printed.
    """
    logger.log(level, message)
    if callback is not None:
        callback(f"warning: {message}" if level >= logging.WARNING else message)


def duration(seconds: float) -> str:
    """A wall time as a person reads it: ``"42.3 s"``, ``"12 min 5 s"``, ``"1 h 3 min"``."""
    seconds = round(float(seconds), 1)  # 59.96 s reads "1 min 0 s", not "60.0 s"
    if seconds < 60:
        return f"{seconds:.1f} s"
    minutes, secs = divmod(int(round(seconds)), 60)
    if minutes < 60:
        return f"{minutes} min {secs} s"
    hours, minutes = divmod(minutes, 60)
    return f"{hours} h {minutes} min"
