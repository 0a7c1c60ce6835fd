"""Checking output places before any work is written, so that a command fails before it writes.

A command with several outputs (``evaluate --json --csv --plots``) checks all of them first: a
bad third output must not leave the first two written (issue: "check every output first, write
nothing on failure"). The checks are what the writes will need: an existing folder is writable, a
folder that does not exist yet can be created under its nearest existing ancestor, a file is not a
folder.
"""

from __future__ import annotations

import os
from pathlib import Path

from ..errors import InputError

__all__ = ["check_output_dir", "check_output_file"]


def _nearest_existing(path: Path) -> Path:
    path = path.absolute()
    while not path.exists() and path != path.parent:
        path = path.parent
    return path


def _check_creatable(path: Path, what: str) -> None:
    anchor = _nearest_existing(path)
    if not anchor.is_dir():
        raise InputError(path, f"cannot create the {what}: {anchor} is a file, not a folder")
    if not os.access(anchor, os.W_OK | os.X_OK):
        raise InputError(path, f"cannot create the {what}: {anchor} is not writable")


def check_output_dir(path) -> Path:
    """Raise :class:`InputError` unless ``path`` is, or can be made, a writable folder."""
    path = Path(path)
    if path.exists():
        if not path.is_dir():
            raise InputError(path, "exists and is not a folder")
        if not os.access(path, os.W_OK | os.X_OK):
            raise InputError(path, "output folder is not writable")
        return path
    _check_creatable(path, "output folder")
    return path


def check_output_file(path) -> Path:
    """Raise :class:`InputError` unless a file can be written at ``path`` (by temp + rename)."""
    path = Path(path)
    if path.is_dir():
        raise InputError(path, "is a folder; give a file name")
    if path.parent.exists():
        if not path.parent.is_dir():
            raise InputError(path, f"{path.parent} is a file, not a folder")
        # The atomic writer creates a sibling and renames it: the folder must be writable.
        if not os.access(path.parent, os.W_OK | os.X_OK):
            raise InputError(path, f"cannot write here: {path.parent} is not writable")
        return path
    _check_creatable(path.parent, "output folder")
    return path
