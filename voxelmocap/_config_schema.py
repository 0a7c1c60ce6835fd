"""The configuration's schema: what each setting is, which values it takes, and the one check.

Every field of a configuration section (:mod:`voxelmocap.config`) is declared with
:func:`setting`, which puts its default and its rules into the field's metadata:

``doc``
    one line: what the setting is (its meaning; the units are in ``unit``).
``unit``
    the unit of a number (``"mm"``, ``"rad"``, ``"voxels"`` ...), ``""`` when it has none.
``range``
    ``(low, high)`` with ``low_open`` / ``high_open``; ``None`` for an open end, ``(None, None)``
    for a number that any finite value suits.
``choices``
    the strings the setting may take.
``each``
    the range or choices apply to every item of a tuple or every value of a table.
``says``
    the rule as the error message states it when the plain range wording (``> 0``,
    ``between 1 and 250``, ``in [0, 1)``) is not enough; a :meth:`str.format` template of
    ``low``, ``high`` and ``value``.
``checked_by``
    the function holding the rule when it lives outside the schema (the filter's options are
    checked by :func:`voxelmocap.tracking.apf.check_options`).

:func:`check_section` reads them; it is the one check, run by every section's
``__post_init__``, so a config read from TOML and a config built in Python are held to the same
rules and refused with the same one-line :class:`~voxelmocap.errors.InputError` naming the key.
Rules between fields are short per-class lists of :class:`Rule` (``_rules`` of the section).

>>> from dataclasses import dataclass
>>> @dataclass(frozen=True)
... class Demo(Section):
...     size: float = setting(20.0, "edge", unit="mm", gt=0)
>>> Demo(size=-1.0)
Traceback (most recent call last):
    ...
voxelmocap.errors.InputError: Demo: key 'size' must be > 0
"""

from __future__ import annotations

import dataclasses
import functools
import types
import typing
from collections.abc import Callable
from typing import ClassVar, NamedTuple

import numpy as np

from .errors import InputError

__all__ = ["Rule", "Section", "also", "check_section", "check_value", "range_text", "setting", "together"]


def setting(default=dataclasses.MISSING, doc: str = "", *, factory=dataclasses.MISSING,
            unit: str = "", ge=None, gt=None, le=None, lt=None, unbounded: bool = False,
            choices: tuple[str, ...] = (), each: bool = False, says: str | None = None,
            noun: str = "value", checked_by: str | None = None):
    """A configuration field: its default and its schema (module docstring).

    Parameters
    ----------
    default, factory
        The default value, or a callable making it (tables).
    doc : str
        One line: what the setting is.
    unit : str
        Unit of a number (``""``: none).
    ge, gt, le, lt : float, optional
        Bounds: ``>= ge`` or ``> gt``, ``<= le`` or ``< lt``.
    unbounded : bool
        A number any finite value suits (stated, so that a missing range is an omission).
    choices : tuple of str
        The legal strings.
    each : bool
        Bounds or choices apply to every item (tuples) or value (tables).
    says : str, optional
        Template of the rule in the error message (``low``, ``high``, ``value``).
    noun : str
        What an item of a tuple with ``choices`` is, for the message (``unknown format 'fbx'``).
    checked_by : str, optional
        Where the rule lives when outside the schema.
    """
    if "\n" in doc or not doc.strip():
        raise ValueError(f"a setting's doc is one line, got {doc!r}")  # programming error
    meta = {"doc": doc, "unit": unit, "each": each, "noun": noun}
    if ge is not None or gt is not None or le is not None or lt is not None or unbounded:
        meta.update(range=(gt if gt is not None else ge, lt if lt is not None else le),
                    low_open=gt is not None, high_open=lt is not None)
    if choices:
        meta["choices"] = tuple(choices)
    if says is not None:
        meta["says"] = says
    if checked_by is not None:
        meta["checked_by"] = checked_by
    if factory is not dataclasses.MISSING:
        return dataclasses.field(default_factory=factory, metadata=meta)
    return dataclasses.field(default=default, metadata=meta)


