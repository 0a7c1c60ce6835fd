"""A 3-D reference for ``evaluate --reference``: named points (TRC or CSV) and a landmark mapping.

The **reference** is a TRC (:func:`voxelmocap.io.trc.read_trc`: any units it states, converted
to mm) or a CSV of named points (:func:`voxelmocap.io.csv_export.read_points_csv`), e.g. a
Pose2Sim or marker-based capture of the same recording, in the same world frame.

The **mapping** is a small TOML file saying which reference point each voxelmocap landmark is::

    [landmarks]                  # voxelmocap landmark = reference point, or the mean of two
    head = "Head"
    pelvis = ["RHip", "LHip"]
    l_knee = "LKnee"

    [reference]                  # optional
    axes = "y_up"                # the reference's axes: "world" (default) or OpenSim's Y up
    frame_offset = 0             # reference Frame# = result frame + frame_offset

A file that names its axes (voxelmocap's TRC on its first line, its CSV by the ``x_yup_mm …``
columns) is read in them; a mapping that says other axes is refused.

Landmarks left out of ``[landmarks]`` are not scored. Frames are matched by number (after the
offset); a TRC whose DataRate differs from the result's frame rate is refused, since its frame
numbers then count other instants.

>>> m = parse_mapping({"landmarks": {"head": "Head"}}, "map.toml")
>>> m.pairs
{'head': ('Head',)}
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError

__all__ = ["Mapping", "ReferencePoints", "aligned", "parse_mapping", "read_mapping",
           "read_reference"]

#: Reference Y-up (OpenSim) → world Z-up: the inverse of Pose2Sim's zup2yup (X ← Y, Y ← Z, Z ← X).
_FROM_Y_UP = [2, 0, 1]


@dataclass
class ReferencePoints:
    """Named 3-D points of a reference file, in mm."""

    names: list  #: point names
    frames: np.ndarray  #: (F,) frame numbers
    positions: np.ndarray  #: (F, N, 3) mm, NaN where missing
    frame_rate: float | None  #: Hz when the file states it (TRC), else None
    path: Path
    axes: str | None = None  #: "world" or "y_up" when the file names its axes, else None


@dataclass
class Mapping:
    """A parsed mapping file (module docstring)."""

    pairs: dict  #: voxelmocap landmark → tuple of one or two reference names
    axes: str | None = None  #: "world" or "y_up"; None: not said (the file's, else world)
    frame_offset: int = 0
    path: Path | str = "mapping"


def read_reference(path) -> ReferencePoints:
    """Read a ``.trc`` or ``.csv`` reference (by suffix).

    Raises
    ------
    InputError
        Another suffix, or what the format's reader refuses.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".trc":
        from .trc import read_trc

        trc = read_trc(path)
        return ReferencePoints(trc.names, trc.frames, trc.positions, trc.frame_rate, path,
                               trc.axes)
    if suffix == ".csv":
        from .csv_export import read_points_csv

        names, frames, positions, axes = read_points_csv(path)
        return ReferencePoints(names, frames, positions, None, path, axes)
    raise InputError(path, "expected a reference .trc or .csv file")


def parse_mapping(data: dict, source) -> Mapping:
    """Check a parsed mapping TOML (module docstring).

    Raises
    ------
    InputError
        Unknown tables or keys, an unknown voxelmocap landmark, a value that is not a point name
        or a list of two, bad ``axes`` or ``frame_offset``, no landmark at all.
    """
    from ..joints import LANDMARK_NAMES

    unknown = sorted(set(data) - {"landmarks", "reference"})
    if unknown:
        raise InputError(source, f"unknown table [{unknown[0]}] (known: [landmarks], [reference])")
    table = data.get("landmarks")
    if not isinstance(table, dict) or not table:
        raise InputError(source, "no [landmarks] table mapping voxelmocap landmarks to "
                                 "reference points")
    pairs = {}
    for name, value in table.items():
        if name not in LANDMARK_NAMES:
            raise InputError(source, f"unknown landmark {name!r} (known: "
                                     f"{', '.join(LANDMARK_NAMES)})")
        if isinstance(value, str) and value:
            pairs[name] = (value,)
        elif (isinstance(value, list) and len(value) == 2
              and all(isinstance(v, str) and v for v in value)):
            pairs[name] = tuple(value)
        else:
            raise InputError(source, f"landmarks.{name} must be a reference point name or a list "
                                     "of two (their mean)")
    ref = data.get("reference", {})
    if not isinstance(ref, dict):
        raise InputError(source, "[reference] must be a table")
    extra = sorted(set(ref) - {"axes", "frame_offset"})
    if extra:
        raise InputError(source, f"unknown key 'reference.{extra[0]}' (known: axes, "
                                 "frame_offset)")
    axes = ref.get("axes")
    if axes is not None and axes not in ("world", "y_up"):
        raise InputError(source, f"reference.axes must be 'world' or 'y_up', got {axes!r}")
    offset = ref.get("frame_offset", 0)
    if isinstance(offset, bool) or not isinstance(offset, int) or abs(offset) > 2**31 - 1:
        raise InputError(source, f"reference.frame_offset must be an integer within ±(2**31 - "
                                 f"1), got {offset!r}")
    return Mapping(pairs, axes, int(offset), source)


