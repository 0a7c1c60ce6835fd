"""The one TOML reader and writer: configs, ``sizes.toml``, body files, calibration TOML.

Every TOML file the package reads goes through :func:`read_toml` (or :func:`parse_toml` for text
already in memory, e.g. a config stored in a result file), so every such file fails the same
way: one :class:`~voxelmocap.errors.InputError` line naming the file and the problem — not
found, a folder, not UTF-8 text, invalid TOML — never a traceback. :func:`write_toml` writes
atomically (:mod:`voxelmocap.io._atomic`): a failed write leaves neither a partial file nor a
temporary one.

>>> parse_toml('voxel_size = 20.0', "example")
{'voxel_size': 20.0}
"""

from __future__ import annotations

from pathlib import Path

from ..errors import InputError
from ._atomic import atomic_write_text

try:  # Python ≥ 3.11
    import tomllib
except ModuleNotFoundError:  # pragma: no cover - Python 3.10
    import tomli as tomllib

__all__ = ["dumps_toml", "parse_toml", "read_toml", "write_toml"]


def parse_toml(text: str, source) -> dict:
    """Parse TOML text; :class:`InputError` naming ``source`` when it is not valid TOML.

    Parameters
    ----------
    text : str
        The TOML document.
    source : str or os.PathLike
        What the text is (a file name, ``"config"``), leading the error message.

    Returns
    -------
    dict
        The document's tables as nested dicts (TOML arrays as lists).
    """
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(source, f"invalid TOML ({exc})") from None
    except RecursionError:
        # tomllib recurses per nesting level of arrays and inline tables
        raise InputError(source, "invalid TOML (arrays or tables nested too deeply)") from None


def read_toml(path) -> dict:
    """Read and parse a TOML file (UTF-8; a leading byte-order mark is accepted).

    Raises
    ------
    InputError
        ``<path>: file not found``, ``is a folder, not a file``, ``not UTF-8 text (...)``,
        ``invalid TOML (...)`` or ``cannot read (...)``.
    """
    path = Path(path)
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        raise InputError(path, "file not found") from None
    except IsADirectoryError:
        raise InputError(path, "is a folder, not a file") from None
    except OSError as exc:
        raise InputError(path, f"cannot read ({exc.strerror or exc.__class__.__name__})") from None
    try:
        # utf-8-sig: editors on Windows start UTF-8 files with a byte-order mark
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise InputError(path, f"not UTF-8 text (byte {exc.start + 1} is 0x{data[exc.start]:02x}); "
                               "save the file as UTF-8") from None
    return parse_toml(text, path)


def dumps_toml(data: dict) -> str:
    """TOML text of nested dicts/lists of strings, numbers and booleans (no None: TOML has no null)."""
    import tomli_w

    return tomli_w.dumps(data)


def write_toml(path, data: dict) -> None:
    """Write ``data`` as a TOML file, atomically (UTF-8)."""
    atomic_write_text(Path(path), dumps_toml(data))