class Rule(NamedTuple):
    """A rule of a section beyond its fields' own: ``check(obj, key, source)`` raises
    :class:`InputError` when ``obj`` breaks it; ``key(name)`` is the dotted key of a field."""

    keys: tuple[str, ...]
    check: Callable


def together(*names: str) -> Rule:
    """Optional fields given all or none (``keys 'a' and 'b' go together``)."""
    def check(obj, key, source):
        if len({getattr(obj, name) is None for name in names}) > 1:
            raise InputError(source, f"keys {' and '.join(repr(key(n)) for n in names)} go "
                                     "together")
    return Rule(names, check)


def also(name: str, holds: Callable) -> Rule:
    """A condition on one field beyond its range (``order`` even), refused with the field's own
    message."""
    def check(obj, key, source):
        value = getattr(obj, name)
        if value is not None and not holds(value):
            meta = {f.name: f.metadata for f in dataclasses.fields(obj)}[name]
            shown = list(value) if isinstance(value, tuple) else value
            raise InputError(source, _range_problem(meta, key(name), shown))
    return Rule((name,), check)


class Section:
    """Base of the configuration sections: checked on construction by :func:`check_section`.

    ``_section`` is the section's dotted place in the TOML (``"measurement.silhouette"``),
    ``_rules`` its rules between fields.
    """

    _section: ClassVar[str] = ""
    _rules: ClassVar[tuple[Rule, ...]] = ()

    def __post_init__(self):
        check_section(self, self._section, type(self).__name__)


@functools.cache
def _hints(cls) -> dict:
    return typing.get_type_hints(cls)


def check_section(obj, prefix: str, source) -> None:
    """Check a section's values: types, then choices and ranges field by field, then its rules.

    Tuples and tables are normalised in place (``object.__setattr__``: the sections are frozen),
    so a config built from Python values equals the same config read from TOML; a nested section
    is already checked (its own ``__post_init__``).

    Raises
    ------
    InputError
        ``source: key 'prefix.name' <problem>``, the first problem found.
    """
    hints = _hints(type(obj))
    fields = dataclasses.fields(obj)

    def key(name):
        return f"{prefix}.{name}" if prefix else name

    for f in fields:
        hint, value = hints[f.name], getattr(obj, f.name)
        if dataclasses.is_dataclass(hint):
            if not isinstance(value, hint):
                raise InputError(source, f"key {key(f.name)!r} must be a {hint.__name__}, got "
                                         f"{value!r}")
            continue
        object.__setattr__(obj, f.name, check_value(value, hint, key(f.name), source))
    for f in fields:
        _check_field(f.metadata, getattr(obj, f.name), key(f.name), source)
    for rule in obj._rules:
        rule.check(obj, key, source)


def _check_field(meta, value, key: str, source) -> None:
    if value is None or ("choices" not in meta and "range" not in meta):
        return
    if meta["each"] and isinstance(value, dict):
        items = [(f"{key}.{name}", item) for name, item in value.items()]
    elif meta["each"]:
        items = [(key, item) for item in value]
    else:
        items = [(key, value)]
    choices = meta.get("choices")
    for item_key, item in items:
        if choices and item not in choices and meta["each"]:
            raise InputError(source, f"key {item_key!r}: unknown {meta['noun']} {item!r} (known: "
                                     f"{', '.join(choices)})")
        if choices and item not in choices:
            raise InputError(source, f"key {item_key!r} must be one of {', '.join(choices)}, "
                                     f"got {item!r}")
        if "range" in meta and not _inside(meta, item):
            shown = list(value) if isinstance(value, tuple) else item
            raise InputError(source, _range_problem(meta, item_key, shown))


def _inside(meta, value) -> bool:
    low, high = meta["range"]
    if low is not None and not (value > low if meta["low_open"] else value >= low):
        return False
    return high is None or (value < high if meta["high_open"] else value <= high)


def _range_problem(meta, key: str, value) -> str:
    low, high = meta["range"]
    if "says" in meta:
        return f"key {key!r} must be {meta['says'].format(low=low, high=high, value=value)}"
    return f"key {key!r} must be {range_text(meta)}"


