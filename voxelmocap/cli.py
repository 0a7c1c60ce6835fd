"""The ``voxelmocap`` command: a thin argparse front over one module per subcommand.

Each subcommand lives in ``voxelmocap/commands/<name>.py`` with ``add_parser(subparsers)`` and
``run(args) -> int``; heavy imports happen inside ``run`` so that ``--help`` stays fast. Errors that
users can fix (:class:`voxelmocap.errors.VoxelmocapError`) are printed as one line and exit with 2.

``-v`` / ``-q`` (before or after the subcommand) set how much of the package's logging reaches the
console (:mod:`voxelmocap.logs`); a subcommand that sets ``log_folder`` (``track``, ``dump``,
``sweep``) also appends its messages to ``<folder>/voxelmocap.log``. A subcommand with
``--no-progress`` draws no progress bar when standard error is not a terminal either
(:func:`voxelmocap.logs.progress_to_terminal`).
"""

from __future__ import annotations

import argparse
import importlib
import logging
import os
import sys

from . import __version__, cpu_paths, thread_waits

# Before anything imports NumPy: the same NumPy loops and OpenBLAS kernels on every machine
# (a tracked result must not depend on the CPU; voxelmocap.cpu_paths)
PINNED = cpu_paths.pin()
# Before numba loads its OpenMP layer: idle workers sleep (voxelmocap.thread_waits)
thread_waits.passive()

from .errors import VoxelmocapError  # noqa: E402

__all__ = ["main"]

#: Subcommand name → module under ``voxelmocap.commands``. Order is the order of ``--help``.
COMMANDS: dict[str, str] = {
    "demo": "demo",
    "synth": "synth",
    "info": "info",
    "import": "import_",
    "track": "track",
    "evaluate": "evaluate",
    "export": "export",
    "groundtruth": "groundtruth",
    "sweep": "sweep",
    "overlay": "overlay",
    "dump": "dump",
    "view": "view",
}


def build_parser() -> argparse.ArgumentParser:
    """The top-level parser with every registered subcommand."""
    parser = argparse.ArgumentParser(
        prog="voxelmocap",
        description="Markerless multi-camera motion capture on HumanEva-format sequences.",
    )
    parser.add_argument("--version", action="version", version=f"voxelmocap {__version__}")
    _add_verbosity(parser, argparse.SUPPRESS)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for module_name in COMMANDS.values():
        module = importlib.import_module(f"voxelmocap.commands.{module_name}")
        module.add_parser(sub)
    for subparser in sub.choices.values():
        # SUPPRESS: a subcommand's parser leaves a -v given before the subcommand standing.
        _add_verbosity(subparser, argparse.SUPPRESS)
    return parser


def _add_verbosity(parser: argparse.ArgumentParser, default) -> None:
    group = parser.add_argument_group("output")
    group.add_argument("-v", "--verbose", action="count", default=default,
                       help="debug messages too (a run's voxelmocap.log always has them)")
    group.add_argument("-q", "--quiet", action="count", default=default,
                       help="only warnings and errors on the console")


#: Options whose value may start with "-" (a frame range such as ``-5:3``): argparse would take
#: the value for an option and print its usage instead of the range's own error.
_DASH_VALUE_OPTIONS = ("--frames",)


def _join_dash_values(argv: list[str]) -> list[str]:
    """``["--frames", "-5:3"]`` → ``["--frames=-5:3"]``, so the value reaches its validator."""
    out: list[str] = []
    i = 0
    while i < len(argv):
        arg = argv[i]
        if arg in _DASH_VALUE_OPTIONS and i + 1 < len(argv) and argv[i + 1].startswith("-") \
                and argv[i + 1][1:2].isdigit():
            out.append(f"{arg}={argv[i + 1]}")
            i += 2
            continue
        out.append(arg)
        i += 1
    return out


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``voxelmocap`` console script; returns the exit code."""
    # FFmpeg's own messages ("[mjpeg @ 0x…] overread 8") would precede our one-line errors; OpenCV
    # reads this when it first opens a video. A user's own setting wins (e.g. to debug a codec).
    os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")  # AV_LOG_QUIET
    parser = build_parser()
    args = parser.parse_args(_join_dash_values(list(sys.argv[1:] if argv is None else argv)))
    if not getattr(args, "command", None):
        parser.print_help()
        return 0
    from . import logs

    verbosity = getattr(args, "verbose", 0) - getattr(args, "quiet", 0)
    log_folder = getattr(args, "log_folder", None)
    logs.configure(verbosity, log_dir=log_folder(args) if log_folder else None,
                   argv=sys.argv[1:] if argv is None else argv)
    logger = logging.getLogger("voxelmocap.cli")
    if getattr(args, "no_progress", None) is False and not logs.progress_to_terminal():
        args.no_progress = True  # the bars would land in a file or a pipe as noise
        logger.debug("no progress bars: standard error is not a terminal")
    if PINNED:
        logger.debug("CPU paths pinned (voxelmocap.cpu_paths): %s",
                     ", ".join(f"{k}={v}" for k, v in PINNED.items()))
    committed = True
    try:
        code = int(args.run(args) or 0)
        logger.debug("exit code %d", code)
    except VoxelmocapError as exc:
        code = _refused(args, exc, logger)
        committed = False
    except KeyboardInterrupt:
        print(f"voxelmocap {args.command}: interrupted", file=sys.stderr)
        logger.error("interrupted (exit code 130)", extra={"file_only": True})
        code = 130
        committed = False
    except BaseException:
        logger.exception("failed", extra={"file_only": True})
        logs.finish(False)
        raise
    try:
        logs.finish(committed)
    except VoxelmocapError as exc:  # the log file of a finished command cannot be written
        print(f"voxelmocap {args.command}: error: {exc}", file=sys.stderr)
        code = 2
    return code


def _refused(args, exc: VoxelmocapError, logger: logging.Logger) -> int:
    print(f"voxelmocap {args.command}: error: {exc}", file=sys.stderr)
    # In the log file only, and only if the run had begun: a refused command leaves nothing.
    logger.error("%s (exit code 2)", exc, extra={"file_only": True})
    return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
