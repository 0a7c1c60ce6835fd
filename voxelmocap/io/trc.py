"""TRC marker files (OpenSim, Pose2Sim): write landmark trajectories, read named 3-D points.

The layout is OpenSim's ``.trc`` with Pose2Sim's header conventions (``Pose2Sim/triangulation.py:
make_trc``): tab-separated, five header lines, then one row per frame::

    PathFileType  4  (X/Y/Z)  <file name>  Axes: <the frame>
    DataRate  CameraRate  NumFrames  NumMarkers  Units  OrigDataRate  OrigDataStartFrame  OrigNumFrames
    60  60  100  15  mm  60  1  100
    Frame#  Time  thorax  ''  ''  pelvis  ''  '' …
    ''  ''  X1  Y1  Z1  X2  Y2  Z2 …
    1  0.000000  x  y  z …

voxelmocap writes millimetres (``Units`` says so; Pose2Sim writes metres; ``units="m"`` for the
OpenSim hand-off) with six decimals, ``Frame#`` is the synchronised 1-based frame number and
``Time`` = (Frame# − 1) / DataRate, the time in the video. A missing value is ``NaN``, as OpenSim
writes it: OpenSim 4.6's reader counts the fields of a row and refuses one whose last marker is
empty (trailing tabs), so empty fields would break frames without a person.

The axes are named in a fifth field of the first line (:data:`AXES_NOTES`; OpenSim, Pose2Sim
and other readers take the first four and ignore it, where an extra key on line 2 makes OpenSim
refuse the file): ``Axes: Z up …`` for the calibration's world frame, ``Axes: Y up …`` for
OpenSim's. A TRC has no confidence column.

:func:`read_trc` reads any such file (also OpenSim's own, with a blank line after the header, and
Pose2Sim's in metres) into millimetres, and the axes when the file names them.

>>> import numpy as np, tempfile, pathlib
>>> path = pathlib.Path(tempfile.mkdtemp()) / "a.trc"
>>> path = write_trc(path, np.zeros((2, 1, 3)), ["head"], frame_rate=60.0, frames=[1, 2])
>>> read_trc(path).names
['head']
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError
from ._atomic import atomic_write_text

__all__ = ["AXES_NOTES", "TrcData", "read_trc", "write_trc"]

_HEADER_KEYS = ("DataRate", "CameraRate", "NumFrames", "NumMarkers", "Units", "OrigDataRate",
                "OrigDataStartFrame", "OrigNumFrames")
#: Length units a TRC may state, in mm.
UNITS_MM = {"mm": 1.0, "cm": 10.0, "m": 1000.0}
#: The fifth field of line 1 for each frame voxelmocap writes (see the module docstring).
AXES_NOTES = {
    "world": "Axes: Z up (the calibration's world frame, floor at Z = 0)",
    "y_up": "Axes: Y up (OpenSim; X = world Y, Y = world Z, Z = world X)",
}


@dataclass
class TrcData:
    """A TRC file's content, lengths in millimetres."""

    names: list  #: marker names, in column order
    frames: np.ndarray  #: (F,) the Frame# column
    time: np.ndarray  #: (F,) the Time column (s)
    positions: np.ndarray  #: (F, M, 3) mm, NaN where a value is missing
    frame_rate: float  #: DataRate (Hz)
    units: str  #: the file's Units (positions are converted to mm)
    axes: str | None = None  #: "world" or "y_up" when line 1 names them (:data:`AXES_NOTES`)


def write_trc(path, positions, names, *, frame_rate: float, frames=None, axes: str = "world",
              units: str = "mm", file_name: str | None = None) -> Path:
    """Write trajectories as a TRC file (atomically).

    Parameters
    ----------
    path : str or os.PathLike
        The ``.trc`` file.
    positions : (F, M, 3) array_like
        Marker positions (mm); NaN is written as ``NaN``.
    names : sequence of str
        The M marker names (no tab or newline).
    frame_rate : float
        DataRate and CameraRate (Hz).
    frames : (F,) array_like of int, optional
        Frame# of each row (default 1 … F); Time is (Frame# − 1) / frame_rate.
    axes : {"world", "y_up"}
        The frame of ``positions``, named on line 1 (:data:`AXES_NOTES`).
    units : {"mm", "m"}
        The file's units (``positions`` are converted from mm).
    file_name : str, optional
        The name on line 1 (default: ``path``'s; for a file written under a temporary name).

    Returns
    -------
    Path
    """
    path = Path(path)
    x = np.asarray(positions, dtype=float)
    names = [str(n) for n in names]
    if x.ndim != 3 or x.shape[2] != 3 or x.shape[1] != len(names):
        raise ValueError(f"write_trc: positions must be (F, {len(names)}, 3), got {x.shape}")
    if any(c in n for n in names for c in "\t\r\n") or any(not n for n in names):
        raise ValueError("write_trc: marker names must be non-empty and free of tabs/newlines")
    frames = np.arange(1, len(x) + 1) if frames is None else np.asarray(frames, dtype=np.int64)
    if frames.shape != (len(x),):
        raise ValueError(f"write_trc: {len(x)} frame numbers needed, got {frames.shape}")
    if axes not in AXES_NOTES:
        raise ValueError(f"write_trc: axes must be one of {sorted(AXES_NOTES)}, got {axes!r}")
    if units not in ("mm", "m"):
        raise ValueError(f"write_trc: units must be 'mm' or 'm', got {units!r}")
    x = x / UNITS_MM[units]
    digits = 6 if units == "mm" else 9  # µm either way
    n, m = x.shape[:2]
    rate = f"{float(frame_rate):g}"
    start = int(frames[0]) if n else 1
    lines = [
        f"PathFileType\t4\t(X/Y/Z)\t{file_name or path.name}\t{AXES_NOTES[axes]}",
        "\t".join(_HEADER_KEYS),
        "\t".join([rate, rate, str(n), str(m), units, rate, str(start), str(n)]),
        "Frame#\tTime\t" + "\t\t\t".join(names) + "\t\t",
        "\t\t" + "\t".join(f"X{i + 1}\tY{i + 1}\tZ{i + 1}" for i in range(m)),
    ]
    time = (frames - 1) / float(frame_rate)
    flat = x.reshape(n, 3 * m)
    for i in range(n):
        values = "\t".join("NaN" if np.isnan(v) else f"{v:.{digits}f}" for v in flat[i])
        lines.append(f"{int(frames[i])}\t{time[i]:.6f}\t{values}")
    atomic_write_text(path, "\n".join(lines) + "\n")
    return path


