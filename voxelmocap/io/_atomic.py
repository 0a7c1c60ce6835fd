"""Atomic file writes: write to a temporary sibling, then rename over the target.

The temporary is a hidden sibling ``.<stem>.partial-<letters><suffix>``: beside the target so the
rename is atomic, with the target's suffix so writers that dispatch on it (OpenCV, h5py, Matplotlib)
still work, and without digits, which OpenCV's image writers read as a frame-number pattern.
It is created (empty) before the caller writes, so an output that cannot be written is reported
as one :class:`~voxelmocap.errors.InputError` before any work, and deleted on every failure.
"""

from __future__ import annotations

import contextlib
import os
import re
import secrets
import string
from collections.abc import Iterator
from pathlib import Path

from ..errors import InputError

__all__ = ["atomic_path", "atomic_write_bytes", "atomic_write_text", "create_temporary",
           "ensure_output_dir", "temporary_name", "write_error", "write_reason"]


def ensure_output_dir(path) -> Path:
    """Create the folder ``path`` (and parents); :class:`InputError` if that is impossible."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise InputError(path, "exists and is not a folder")
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(path, f"cannot create the output folder ({exc.strerror or exc})") from None
    return path


def temporary_name(path) -> Path:
    """A fresh hidden sibling name of ``path`` with its suffix and no digit (see the module doc)."""
    path = Path(path)
    letters = "".join(secrets.choice(string.ascii_lowercase) for _ in range(10))
    return path.with_name(f".{path.stem}.partial-{letters}{path.suffix}")


def create_temporary(path) -> Path:
    """Check that ``path`` can be written and create its (empty) temporary sibling.

    Parameters
    ----------
    path : str or os.PathLike
        The final file.

    Returns
    -------
    Path
        The temporary file, created empty; the caller renames or deletes it.

    Raises
    ------
    InputError
        ``path`` is a folder, its folder cannot be created, or no file can be created there.
    """
    path = Path(path)
    try:
        is_dir = path.is_dir()
    except OSError as exc:  # e.g. a name too long for the file system
        raise InputError(path, f"cannot write here ({exc.strerror or exc})") from None
    if is_dir:
        raise InputError(path, "is a folder; give a file name")
    ensure_output_dir(path.parent)
    while True:
        tmp = temporary_name(path)
        try:
            with open(tmp, "xb"):
                return tmp
        except FileExistsError:  # pragma: no cover - 26^10 names
            continue
        except OSError as exc:
            raise InputError(path, f"cannot write here ({exc.strerror or exc})") from None


@contextlib.contextmanager
def atomic_path(path) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; on success rename it to ``path``, else delete it.

    The temporary exists (empty) when yielded; writers replace its content.

    Raises
    ------
    InputError
        ``path`` cannot be written (see :func:`create_temporary`), or the finished file cannot be
        moved to its name.
    """
    path = Path(path)
    tmp = create_temporary(path)
    try:
        try:
            yield tmp
        except OSError as exc:
            # The writer's own failure (a full disk, an I/O error): one line, nothing left.
            raise write_error(path, exc) from None
        try:
            os.replace(tmp, path)
        except OSError as exc:
            raise InputError(path, f"cannot write here ({exc.strerror or exc})") from None
        _remove_stale_temporaries(path)
    finally:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()


def _remove_stale_temporaries(path: Path) -> None:
    """Delete the temporaries of ``path`` a killed writer left (``kill -9`` between creating one
    and renaming it): once ``path`` is written, no other write of it is under way (a run's outputs
    are locked to it), so any other such sibling is a leftover."""
    pattern = re.compile(re.escape(f".{path.stem}.partial-") + "[a-z]{10}" + re.escape(path.suffix))
    with contextlib.suppress(OSError):
        for entry in os.scandir(path.parent):
            if pattern.fullmatch(entry.name):
                with contextlib.suppress(FileNotFoundError):
                    os.unlink(entry.path)


def write_reason(exc: BaseException) -> str:
    """Why a write failed, in a few words: the errno's text (an ``OSError``'s, or the one a
    library's exception names in its text, as HDF5's do), else the exception's first words."""
    import re

    code = getattr(exc, "errno", None)
    if code is None:
        found = re.search(r"errno = (\d+)", str(exc))
        code = int(found[1]) if found else None
    return os.strerror(code) if code else " ".join(str(exc).split())[:120]


def write_error(path, exc: BaseException) -> InputError:
    """The one-line error of a write to ``path`` that failed with ``exc``."""
    return InputError(path, f"cannot write ({write_reason(exc)})")


def atomic_write_text(path, text: str, encoding: str = "utf-8") -> None:
    """Write ``text`` to ``path`` atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding=encoding)


def atomic_write_bytes(path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