def range_text(meta) -> str:
    """The range of a field's metadata in words: ``> 0``, ``between 1 and 250``, ``in [0, 1)``,
    ``between 0 and 0.5 (exclusive)``; ``any`` when unbounded."""
    low, high = meta["range"]
    lo, ho = meta["low_open"], meta["high_open"]
    if low is None and high is None:
        return "any"
    if high is None:
        return f"{'>' if lo else '>='} {low:g}"
    if low is None:
        return f"{'<' if ho else '<='} {high:g}"
    if lo == ho:
        return f"between {low:g} and {high:g}" + (" (exclusive)" if lo else "")
    return f"in {'(' if lo else '['}{low:g}, {high:g}{')' if ho else ']'}"


def check_value(value, hint, key: str, source):
    """``value`` converted to the type ``hint`` (``int``, ``float``, ``bool``, ``str``, tuples,
    ``dict[str, float]``, optional), or :class:`InputError` naming ``key``."""
    origin = typing.get_origin(hint)
    args = typing.get_args(hint)
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        inner = [a for a in args if a is not type(None)]
        return check_value(value, inner[0], key, source)
    if hint is bool:
        if not isinstance(value, bool):
            raise InputError(source, f"key {key!r} must be true or false, got {value!r}")
        return value
    if hint is int:
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
            raise InputError(source, f"key {key!r} must be an integer, got {value!r}")
        return int(value)
    if hint is float:
        if isinstance(value, bool) or not isinstance(value, (int, float, np.number)):
            raise InputError(source, f"key {key!r} must be a number, got {value!r}")
        if not np.isfinite(value):
            raise InputError(source, f"key {key!r} must be finite, got {value!r}")
        return float(value)
    if hint is str:
        if not isinstance(value, str):
            raise InputError(source, f"key {key!r} must be a string, got {value!r}")
        return value
    if origin is dict:
        if not isinstance(value, dict):
            raise InputError(source, f"key {key!r} must be a table, got {value!r}")
        out = {}
        for name, item in value.items():
            if not isinstance(name, str):
                raise InputError(source, f"key {key!r} must have string keys, got {name!r}")
            out[name] = check_value(item, args[1], f"{key}.{name}", source)
        return out
    if origin is tuple:
        if not isinstance(value, (list, tuple)):
            raise InputError(source, f"key {key!r} must be a list, got {value!r}")
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(check_value(v, args[0], key, source) for v in value)
        if len(value) != len(args):
            raise InputError(source, f"key {key!r} must have {len(args)} values, got {len(value)}")
        return tuple(check_value(v, a, key, source) for v, a in zip(value, args, strict=True))
    raise TypeError(f"unsupported config type {hint!r}")  # pragma: no cover - programming error


# ---------------------------------------------------------------------- the reference tables
def rule_words(meta) -> str:
    """A field's rule for the reference: its ``says`` up to the echoed value, else its range in
    words, else its choices; ``""`` for a field without one (booleans)."""
    if "says" in meta:
        low, high = meta["range"]
        return meta["says"].split(", got {value")[0].format(low=low, high=high)
    if "range" in meta:
        return ("each " if meta["each"] else "") + range_text(meta)
    if "choices" in meta:
        return ("each of " if meta["each"] else "") + ", ".join(f"`{c}`" for c in meta["choices"])
    if "checked_by" in meta:
        return f"`{meta['checked_by'].rsplit('.', 1)[-1]}`"
    return ""


def _toml(value) -> str:
    if value is None:
        return "unset"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, (tuple, list)):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k} = {_toml(v)}" for k, v in value.items()) + "}"
    return repr(value)


def reference_table(cls) -> str:
    """The Markdown table of a section for ``docs/usage.md``: key, default, range, unit, meaning
    (nested sections are left out: they have their own table)."""
    rows = ["| key | default | range | unit | meaning |", "|---|---|---|---|---|"]
    defaults = cls()
    for f in dataclasses.fields(cls):
        if dataclasses.is_dataclass(_hints(cls)[f.name]):
            continue
        cells = (f"`{f.name}`", f"`{_toml(getattr(defaults, f.name))}`", rule_words(f.metadata),
                 f.metadata["unit"], f.metadata["doc"])
        rows.append("| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |")
    return "\n".join(rows) + "\n"
