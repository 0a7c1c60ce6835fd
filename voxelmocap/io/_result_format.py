"""The result file's format: what it holds, its in-memory form and checkpoints as bytes.

:mod:`voxelmocap.io.results` describes the file; :mod:`._result_writer` writes it and
:mod:`._result_reader` reads it.
"""

from __future__ import annotations

import io
import json
from dataclasses import dataclass, field

import h5py
import numpy as np

FORMAT = "voxelmocap tracking result"
FORMAT_VERSION = 3
#: Datasets added in format 3, and what an older file reads as (see :class:`TrackResult`).
_ADDED_IN_3 = ("landmark_spread", "confidence", "observed")

#: Per-frame datasets: name → (units, description).
PER_FRAME: dict[str, tuple[str, str]] = {
    "frames": ("1", "synchronised 1-based frame number"),
    "state": ("mm (translation), rad (angles)", "the estimate: weighted mean of the last "
              "annealing layer, clipped to the legal ranges; names in state_names"),
    "landmarks": ("mm", "the 15 landmarks of the estimate, names in landmark_names"),
    "endpoints": ("mm", "the 20 body_pose endpoints of the estimate, names in endpoint_names"),
    "part_scores": ("1", "Out, DO, Empty, Surf of each body part of the estimate (part_names, "
                    "score_names)"),
    "ess": ("particles", "effective sample size of each annealing layer"),
    "betas": ("1", "likelihood exponent of each annealing layer"),
    "seconds": ("s", "wall time of the frame: measurement, initialisation and filter"),
    "log_likelihood": ("1", "log-likelihood of the estimate (paper 002 eqs 7-9)"),
    "map_state": ("mm (translation), rad (angles)", "the particle of largest last-layer weight"),
    "landmark_spread": ("mm", "weighted RMS distance of each landmark over the particles, "
                        "the variances of every partition's last layer added "
                        "(voxelmocap.pose.confidence.searched_spread; NaN: unknown)"),
    "confidence": ("1", "confidence of each landmark in [0, 1]: voxel support of its parts x "
                   "P(error < 100 mm) for the particles' spread (voxelmocap.pose.confidence)"),
    "observed": ("1", "1 when a person was seen in the frame, 0 when not (then the estimate "
                 "is the filter's prediction)"),
}
#: What a record without the format-3 attributes (e.g. one made before them) writes.
_ROW_DEFAULTS = {"landmark_spread": np.full(15, np.nan), "confidence": np.full(15, np.nan),
                 "observed": 1}
_INT_ROWS = {"frames"}
_UINT8_ROWS = {"observed"}
_CHUNK_ROWS = 64  # rows per chunk: a few kB per dataset, rewritten at most once per frame
_STR = h5py.string_dtype("utf-8")
_LOCKING = False  # this module's own flock guards the file; HDF5's would block its readers
_SCORE_NAMES = ("out", "do", "empty", "surf")
_HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"
#: How long a reader keeps retrying a file whose writer moves under it (each try: milliseconds).
_LIVE_READ_SECONDS = 5.0
#: How long a new writer waits out readers' momentary shared locks before calling a file busy.
_LOCK_PATIENCE_SECONDS = 0.5
_COORDINATE_FRAME = ("world frame of the cameras' calibration: right-handed, Z up, floor at Z = 0,"
                     " lengths in mm")


@dataclass
class TrackResult:
    """In-memory form of a result file (per-frame arrays stacked along axis 0).

    ``attrs`` holds the file's attributes and ``complete`` (whether the run finished);
    ``checkpoint`` the filter state after the last frame (None when the file has none).
    """

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
    #: (F, 15) mm; NaN when unknown (results before format 3)
    landmark_spread: np.ndarray | None = None
    #: (F, 15) in [0, 1]; NaN when unknown
    confidence: np.ndarray | None = None
    #: (F,) bool; all True when unknown
    observed: np.ndarray | None = None

    def __post_init__(self) -> None:
        n = len(self.frames)
        if self.landmark_spread is None:
            self.landmark_spread = np.full((n, 15), np.nan)
        if self.confidence is None:
            self.confidence = np.full((n, 15), np.nan)
        self.observed = (np.ones(n, dtype=bool) if self.observed is None
                         else np.asarray(self.observed, dtype=bool))

    def __len__(self) -> int:
        return len(self.frames)


# ---------------------------------------------------------------------- checkpoints as bytes
def _pack_checkpoint(state: dict) -> np.ndarray:
    """A filter state (arrays, numbers, strings, dicts, None) as the bytes of an ``.npz``."""
    arrays = {k: v for k, v in state.items() if isinstance(v, np.ndarray)}
    scalars = {k: v for k, v in state.items() if not isinstance(v, np.ndarray)}
    if any(a.dtype.hasobject for a in arrays.values()):
        raise TypeError("cannot store object arrays in a checkpoint")
    text = json.dumps(scalars, default=_json_default).encode()
    buffer = io.BytesIO()
    np.savez(buffer, __scalars__=np.frombuffer(text, dtype=np.uint8), **arrays)
    return np.frombuffer(buffer.getvalue(), dtype=np.uint8)


def _json_default(value):
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.floating):
        return float(value)
    raise TypeError(f"cannot store {type(value).__name__} in a checkpoint")


def _unpack_checkpoint(data: np.ndarray) -> dict:
    with np.load(io.BytesIO(np.asarray(data, dtype=np.uint8).tobytes()),
                 allow_pickle=False) as z:
        state = json.loads(bytes(z["__scalars__"]).decode())
        for key in z.files:
            if key != "__scalars__":
                state[key] = z[key]
    return state
