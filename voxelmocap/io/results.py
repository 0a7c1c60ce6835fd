"""Tracking results in HDF5: one file per sequence, rewritten atomically after every frame.

``RUN/<Subject>/<Action>_<Trial>.h5`` holds

* datasets ``frames`` (F,) synchronised 1-based frame numbers, ``state`` (F, 27), ``state_names``,
  ``landmarks`` (F, 15, 3) mm, ``endpoints`` (F, 20, 3) mm, ``part_scores`` (F, n_parts, 4) of the
  estimate (Out, DO, Empty, Surf), ``part_names``, ``ess`` and ``betas`` (F, L) per annealing layer,
  ``seconds`` (F,) per frame, ``log_likelihood`` (F,) of the estimate, ``map_state`` (F, 27);
* attributes ``config`` (the TOML used), ``seed``, ``subject``, ``action``, ``trial``, ``dataset``,
  ``cameras``, ``init_method``, ``frames_requested`` and ``complete`` (False while running);
* group ``checkpoint``: the filter's full state after the last completed frame, so that ``--resume``
  continues bit-identically.

Because the file is replaced atomically (temporary file + rename) after each frame, an interrupted
run leaves the last completed frame on disk and never a half-written file.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

from ..errors import InputError
from ._atomic import atomic_path

__all__ = ["TrackResult", "read_result", "write_result"]

_PER_FRAME = ("frames", "state", "landmarks", "endpoints", "part_scores", "ess", "betas",
              "seconds", "log_likelihood", "map_state")


@dataclass
class TrackResult:
    """In-memory form of a result file (per-frame arrays stacked along axis 0)."""

    frames: np.ndarray
    state: np.ndarray
    landmarks: np.ndarray
    endpoints: np.ndarray
    part_scores: np.ndarray
    ess: np.ndarray
    betas: np.ndarray
    seconds: np.ndarray
    log_likelihood: np.ndarray
    map_state: np.ndarray
    state_names: list = field(default_factory=list)
    part_names: list = field(default_factory=list)
    attrs: dict = field(default_factory=dict)
    checkpoint: dict | None = None

    def __len__(self) -> int:
        return len(self.frames)


def _write_checkpoint(group: h5py.Group, state: dict) -> None:
    scalars = {}
    for key, value in state.items():
        if isinstance(value, np.ndarray):
            group.create_dataset(key, data=value)
        elif value is None:
            scalars[key] = None
        else:
            scalars[key] = value
    group.attrs["scalars"] = json.dumps(scalars, default=_json_default)


def _json_default(value):
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.floating):
        return float(value)
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"cannot store {type(value).__name__} in a checkpoint")


def _read_checkpoint(group: h5py.Group) -> dict:
    state = json.loads(group.attrs["scalars"])
    for key in group:
        state[key] = group[key][()]
    return state


def write_result(path, result: TrackResult) -> None:
    """Write (replace) a result file atomically."""
    path = Path(path)
    with atomic_path(path) as tmp:
        with h5py.File(tmp, "w") as f:
            for name in _PER_FRAME:
                f.create_dataset(name, data=np.asarray(getattr(result, name)))
            f.create_dataset("state_names", data=np.array(result.state_names, dtype="S"))
            f.create_dataset("part_names", data=np.array(result.part_names, dtype="S"))
            for key, value in result.attrs.items():
                f.attrs[key] = value
            if result.checkpoint is not None:
                _write_checkpoint(f.create_group("checkpoint"), result.checkpoint)


def _check_shapes(path, data: dict) -> None:
    n = len(np.atleast_1d(data["frames"]))
    expected = {"frames": (n,), "state": (n, None), "landmarks": (n, 15, 3),
                "endpoints": (n, 20, 3), "part_scores": (n, None, 4), "ess": (n, None),
                "betas": (n, None), "seconds": (n,), "log_likelihood": (n,),
                "map_state": (n, None)}
    for name, shape in expected.items():
        got = np.shape(data[name])
        if len(got) != len(shape) or any(e is not None and g != e for g, e in zip(got, shape, strict=True)):
            want = "×".join("*" if e is None else str(e) for e in shape)
            raise InputError(path, f"dataset {name!r} has shape {got}, expected {want}")


def read_result(path) -> TrackResult:
    """Read a result file written by :func:`write_result`.

    Raises
    ------
    InputError
        Missing file, not HDF5, or a file lacking the result datasets.
    """
    path = Path(path)
    if not path.exists():
        raise InputError(path, "result file not found")
    try:
        with h5py.File(path, "r") as f:
            missing = [n for n in (*_PER_FRAME, "state_names", "part_names") if n not in f]
            if missing:
                raise InputError(path, f"not a voxelmocap result file (no {missing[0]!r} dataset)")
            data = {n: f[n][()] for n in _PER_FRAME}
            _check_shapes(path, data)
            checkpoint = None
            if "checkpoint" in f:
                if "scalars" not in f["checkpoint"].attrs:
                    raise InputError(path, "damaged checkpoint (no 'scalars' attribute)")
                try:
                    checkpoint = _read_checkpoint(f["checkpoint"])
                except ValueError as exc:
                    raise InputError(path, f"damaged checkpoint ({exc})") from None
            return TrackResult(
                **data,
                state_names=[s.decode() for s in f["state_names"][()]],
                part_names=[s.decode() for s in f["part_names"][()]],
                attrs={k: (v.item() if isinstance(v, np.generic) else v)
                       for k, v in f.attrs.items()},
                checkpoint=checkpoint,
            )
    except OSError as exc:
        raise InputError(path, f"cannot read HDF5 result file ({exc})") from None
