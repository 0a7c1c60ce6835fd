"""Exceptions that user-facing commands turn into one clear line and exit code 2."""

from __future__ import annotations

import os

__all__ = ["InputError", "VoxelmocapError", "printable"]


class VoxelmocapError(Exception):
    """Base class of every error that the command line reports as one line, without traceback."""


class InputError(VoxelmocapError, ValueError):
    """Malformed or missing input: a file, a folder or a value that cannot be used.

    Parameters
    ----------
    source : str or os.PathLike or None
        The file (or folder, or option name) at fault. It leads the message.
    problem : str
        What is wrong with it, in a few words.

    Examples
    --------
    >>> str(InputError("S1/Calibration_Data/C1.cal", "expected 22 numbers, found 21"))
    'S1/Calibration_Data/C1.cal: expected 22 numbers, found 21'
    """

    def __init__(self, source: str | os.PathLike | None, problem: str):
        self.source = None if source is None else os.fspath(source)
        self.problem = problem
        super().__init__(problem if self.source is None else f"{printable(self.source)}: {problem}")


def printable(name: str | bytes | os.PathLike) -> str:
    """A file name as text that any terminal or log can show: bytes that are not UTF-8 (kept by
    Python as lone surrogates, which cannot be printed) as ``\\xff`` escapes.

    >>> printable(b"cam01\\xff.mp4".decode("utf-8", "surrogateescape"))
    'cam01\\\\xff.mp4'
    """
    name = os.fspath(name)
    raw = name if isinstance(name, bytes) else name.encode("utf-8", "surrogateescape")
    return raw.decode("utf-8", "backslashreplace")
