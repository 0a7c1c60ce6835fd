"""Reading small text files with the one-line errors every command reports."""

from __future__ import annotations

from pathlib import Path

from ..errors import InputError

__all__ = ["is_float", "read_text_file"]


def is_float(token: str) -> bool:
    """Whether ``float(token)`` succeeds (to name the first bad value in an error)."""
    try:
        float(token)
    except ValueError:
        return False
    return True


def read_text_file(path, what: str, encoding: str = "utf-8") -> str:
    """The text of ``path``, or :class:`InputError` saying "<what> not found" / "cannot read <what>".

    Parameters
    ----------
    path : str or os.PathLike
        The file.
    what : str
        What the file is, for the message (e.g. ``"calibration file"``).
    encoding : str
        Text encoding; undecodable bytes are an error, not replaced.
    """
    path = Path(path)
    try:
        return path.read_text(encoding=encoding, errors="strict")
    except FileNotFoundError:
        raise InputError(path, f"{what} not found") from None
    except IsADirectoryError:
        raise InputError(path, f"is a folder, not a {what}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(path, f"cannot read {what} ({exc.__class__.__name__})") from None