def read_mapping(path) -> Mapping:
    """Read and check a mapping TOML file."""
    from .toml import read_toml

    return parse_mapping(read_toml(path), Path(path))


def aligned(frames, landmarks, frame_rate: float, reference: ReferencePoints,
            mapping: Mapping, source="result"):
    """The estimate and the reference of the mapped landmarks, on the frames both have.

    Parameters
    ----------
    frames : (F,) array_like of int
        The result's frame numbers.
    landmarks : (F, 15, 3) array_like
        The result's landmarks (mm, world frame); NaN rows are left out later.
    frame_rate : float
        The result's frame rate (Hz).
    reference : ReferencePoints
    mapping : Mapping
    source : str or os.PathLike
        The result, named in errors.

    Returns
    -------
    names : list of str
        The mapped landmarks, in ``LANDMARK_NAMES`` order.
    frames : (K,) ndarray
        The result frames that the reference has.
    est, ref : (K, M, 3) ndarray
        mm, in the world frame.

    Raises
    ------
    InputError
        A mapped name the reference lacks (naming the mapping), other frame rates, no common
        frame.
    """
    from ..joints import LANDMARK_NAMES

    index = {n: i for i, n in enumerate(reference.names)}
    for name, points in mapping.pairs.items():
        for p in points:
            if p not in index:
                raise InputError(mapping.path, f"landmarks.{name}: {p!r} is not a point of "
                                               f"{reference.path.name}")
    if reference.frame_rate is not None and not np.isclose(reference.frame_rate, frame_rate,
                                                           rtol=1e-6):
        raise InputError(reference.path, f"DataRate {reference.frame_rate:g} Hz differs from "
                                         f"the result's {frame_rate:g} Hz: frame numbers "
                                         "cannot be matched")
    frames = np.asarray(frames, dtype=np.int64)
    wanted = frames + mapping.frame_offset
    row_of = {int(f): i for i, f in enumerate(reference.frames)}
    keep = np.array([int(f) in row_of for f in wanted], dtype=bool)
    if not keep.any():
        raise InputError(reference.path, f"no frame in common with {source} (result frames "
                                         f"{frames[0]}–{frames[-1]}, reference frames "
                                         f"{reference.frames.min()}–{reference.frames.max()}, "
                                         f"frame_offset {mapping.frame_offset})")
    rows = np.array([row_of[int(f)] for f in wanted[keep]])
    names = [n for n in LANDMARK_NAMES if n in mapping.pairs]
    pos = reference.positions[rows]
    if mapping.axes is not None and reference.axes is not None and mapping.axes != reference.axes:
        raise InputError(mapping.path, f"reference.axes is {mapping.axes!r} but "
                                       f"{reference.path.name} says its axes are "
                                       f"{reference.axes!r}")
    if (reference.axes or mapping.axes) == "y_up":
        pos = pos[..., _FROM_Y_UP]
    ref = np.stack([pos[:, [index[p] for p in mapping.pairs[n]]].mean(axis=1) for n in names],
                   axis=1)
    columns = [LANDMARK_NAMES.index(n) for n in names]
    est = np.asarray(landmarks, dtype=float)[keep][:, columns]
    return names, frames[keep], est, ref