#: Frame numbers a reference may hold (int32, as C3D and every mocap system).
MAX_FRAME = 2**31 - 1


def _number(path, text: str, what: str, kind=float):
    try:
        value = kind(text)
    except ValueError:
        raise InputError(path, f"malformed TRC: {what} is {text[:24]!r}, not a number") from None
    if kind is float and not np.isfinite(value):
        raise InputError(path, f"malformed TRC: {what} is {text[:24]!r}")
    if kind is int and not -MAX_FRAME <= value <= MAX_FRAME:
        raise InputError(path, f"malformed TRC: {what} is {text[:24]}, out of range")
    return value


def read_trc(path) -> TrcData:
    """Read a TRC file (see the module docstring); lengths converted to mm.

    Raises
    ------
    InputError
        Missing or unreadable file, a header that is not a TRC's, unknown units, rows with a
        non-numeric value or more values than markers.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(path, "TRC file not found" if not path.exists() else "is not a file")
    try:
        text = path.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(path, f"cannot read the TRC file ({exc})") from None
    if "\0" in text:
        raise InputError(path, "holds a NUL byte: not a TRC text file")
    lines = text.splitlines()
    if len(lines) < 5 or not lines[0].startswith("PathFileType"):
        raise InputError(path, "not a TRC file (no 'PathFileType' header line)")
    keys = [k.strip() for k in lines[1].split("\t")]
    values = [v.strip() for v in lines[2].split("\t")]
    header = dict(zip(keys, values, strict=False))
    for key in ("DataRate", "NumMarkers", "Units"):
        if not header.get(key):
            raise InputError(path, f"malformed TRC header: no {key} value")
    rate = _number(path, header["DataRate"], "DataRate")
    if rate <= 0:
        raise InputError(path, f"malformed TRC header: DataRate {header['DataRate']}")
    units = header["Units"]
    if units.lower() not in UNITS_MM:
        raise InputError(path, f"unknown TRC units {units!r} (known: {', '.join(UNITS_MM)})")
    names = [n.strip() for n in lines[3].split("\t")[2:] if n.strip()]
    declared = _number(path, header["NumMarkers"], "NumMarkers", int)
    if declared != len(names):
        raise InputError(path, f"malformed TRC header: NumMarkers is {declared} but line 4 "
                               f"names {len(names)} markers")
    if len(set(names)) != len(names):
        dup = next(n for n in names if names.count(n) > 1)
        raise InputError(path, f"marker {dup!r} appears twice")
    m = len(names)
    frames, times, rows = [], [], []
    for number, line in enumerate(lines[5:], start=6):
        if not line.strip():
            continue
        cells = line.split("\t")
        if len(cells) < 2:
            raise InputError(path, f"line {number}: malformed TRC row (fewer than 2 columns)")
        extra = cells[2 + 3 * m:]
        if any(c.strip() for c in extra):
            raise InputError(path, f"line {number}: more values than {m} markers × 3")
        frames.append(_number(path, cells[0], f"line {number}'s Frame#", int))
        times.append(_number(path, cells[1], f"line {number}'s Time"))
        coords = cells[2:2 + 3 * m] + [""] * max(0, 3 * m - (len(cells) - 2))
        rows.append([_number(path, c, f"a value on line {number}")
                     if c.strip() and c.strip().lower() != "nan" else np.nan for c in coords])
    if not rows:
        raise InputError(path, "TRC file has no data rows")
    scale = UNITS_MM[units.lower()]
    positions = np.asarray(rows, dtype=float).reshape(len(rows), m, 3) * scale
    first = [c.strip() for c in lines[0].split("\t")]
    axes = next((k for k, note in AXES_NOTES.items() if len(first) > 4 and first[4] == note), None)
    return TrcData(names, np.asarray(frames, dtype=np.int64), np.asarray(times, dtype=float),
                   positions, float(rate), units, axes)
