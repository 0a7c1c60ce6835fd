"""Tidy CSV of landmark trajectories: one row per frame and landmark.

Columns (comma-separated, a header row, UTF-8)::

    frame,time_s,landmark,x_mm,y_mm,z_mm,confidence,spread_mm,observed

``frame`` is the synchronised 1-based frame number, ``time_s`` = (frame − 1) / frame rate,
``x_mm … z_mm`` the position (empty when there is no estimate), ``confidence`` in [0, 1] and
``spread_mm`` the particle spread (:mod:`voxelmocap.pose.confidence`; empty when unknown),
``observed`` 1 when a person was seen in the frame, else 0. Rows are ordered by frame, then by
landmark. In OpenSim's Y-up axes (``axes="y_up"``) the position columns are ``x_yup_mm``,
``y_yup_mm``, ``z_yup_mm`` (:func:`columns`), so a column never holds another axis than its name
says. ``pandas.read_csv`` reads it as is; so does :func:`read_points_csv`, which also reads a
reference of named points (``frame``, ``landmark`` or ``marker`` or ``name``, and ``x_mm``,
``y_mm``, ``z_mm``, or ``x``, ``y``, ``z`` in mm, or ``x_m``, ``y_m``, ``z_m``, or the Y-up
columns).

>>> import numpy as np, tempfile, pathlib
>>> path = pathlib.Path(tempfile.mkdtemp()) / "a.csv"
>>> path = write_landmarks_csv(path, np.zeros((1, 1, 3)), ["head"], frames=[5], frame_rate=50.0)
>>> path.read_text().splitlines()[1]
'5,0.080000,head,0.000000,0.000000,0.000000,,,1'
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from ..errors import InputError
from ._atomic import atomic_write_text

__all__ = ["COLUMNS", "columns", "read_points_csv", "write_landmarks_csv"]

#: Frame numbers a reference may hold (int32).
MAX_FRAME = 2**31 - 1

#: The columns of the world-frame CSV.
COLUMNS = ("frame", "time_s", "landmark", "x_mm", "y_mm", "z_mm", "confidence", "spread_mm",
           "observed")
_POSITION_COLUMNS = {"world": ("x_mm", "y_mm", "z_mm"), "y_up": ("x_yup_mm", "y_yup_mm", "z_yup_mm")}


def columns(axes: str = "world") -> tuple[str, ...]:
    """The header of a CSV whose positions are in ``axes`` ("world" or "y_up")."""
    if axes not in _POSITION_COLUMNS:
        raise ValueError(f"axes must be one of {sorted(_POSITION_COLUMNS)}, got {axes!r}")
    return COLUMNS[:3] + _POSITION_COLUMNS[axes] + COLUMNS[6:]


def _cell(v: float) -> str:
    return "" if np.isnan(v) else f"{v:.6f}"


def write_landmarks_csv(path, positions, names, *, frames, frame_rate: float, confidence=None,
                        spread=None, observed=None, axes: str = "world") -> Path:
    """Write the tidy CSV (atomically).

    Parameters
    ----------
    path : str or os.PathLike
    positions : (F, M, 3) array_like
        mm; NaN → empty cells.
    names : sequence of str
        The M landmark names.
    frames : (F,) array_like of int
        Synchronised 1-based frame numbers.
    frame_rate : float
        Hz, for ``time_s``.
    confidence, spread : (F, M) array_like, optional
        Empty cells when absent or NaN.
    observed : (F,) array_like of bool, optional
        Default all observed.
    axes : {"world", "y_up"}
        The frame of ``positions``, named by the position columns (:func:`columns`).
    """
    x = np.asarray(positions, dtype=float)
    n, m = x.shape[:2]
    frames = np.asarray(frames, dtype=np.int64)
    conf = np.full((n, m), np.nan) if confidence is None else np.asarray(confidence, float)
    spr = np.full((n, m), np.nan) if spread is None else np.asarray(spread, float)
    obs = np.ones(n, bool) if observed is None else np.asarray(observed, bool)
    buffer = io.StringIO()
    out = csv.writer(buffer, lineterminator="\n")
    out.writerow(columns(axes))
    for i in range(n):
        time = f"{(frames[i] - 1) / float(frame_rate):.6f}"
        for j, name in enumerate(names):
            out.writerow([int(frames[i]), time, name, *(_cell(v) for v in x[i, j]),
                          _cell(conf[i, j]), _cell(spr[i, j]), int(obs[i])])
    atomic_write_text(path, buffer.getvalue())
    return Path(path)


_NAME_COLUMNS = ("landmark", "marker", "name")
# (position columns, to mm, the axes they declare: None = not said)
_COORDS = ((_POSITION_COLUMNS["world"], 1.0, None), (_POSITION_COLUMNS["y_up"], 1.0, "y_up"),
           (("x", "y", "z"), 1.0, None), (("x_m", "y_m", "z_m"), 1000.0, None))


def read_points_csv(path):
    """Named 3-D points from a CSV in the long layout (module docstring), in mm.

    Positions are returned in the file's axes; ``x_yup_mm …`` columns declare OpenSim's Y-up
    axes (``axes`` "y_up"), the other column names declare nothing (None).

    Returns
    -------
    names : list of str
        Point names in order of first appearance.
    frames : (F,) ndarray of int
        Sorted frame numbers.
    positions : (F, M, 3) ndarray
        mm; NaN where a point has no value in a frame.
    axes : str or None
        "y_up" for Y-up columns, else None.

    Raises
    ------
    InputError
        Missing file, missing columns, non-numeric values, a point given twice in a frame.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(path, "CSV file not found" if not path.exists() else "is not a file")
    try:
        text = path.read_text(encoding="utf-8-sig")
        if "\0" in text:
            line = text[:text.index("\0")].count("\n") + 1
            raise InputError(path, f"line {line} holds a NUL byte: not a CSV text file")
        rows = list(csv.reader(text.splitlines()))
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise InputError(path, f"cannot read the CSV file ({exc})") from None
    if not rows:
        raise InputError(path, "empty CSV file")
    header = [h.strip().lower() for h in rows[0]]
    name_col = next((c for c in _NAME_COLUMNS if c in header), None)
    coords = next((c for c in _COORDS if all(k in header for k in c[0])), None)
    if "frame" not in header or name_col is None or coords is None:
        raise InputError(path, "CSV needs columns frame, landmark (or marker, name) and x_mm, "
                               "y_mm, z_mm (or x, y, z in mm, or x_m, y_m, z_m, or x_yup_mm, "
                               "y_yup_mm, z_yup_mm)")
    fi, ni = header.index("frame"), header.index(name_col)
    ci = [header.index(c) for c in coords[0]]
    values: dict[tuple[int, str], list[float]] = {}
    names: list[str] = []
    for line, row in enumerate(rows[1:], start=2):
        if not any(cell.strip() for cell in row):
            continue
        if len(row) < len(header):
            raise InputError(path, f"line {line}: {len(row)} cells, the header has {len(header)}")
        try:
            frame = int(row[fi])
            xyz = [float(row[i]) if row[i].strip() else np.nan for i in ci]
        except ValueError:
            raise InputError(path, f"line {line}: frame or coordinate is not a number") from None
        if not -MAX_FRAME <= frame <= MAX_FRAME:
            raise InputError(path, f"line {line}: frame {row[fi][:24]} is out of range")
        if any(np.isinf(v) for v in xyz):  # an empty cell (NaN) is a missing value, inf is not
            raise InputError(path, f"line {line}: a coordinate is not finite")
        name = row[ni].strip()
        if (frame, name) in values:
            raise InputError(path, f"line {line}: {name!r} given twice for frame {frame}")
        if name not in names:
            names.append(name)
        values[(frame, name)] = xyz
    if not values:
        raise InputError(path, "CSV file has no data rows")
    frames = np.array(sorted({f for f, _ in values}), dtype=np.int64)
    row_of = {int(f): i for i, f in enumerate(frames)}
    col_of = {n: j for j, n in enumerate(names)}
    positions = np.full((len(frames), len(names), 3), np.nan)
    for (frame, name), xyz in values.items():
        positions[row_of[frame], col_of[name]] = xyz
    return names, frames, positions * coords[1], coords[2]
