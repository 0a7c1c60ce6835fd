"""Landmark exports of a tracking result: TRC, C3D and a tidy CSV (``docs/outputs.md``).

:func:`export_result` reads a result file (:mod:`voxelmocap.io.results`), builds its
:class:`LandmarkTable` and writes each requested format beside it (or into another folder):

* ``<Action>_<Trial>.trc`` (:mod:`.trc`), ``.c3d`` (:mod:`.c3d`), ``.csv`` (:mod:`.csv_export`);
* with a low-pass filter, ``<Action>_<Trial>_butterworth<f>Hz.<ext>``, so a filtered export never
  passes for the raw estimates;
* in OpenSim's Y-up axes (``axes="y_up"``), ``…_yup.<ext>``, so it never overwrites (or passes
  for) the world-frame files.

Every export carries the result's own frame rate (``frame_rate`` attribute), the landmark names
(``landmark_names``), millimetres and the calibration's world frame (or OpenSim's Y-up axes with
``axes="y_up"``), and says which frame: the TRC on its first line, the C3D in POINT:X_SCREEN /
Y_SCREEN, the CSV in its column names (``x_yup_mm …``). Rows cover every frame from the first
to the last tracked one at that rate; frames the result does not hold, and frames where no
person was observed, have no position. Smoothing (:func:`voxelmocap.smoothing.butterworth`) runs
on the positions after those gaps are cut, so it never bridges them.

>>> table = landmark_table(read_result("RUN/S1/Walking_1.h5"), cutoff_hz=6.0)  # doctest: +SKIP
>>> table.positions.shape, table.frame_rate                                    # doctest: +SKIP
((100, 15, 3), 60.0)
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError

__all__ = ["FORMATS", "LandmarkTable", "export_path", "export_result", "landmark_table",
           "parse_formats", "write_export"]

FORMATS = ("trc", "c3d", "csv")
#: Largest frame number exported (a 1 kHz recording of 24 days).
MAX_FRAME = 2**31 - 1
#: Most rows an export may span (frames from the first to the last tracked one).
MAX_EXPORT_ROWS = 1_000_000
#: Largest frame rate accepted (Hz).
MAX_FRAME_RATE = 1e5
#: Pose2Sim's Z-up → Y-up permutation (``Pose2Sim/common.py: zup2yup``): X ← Y, Y ← Z, Z ← X.
Y_UP = [1, 2, 0]
#: File-name tag of each frame (the world frame has none).
AXES_TAGS = {"world": "", "y_up": "_yup"}


@dataclass
class LandmarkTable:
    """Landmark trajectories ready for export (consecutive frames)."""

    frames: np.ndarray  #: (F,) synchronised 1-based frame numbers, consecutive
    positions: np.ndarray  #: (F, M, 3) mm; NaN: no estimate (not tracked, or not observed)
    confidence: np.ndarray  #: (F, M) in [0, 1]; NaN: unknown
    spread: np.ndarray  #: (F, M) mm; NaN: unknown
    observed: np.ndarray  #: (F,) bool; False also for frames the result does not hold
    names: list  #: the M landmark names
    frame_rate: float  #: Hz
    filter: str  #: "none" or a description of the low-pass filter
    axes: str  #: "world" or "y_up"

    @property
    def time(self) -> np.ndarray:
        """(F,) seconds since frame 1: (frame − 1) / frame_rate."""
        return (self.frames - 1) / self.frame_rate


def landmark_table(result, *, cutoff_hz: float | None = None, order: int = 4,
                   axes: str = "world", source="result") -> LandmarkTable:
    """The exportable trajectories of a :class:`~voxelmocap.io.results.TrackResult`.

    Parameters
    ----------
    result : TrackResult
    cutoff_hz : float, optional
        Zero-lag Butterworth cut-off (Hz); None: no filtering.
    order : int
        Order of the zero-lag filter.
    axes : {"world", "y_up"}
    source : str or os.PathLike
        Named in errors.

    Raises
    ------
    InputError
        An empty result, frames not increasing, a missing frame rate, a bad filter.
    """
    from ..joints import LANDMARK_NAMES
    from ..smoothing import butterworth, check_filter

    if axes not in ("world", "y_up"):
        raise InputError("axes", f"must be 'world' or 'y_up', got {axes!r}")
    frames = np.asarray(result.frames, dtype=np.int64)
    if len(frames) == 0:
        raise InputError(source, "the result holds no frame")
    if frames[0] < 1 or frames[-1] > MAX_FRAME:
        raise InputError(source, f"frame numbers {frames[0]}…{frames[-1]} are outside "
                                 f"1…{MAX_FRAME}")
    if np.any(np.diff(frames) <= 0):
        raise InputError(source, "frame numbers are not increasing")
    # One row per frame from the first to the last: a gap is rows of NaN, so the span is what
    # is allocated.
    span = int(frames[-1] - frames[0]) + 1
    if span > max(MAX_EXPORT_ROWS, 2 * len(frames)):
        raise InputError(source, f"frames {frames[0]}…{frames[-1]} span {span} rows for "
                                 f"{len(frames)} tracked frames: damaged frame numbers")
    given = result.attrs.get("frame_rate", np.nan)
    try:
        rate = (float(given) if isinstance(given, (int, float, np.number))
                and not isinstance(given, bool) else np.nan)
    except OverflowError:
        rate = np.nan
    if not (np.isfinite(rate) and 0 < rate <= MAX_FRAME_RATE):
        raise InputError(source, f"the result's frame_rate attribute {given!r:.40} is not a "
                                 f"number of Hz in (0, {MAX_FRAME_RATE:g}]")
    names = list(result.attrs.get("landmark_names") or LANDMARK_NAMES)
    landmarks = np.asarray(result.landmarks)
    if landmarks.ndim != 3 or landmarks.shape[1] != len(names) or landmarks.shape[2] != 3:
        raise InputError(source, f"{len(names)} landmark names for landmarks of shape "
                                 f"{landmarks.shape}: damaged result")
    dense = np.arange(frames[0], frames[-1] + 1)
    rows = frames - frames[0]
    n, m = len(dense), len(names)
    positions = np.full((n, m, 3), np.nan)
    confidence = np.full((n, m), np.nan)
    spread = np.full((n, m), np.nan)
    observed = np.zeros(n, bool)
    observed[rows] = np.asarray(result.observed, bool)
    positions[rows] = result.landmarks
    positions[~observed] = np.nan  # no person, no position
    confidence[rows] = result.confidence
    spread[rows] = result.landmark_spread
    description = "none"
    if cutoff_hz is not None:
        check_filter(rate, cutoff_hz, order, source="--smooth")
        positions = butterworth(positions, rate, cutoff_hz=cutoff_hz, order=order)
        description = f"zero-lag Butterworth low-pass, {cutoff_hz:g} Hz, order {order}"
    if axes == "y_up":
        positions = positions[..., Y_UP]
    return LandmarkTable(dense, positions, confidence, spread, observed, names, rate,
                         description, axes)


def export_path(result_path, fmt: str, cutoff_hz: float | None = None, out_dir=None,
                axes: str = "world") -> Path:
    """Where :func:`export_result` writes format ``fmt`` of a result (module docstring)."""
    result_path = Path(result_path)
    folder = result_path.parent if out_dir is None else Path(out_dir)
    tag = "" if cutoff_hz is None else f"_butterworth{cutoff_hz:g}Hz"
    return folder / f"{result_path.stem}{tag}{AXES_TAGS[axes]}.{fmt}"


def write_export(table: LandmarkTable, fmt: str, path) -> Path:
    """Write one format of a table (atomically)."""
    if fmt == "trc":
        from .trc import write_trc

        return write_trc(path, table.positions, table.names, frame_rate=table.frame_rate,
                         frames=table.frames, axes=table.axes)
    if fmt == "csv":
        from .csv_export import write_landmarks_csv

        return write_landmarks_csv(path, table.positions, table.names, frames=table.frames,
                                   frame_rate=table.frame_rate, confidence=table.confidence,
                                   spread=table.spread, observed=table.observed,
                                   axes=table.axes)
    if fmt == "c3d":
        from .c3d import write_c3d

        return write_c3d(path, table.positions, table.names, frame_rate=table.frame_rate,
                         first_frame=int(table.frames[0]), residuals=table.spread,
                         axes=table.axes)
    raise InputError("format", f"unknown export format {fmt!r} (known: {', '.join(FORMATS)})")


def parse_formats(text, source="--format") -> tuple[str, ...]:
    """``"trc,csv"`` (or a sequence) → ``("trc", "csv")``; ``"none"`` or empty → ``()``."""
    items = text.split(",") if isinstance(text, str) else list(text)
    formats = tuple(dict.fromkeys(f.strip().lower() for f in items if f.strip()))
    if formats == ("none",):
        return ()
    if not formats:
        raise InputError(source, f"no format given (known: {', '.join(FORMATS)}, or none)")
    unknown = [f for f in formats if f not in FORMATS]
    if unknown:
        raise InputError(source, f"unknown format {unknown[0]!r} (known: {', '.join(FORMATS)}, "
                                 "or none)")
    return formats


def export_result(result_path, formats, *, cutoff_hz: float | None = None, order: int = 4,
                  axes: str = "world", out_dir=None, result=None) -> list[Path]:
    """Write the exports of one result file.

    Parameters
    ----------
    result_path : str or os.PathLike
        ``RUN/<Subject>/<Action>_<Trial>.h5``.
    formats : sequence of str
        Of :data:`FORMATS`.
    cutoff_hz, order, axes
        As for :func:`landmark_table`.
    out_dir : str or os.PathLike, optional
        Folder of the exports (default: the result's).
    result : TrackResult, optional
        The result, when already read.

    Returns
    -------
    list of Path
    """
    from .results import read_result

    if not formats:
        return []
    result = read_result(result_path) if result is None else result
    table = landmark_table(result, cutoff_hz=cutoff_hz, order=order, axes=axes,
                           source=result_path)
    return [write_export(table, fmt, export_path(result_path, fmt, cutoff_hz, out_dir, axes))
            for fmt in formats]
