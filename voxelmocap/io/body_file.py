"""The subject body file ``<Subject>_body.toml`` (format ``voxelmocap-body-1``): reader and writer.

The contract (``docs/body_model.md``)::

    format = "voxelmocap-body-1"
    [subject]     name, height_mm
    [lengths_mm]  torso, head, and [left, right] pairs: shoulder_offset, shoulder_drop,
                  hip_offset, hip_drop, upper_arm, forearm, thigh, shin
    [widths_mm]   optional [left/lateral, right/front-back] half-width pairs: torso, chest, head,
                  upper_arm, forearm, thigh, shin (defaults: the average adult at this height)

Lengths are positive (the shoulder and hip drops may be 0). :func:`read_body_file` refuses a
file with a missing, unknown, wrongly typed, non-finite or non-positive key with one
:class:`~voxelmocap.errors.InputError` line naming the file and the key; :func:`write_body_file`
writes what the reader reads back to the same :class:`~voxelmocap.body.shapes.BodyDimensions`.

>>> from voxelmocap.body.shapes import BodyDimensions
>>> write_body_file("S1_body.toml", BodyDimensions.average(1700.0), "S1")    # doctest: +SKIP
>>> read_body_file("S1_body.toml").height                                   # doctest: +SKIP
1700.0
"""

from __future__ import annotations

import math
from dataclasses import asdict
from pathlib import Path

from ..body.shapes import LENGTH_KEYS, MAY_BE_ZERO, WIDTH_KEYS, BodyDimensions
from ..errors import InputError
from .toml import read_toml, write_toml

__all__ = ["FORMAT", "body_from_tables", "body_to_tables", "read_body_file", "write_body_file"]

FORMAT = "voxelmocap-body-1"


def read_body_file(path) -> BodyDimensions:
    """Read a ``<Subject>_body.toml`` file.

    Raises
    ------
    InputError
        Naming the file and the key: unreadable file, not UTF-8, invalid TOML, wrong format, a
        missing key, a non-positive, non-finite or wrongly typed value, an unknown key.
    """
    path = Path(path)
    return body_from_tables(read_toml(path), source=str(path))


def write_body_file(path, dimensions: BodyDimensions, name: str) -> None:
    """Write ``dimensions`` of subject ``name`` as a body file, atomically.

    Raises
    ------
    InputError
        Naming ``path`` when the dimensions break the contract (e.g. a zero length): nothing is
        written that :func:`read_body_file` would refuse.
    """
    tables = body_to_tables(dimensions, name)
    body_from_tables(tables, source=str(path))
    write_toml(path, tables)


def body_to_tables(dimensions: BodyDimensions, name: str) -> dict:
    """The body-file tables (``format``, ``subject``, ``lengths_mm``, ``widths_mm``) as dicts."""
    d = asdict(dimensions)
    return {
        "format": FORMAT,
        "subject": {"name": str(name), "height_mm": float(dimensions.height)},
        "lengths_mm": {k: _plain(d[k]) for k in LENGTH_KEYS},
        "widths_mm": {k: _plain(d[f"w_{k}"]) for k in WIDTH_KEYS},
    }


def body_from_tables(data: dict, *, source: str = "body file") -> BodyDimensions:
    """Validate the parsed tables of a body file; see :func:`read_body_file`."""
    if not isinstance(data, dict):
        raise InputError(source, "expected a table at the top level")
    unknown = sorted(set(data) - {"format", "subject", "lengths_mm", "widths_mm"})
    if unknown:
        raise InputError(source, f"unknown key {unknown[0]!r}")
    if data.get("format") != FORMAT:
        raise InputError(source, f"format must be {FORMAT!r}, got {data.get('format')!r}")
    subject = _table(data, "subject", source)
    unknown = sorted(set(subject) - {"name", "height_mm"})
    if unknown:
        raise InputError(source, f"unknown key 'subject.{unknown[0]}'")
    if "name" in subject and not isinstance(subject["name"], str):
        raise InputError(source, "subject.name must be a string")
    if "height_mm" not in subject:
        raise InputError(source, "missing key 'subject.height_mm'")
    height = _number(subject["height_mm"], "subject.height_mm", source)
    # the average adult at this height: the shape of every field and the default widths
    average = BodyDimensions.average(height)

    lengths_tab = _table(data, "lengths_mm", source)
    unknown = sorted(set(lengths_tab) - set(LENGTH_KEYS))
    if unknown:
        raise InputError(source, f"unknown key 'lengths_mm.{unknown[0]}'")
    lengths = {}
    for key in LENGTH_KEYS:
        if key not in lengths_tab:
            raise InputError(source, f"missing key 'lengths_mm.{key}'")
        name = f"lengths_mm.{key}"
        zero_ok = key in MAY_BE_ZERO
        if isinstance(getattr(average, key), tuple):
            lengths[key] = _pair(lengths_tab[key], name, source, zero_ok=zero_ok)
        else:
            lengths[key] = _number(lengths_tab[key], name, source, zero_ok=zero_ok)

    widths = {f"w_{k}": getattr(average, f"w_{k}") for k in WIDTH_KEYS}
    if "widths_mm" in data:
        widths_tab = _table(data, "widths_mm", source)
        unknown = sorted(set(widths_tab) - set(WIDTH_KEYS))
        if unknown:
            raise InputError(source, f"unknown key 'widths_mm.{unknown[0]}'")
        for key, value in widths_tab.items():
            widths[f"w_{key}"] = _pair(value, f"widths_mm.{key}", source)
    return BodyDimensions(height=height, **lengths, **widths)


# --------------------------------------------------------------------------------- helpers
def _plain(value):
    return [float(v) for v in value] if isinstance(value, tuple) else float(value)


def _table(data: dict, key: str, source: str) -> dict:
    if key not in data:
        raise InputError(source, f"missing table [{key}]")
    if not isinstance(data[key], dict):
        raise InputError(source, f"[{key}] must be a table")
    return data[key]


def _number(value, name: str, source: str, *, zero_ok: bool = False) -> float:
    # bool is an int subclass in Python; a TOML 'true' is a wrong type, not 1.0.
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise InputError(source, f"{name} must be a number, got {type(value).__name__}")
    value = float(value)
    if not math.isfinite(value):
        raise InputError(source, f"{name} must be finite, got {value}")
    if value < 0 or (value == 0 and not zero_ok):
        raise InputError(source, f"{name} must be {'≥' if zero_ok else '>'} 0, got {value}")
    return value


def _pair(value, name: str, source: str, *, zero_ok: bool = False) -> tuple[float, float]:
    if not isinstance(value, list) or len(value) != 2:
        raise InputError(source, f"{name} must be a [left, right] pair of numbers")
    return (_number(value[0], f"{name}[0]", source, zero_ok=zero_ok),
            _number(value[1], f"{name}[1]", source, zero_ok=zero_ok))
