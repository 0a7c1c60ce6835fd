"""Motion sources at the output frame rate, grounded and placed in the capture area.

A *motion source* gives canonical points (:mod:`.skeletons`) at any time in seconds:
:class:`BvhSource` (a BVH clip: root positions interpolated linearly, joint rotations by slerp
between the clip's frames, so 25/30/120 fps clips resample cleanly to 60 Hz) or
:class:`ProceduralSource` (:mod:`.motions`). :func:`sample_motion` samples one at a frame rate
and :func:`place_in_area`:

* **grounds** the subject: a constant vertical shift puts the planted ankles at their anatomical
  height (ankle 4 % and toe joint 1.2 % of the stature above the floor; 2nd percentile over the
  window so a jump does not lift the floor);
* **re-centres** the pelvis path on the capture area (x ∈ ±1.5 m, y ∈ ±1 m). A path longer
  than the area (a clip that walks 10 m) has its slow drift removed instead: the pelvis'
  horizontal trajectory low-passed with a 1.5 s Gaussian is subtracted from every point (the
  subject then walks as on a treadmill, feet slipping back slowly; the ground truth is the placed
  points, so images and truth stay consistent).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.ndimage import gaussian_filter1d

from ..errors import InputError
from .motions import MOTIONS, procedural_points
from .skeletons import CANONICAL_NAMES, bvh_canonical_points, detect_family

__all__ = ["AREA", "BvhSource", "ProceduralSource", "motion_source", "place_in_area",
           "sample_motion"]

#: Half-sizes (mm) of the capture area the pelvis path must stay in.
AREA = (1500.0, 1000.0)

_C = {name: i for i, name in enumerate(CANONICAL_NAMES)}

#: HumanEva action name of each procedural motion.
ACTIONS = {"walk": "Walking", "jog": "Jog", "box": "Box", "gestures": "Gestures",
           "throwcatch": "ThrowCatch"}


class ProceduralSource:
    """A built-in motion (unbounded in time)."""

    def __init__(self, kind: str, *, height: float, seed: int = 0):
        if kind not in MOTIONS:
            raise InputError("--motion", f"unknown motion {kind!r} (choose "
                                         f"{', '.join(MOTIONS)} or a .bvh file)")
        self.kind = kind
        self.name = kind
        self.height = float(height)
        self.seed = seed
        self.duration = np.inf
        self.action = ACTIONS[kind]

    def points(self, times) -> np.ndarray:
        """Canonical points ``(T, 20, 3)`` (mm) at ``times`` (s)."""
        return procedural_points(self.kind, times, height=self.height, seed=self.seed)


class BvhSource:
    """A BVH clip mapped to canonical points (skeleton family detected from joint names)."""

    def __init__(self, path, *, unit="auto"):
        from ..io.bvh import read_bvh

        self.path = Path(path)
        if self.path.suffix.lower() == ".amc":
            self.clip = _read_amc(self.path, unit)
        else:
            self.clip = read_bvh(self.path, unit=unit)
        self.family = detect_family(self.clip.names, source=self.path)
        self.name = self.path.name
        self.duration = (self.clip.n_frames - 1) * self.clip.frame_time
        self.action = "Combo"

    def points(self, times) -> np.ndarray:
        """Canonical points ``(T, 20, 3)`` (mm) at ``times`` (s from the clip's first frame)."""
        return bvh_canonical_points(self.clip, times, family=self.family)


def _read_amc(path: Path, unit):
    """An AMC motion with its ASF skeleton: ``<prefix>.asf`` beside ``<prefix>_<n>.amc`` (CMU)."""
    from ..io.asf import read_asf_amc

    candidates = [path.with_name(path.stem.split("_")[0] + ".asf"), path.with_suffix(".asf")]
    asf = next((p for p in candidates if p.exists()), None)
    if asf is None:
        raise InputError(path, f"no ASF skeleton beside it (looked for "
                               f"{', '.join(p.name for p in candidates)})")
    return read_asf_amc(asf, path, fps=120.0, unit=unit)


def motion_source(motion: str, *, height: float = 1750.0, seed: int = 0, unit="auto"):
    """A :class:`ProceduralSource` for a built-in name, else a :class:`BvhSource` for a file path."""
    if motion in MOTIONS:
        return ProceduralSource(motion, height=height, seed=seed)
    path = Path(motion)
    if path.suffix.lower() in (".bvh", ".amc") or path.exists():
        return BvhSource(path, unit=unit)
    raise InputError("--motion", f"unknown motion {motion!r} (choose {', '.join(MOTIONS)} "
                                 "or a .bvh file)")


def sample_motion(source, n_frames: int, fps: float, *, start: float = 0.0) -> np.ndarray:
    """Canonical points ``(n_frames, 20, 3)`` at ``start + k / fps``, ``k = 0 … n_frames − 1``.

    Raises
    ------
    InputError
        When the source is shorter than the requested span (names ``--frames``).
    """
    if n_frames < 1:
        raise InputError("--frames", f"must be at least 1, got {n_frames}")
    if not (np.isfinite(fps) and fps > 0):
        raise InputError("--fps", f"must be positive, got {fps}")
    if start < 0:
        raise InputError("--start", f"must be ≥ 0 s, got {start}")
    span = (n_frames - 1) / fps
    if start + span > source.duration + 1e-9:
        avail = int(np.floor((source.duration - start) * fps + 1e-9)) + 1
        raise InputError("--frames", f"{source.name} lasts {source.duration:.2f} s, which gives "
                                     f"at most {max(avail, 0)} frames at {fps:g} fps from "
                                     f"{start:g} s (camera lead frames included); asked for "
                                     f"{n_frames}")
    times = start + np.arange(n_frames) / fps
    return source.points(np.minimum(times, source.duration))


def stature_estimate(points) -> float:
    """Stature (mm) from canonical points: torso + head + hip-to-ankle + ankle height."""
    P = np.asarray(points, dtype=float)

    def seg(a, b):
        return float(np.median(np.linalg.norm(P[:, _C[a]] - P[:, _C[b]], axis=-1)))

    leg = seg("l_hip", "l_knee") + seg("l_knee", "l_ankle")
    return (seg("pelvis", "thorax") + seg("thorax", "head_top") + leg) / (1 - 0.04)


def place_in_area(points, fps: float, *, area=AREA) -> np.ndarray:
    """Ground the points and keep the pelvis path in the capture area (see module docstring).

    Parameters
    ----------
    points : (T, 20, 3) array_like
        Canonical points (mm).
    fps : float
        Their frame rate (for the drift filter).
    area : (2,) float
        Half-sizes of the capture area in x and y (mm).

    Returns
    -------
    (T, 20, 3) ndarray
        Placed copy.
    """
    P = np.array(points, dtype=float)
    H = stature_estimate(P)
    feet = np.minimum(np.minimum(P[:, _C["l_ankle"], 2], P[:, _C["r_ankle"], 2]) - 0.040 * H,
                      np.minimum(P[:, _C["l_toe"], 2], P[:, _C["r_toe"], 2]) - 0.012 * H)
    P[..., 2] -= np.percentile(feet, 2)
    pel = P[:, _C["pelvis"], :2]
    lo, hi = pel.min(axis=0), pel.max(axis=0)
    if np.all(hi - lo <= 2 * np.asarray(area)):
        P[..., :2] -= 0.5 * (lo + hi)
        return P
    drift = gaussian_filter1d(pel, sigma=1.5 * fps, axis=0, mode="nearest")
    P[..., :2] -= drift[:, None, :]
    pel = P[:, _C["pelvis"], :2]
    P[..., :2] -= 0.5 * (pel.min(axis=0) + pel.max(axis=0))
    return P
