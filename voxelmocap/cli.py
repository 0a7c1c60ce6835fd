"""The ``voxelmocap`` command: a thin argparse front over one module per subcommand.

Each subcommand lives in ``voxelmocap/commands/<name>.py`` with ``add_parser(subparsers)`` and
``run(args) -> int``; heavy imports happen inside ``run`` so that ``--help`` stays fast. Errors that
users can fix (:class:`voxelmocap.errors.VoxelmocapError`) are printed as one line and exit with 2.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys

from . import __version__
from .errors import VoxelmocapError

__all__ = ["main"]

#: Subcommand name → module under ``voxelmocap.commands``. Order is the order of ``--help``.
COMMANDS: dict[str, str] = {
    "demo": "demo",
    "synth": "synth",
    "info": "info",
    "import": "import_",
    "track": "track",
    "evaluate": "evaluate",
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
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for module_name in COMMANDS.values():
        module = importlib.import_module(f"voxelmocap.commands.{module_name}")
        module.add_parser(sub)
    return parser


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
    try:
        return int(args.run(args) or 0)
    except VoxelmocapError as exc:
        print(f"voxelmocap {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"voxelmocap {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
