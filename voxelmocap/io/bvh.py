"""BVH motion files: reading any skeleton into HumanEva's world (mm, Z up), and writing.

A BVH file has a ``HIERARCHY`` (joints with an ``OFFSET`` from their parent and a list of
``CHANNELS``) and a ``MOTION`` block (``Frames:``, ``Frame Time:`` and one row of channel values per
frame). This reader takes the channels per joint from the file, so skeletons where every joint has
six channels (Bandai Namco) read as well as those with rotations only (CMU); any Euler order is
honoured (``Zrotation Xrotation Yrotation`` means ``R = Rz · Rx · Ry`` applied to child vectors).

Conventions of the result (:class:`BvhClip`):

* ``End Site`` entries become extra leaf joints named ``<parent>_End`` without channels.
* A joint with position channels uses them as its translation from the parent (they replace the
  ``OFFSET``, which holds the rest value); other joints translate by their ``OFFSET``.
* Positions are converted from the BVH world (Y up, units of the file) to HumanEva's world
  (millimetres, Z up, right-handed): ``(x, y, z)_bvh → (x, −z, y)_he · scale``, so the BVH's
  forward ``+Z`` becomes ``−Y``.
* The unit scale (file units → mm) is given or, with ``unit="auto"``, guessed from the skeleton's
  size among mm, cm, m, inch and the CMU unit (0.05644 m; see :data:`UNITS`).

>>> clip = read_bvh("walk.bvh")                                  # doctest: +SKIP
>>> clip.positions().shape                                       # doctest: +SKIP
(599, 190, 3)
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from ..errors import InputError
from ._atomic import atomic_write_text
from ._files import is_float, read_text_file

__all__ = ["UNITS", "YUP_TO_ZUP", "BvhClip", "read_bvh", "write_bvh"]

#: File unit name → millimetres per unit, for ``unit=`` and the automatic guess.
UNITS: dict[str, float] = {
    "mm": 1.0,
    "cm": 10.0,
    "m": 1000.0,
    "inch": 25.4,
    "cmu": 56.444,  # CMU ASF "length 0.45": 1 unit = (1/0.45) inch = 0.05644 m
}

#: Rotation taking BVH world coordinates (Y up) to HumanEva's (Z up): x → x, y → z, z → −y.
YUP_TO_ZUP = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])

_CHANNELS = ("Xposition", "Yposition", "Zposition", "Xrotation", "Yrotation", "Zrotation")
_TYPICAL_SIZE_MM = 1700.0  # what the automatic unit guess aims at (see _guess_scale)


@dataclass(eq=False)
class BvhClip:
    """A parsed BVH clip.

    Attributes
    ----------
    names : list of str, length J
        Joint names in file order (``End Site`` entries as ``<parent>_End``).
    parents : (J,) int ndarray
        Parent index of each joint, −1 for the root.
    offsets : (J, 3) float ndarray
        ``OFFSET`` of each joint in file units, BVH axes.
    channels : list of tuple of str, length J
        Channel names of each joint, in file order (empty for end sites).
    channel_start : (J,) int ndarray
        Column of each joint's first channel in :attr:`motion`.
    motion : (F, C) float ndarray
        Channel values per frame (file units and degrees).
    frame_time : float
        Seconds per frame.
    scale : float
        Millimetres per file unit used by :meth:`positions`.
    source : str
        The file read (for messages).
    pre_rotation : (J, 3, 3) float ndarray or None
        Constant rotation applied before each joint's channel rotation (local = pre · channels);
        None for BVH files (identity). ASF/AMC clips use it (:mod:`voxelmocap.io.asf`).
    """

    names: list[str]
    parents: np.ndarray
    offsets: np.ndarray
    channels: list[tuple[str, ...]]
    channel_start: np.ndarray
    motion: np.ndarray
    frame_time: float
    scale: float = 10.0
    source: str = "<bvh>"
    pre_rotation: np.ndarray | None = None

    @property
    def n_frames(self) -> int:
        """Number of frames F."""
        return int(self.motion.shape[0])

    @property
    def fps(self) -> float:
        """Frame rate (Hz)."""
        return 1.0 / self.frame_time

    def index(self, name: str) -> int:
        """Index of a joint by exact name (``KeyError`` if absent)."""
        try:
            return self.names.index(name)
        except ValueError:
            raise KeyError(name) from None

    def _frames(self, frames) -> np.ndarray:
        if frames is None:
            return self.motion
        return self.motion[np.asarray(frames)]

    def local_transforms(self, frames=None) -> tuple[np.ndarray, np.ndarray]:
        """Per-joint local rotation ``(F, J, 3, 3)`` and translation ``(F, J, 3)`` (file units, BVH axes)."""
        data = self._frames(frames)
        n, J = data.shape[0], len(self.names)
        rot = np.broadcast_to(np.eye(3), (n, J, 3, 3)).copy()
        trans = np.broadcast_to(self.offsets, (n, J, 3)).copy()
        for j, chans in enumerate(self.channels):
            if not chans:
                continue
            start = self.channel_start[j]
            pos_cols = [k for k, c in enumerate(chans) if c.endswith("position")]
            if pos_cols:
                t = trans[:, j].copy()
                for k in pos_cols:
                    t[:, "XYZ".index(chans[k][0])] = data[:, start + k]
                trans[:, j] = t
            rot_cols = [k for k, c in enumerate(chans) if c.endswith("rotation")]
            if rot_cols:
                order = "".join(chans[k][0] for k in rot_cols)
                angles = data[:, start + np.array(rot_cols)]
                # Upper-case axes: intrinsic rotations, i.e. R = R_first · R_second · R_third.
                rot[:, j] = Rotation.from_euler(order, angles, degrees=True).as_matrix()
        if self.pre_rotation is not None:
            rot = self.pre_rotation[None] @ rot
        return rot, trans

    def global_transforms(self, frames=None) -> tuple[np.ndarray, np.ndarray]:
        """World rotation ``(F, J, 3, 3)`` and position ``(F, J, 3)`` in file units and BVH axes."""
        return self.forward_kinematics(*self.local_transforms(frames))

    def forward_kinematics(self, rot, trans) -> tuple[np.ndarray, np.ndarray]:
        """Compose local rotations ``(F, J, 3, 3)`` and translations ``(F, J, 3)`` down the tree.

        Returns world rotations and positions in file units and BVH axes.
        """
        g_rot = np.empty_like(rot)
        g_pos = np.empty_like(trans)
        for j, p in enumerate(self.parents):
            if p < 0:
                g_rot[:, j] = rot[:, j]
                g_pos[:, j] = trans[:, j]
            else:
                g_rot[:, j] = g_rot[:, p] @ rot[:, j]
                g_pos[:, j] = g_pos[:, p] + np.einsum("fij,fj->fi", g_rot[:, p], trans[:, j])
        return g_rot, g_pos

    def positions(self, frames=None) -> np.ndarray:
        """Joint positions ``(F, J, 3)`` in HumanEva's world: millimetres, Z up.

        Parameters
        ----------
        frames : array_like of int, optional
            0-based frame indices (default: all frames).
        """
        _, pos = self.global_transforms(frames)
        return (pos @ YUP_TO_ZUP.T) * self.scale

    def rotations(self, frames=None) -> np.ndarray:
        """Joint world rotations ``(F, J, 3, 3)`` expressed in HumanEva's axes.

        ``rotations()[f, j] @ (YUP_TO_ZUP @ v)`` is the HumanEva-world direction of a vector ``v``
        given in joint ``j``'s local BVH axes.
        """
        rot, _ = self.global_transforms(frames)
        return YUP_TO_ZUP @ rot @ YUP_TO_ZUP.T

    def children(self, j: int) -> list[int]:
        """Indices of the direct children of joint ``j``."""
        return [k for k, p in enumerate(self.parents) if p == j]

    def __repr__(self) -> str:
        return (f"BvhClip({Path(self.source).name!r}, joints={len(self.names)}, "
                f"frames={self.n_frames}, fps={self.fps:.4g}, scale={self.scale:g} mm/unit)")


# ---------------------------------------------------------------------- reading
def _tokens_with_lines(text: str):
    for lineno, line in enumerate(text.splitlines(), start=1):
        for tok in line.split():
            yield tok, lineno


def read_bvh(path, *, unit: str | float = "auto") -> BvhClip:
    """Read a BVH file.

    Parameters
    ----------
    path : str or os.PathLike
        The ``.bvh`` file.
    unit : {"auto", "mm", "cm", "m", "inch", "cmu"} or float
        File unit: a name of :data:`UNITS`, millimetres per unit, or ``"auto"`` to pick the named
        unit that makes the skeleton's span (longest chain between two leaves, about the height or
        arm span) closest to 1.7 m.

    Returns
    -------
    BvhClip

    Raises
    ------
    InputError
        Unreadable file, malformed hierarchy, unknown channel names, a wrong number of values in a
        motion row, non-numeric or non-finite values, or a frame count that disagrees with
        ``Frames:``.
    """
    path = Path(path)
    lines = read_text_file(path, "BVH file").splitlines()
    motion_line = next((i for i, ln in enumerate(lines) if ln.strip().upper() == "MOTION"), None)
    if motion_line is None:
        raise InputError(path, "no MOTION section (not a BVH file?)")
    names, parents, offsets, channels = _parse_hierarchy("\n".join(lines[:motion_line]), path)
    start = np.zeros(len(names), dtype=int)
    n_channels = 0
    for j, ch in enumerate(channels):
        start[j] = n_channels
        n_channels += len(ch)
    motion, frame_time = _parse_motion(lines, motion_line, n_channels, path)
    clip = BvhClip(names=names, parents=np.array(parents, dtype=int),
                   offsets=np.array(offsets, dtype=float).reshape(-1, 3), channels=channels,
                   channel_start=start, motion=motion, frame_time=frame_time, source=str(path))
    if isinstance(unit, str):
        if unit == "auto":
            clip.scale = _guess_scale(clip)
        elif unit in UNITS:
            clip.scale = UNITS[unit]
        else:
            raise InputError("unit", f"unknown unit {unit!r} (use auto, {', '.join(UNITS)})")
    else:
        scale = float(unit)
        if not (math.isfinite(scale) and scale > 0):
            raise InputError("unit", f"scale must be a positive number of mm, got {unit!r}")
        clip.scale = scale
    return clip


def _parse_hierarchy(text: str, path):
    toks = list(_tokens_with_lines(text))
    if not toks or toks[0][0].upper() != "HIERARCHY":
        raise InputError(path, "does not start with HIERARCHY")
    names: list[str] = []
    parents: list[int] = []
    offsets: list[list[float]] = []
    channels: list[tuple[str, ...]] = []
    stack: list[int] = []
    i = 1
    pending: int | None = None  # joint just declared, waiting for its '{'

    def number(k):
        tok, ln = toks[k]
        try:
            v = float(tok)
        except ValueError:
            raise InputError(path, f"line {ln}: expected a number, got {tok[:20]!r}") from None
        if not math.isfinite(v):
            raise InputError(path, f"line {ln}: non-finite value {tok!r}")
        return v

    while i < len(toks):
        tok, ln = toks[i]
        key = tok.upper()
        if key in ("ROOT", "JOINT"):
            if i + 1 >= len(toks):
                raise InputError(path, f"line {ln}: {tok} without a name")
            if key == "ROOT" and stack:
                raise InputError(path, f"line {ln}: ROOT inside another joint")
            if key == "JOINT" and not stack:
                raise InputError(path, f"line {ln}: JOINT outside ROOT")
            names.append(toks[i + 1][0])
            parents.append(stack[-1] if stack else -1)
            offsets.append([0.0, 0.0, 0.0])
            channels.append(())
            pending = len(names) - 1
            i += 2
        elif key == "END":
            if not stack or i + 1 >= len(toks) or toks[i + 1][0].upper() != "SITE":
                raise InputError(path, f"line {ln}: misplaced End Site")
            names.append(f"{names[stack[-1]]}_End")
            parents.append(stack[-1])
            offsets.append([0.0, 0.0, 0.0])
            channels.append(())
            pending = len(names) - 1
            i += 2
        elif tok == "{":
            if pending is None:
                raise InputError(path, f"line {ln}: '{{' without a joint")
            stack.append(pending)
            pending = None
            i += 1
        elif tok == "}":
            if not stack:
                raise InputError(path, f"line {ln}: unbalanced '}}'")
            stack.pop()
            i += 1
        elif key == "OFFSET":
            if not stack or i + 3 >= len(toks):
                raise InputError(path, f"line {ln}: misplaced OFFSET")
            offsets[stack[-1]] = [number(i + 1), number(i + 2), number(i + 3)]
            i += 4
        elif key == "CHANNELS":
            if not stack or _is_end(names, parents, stack[-1]):
                raise InputError(path, f"line {ln}: CHANNELS outside a joint")
            try:
                n = int(toks[i + 1][0])
            except (ValueError, IndexError):
                raise InputError(path, f"line {ln}: CHANNELS needs a count") from None
            if n < 0 or n > 6 or i + 2 + n > len(toks):
                raise InputError(path, f"line {ln}: bad channel count {n}")
            chans = tuple(t for t, _ in toks[i + 2:i + 2 + n])
            for c in chans:
                if c not in _CHANNELS:
                    raise InputError(path, f"line {ln}: unknown channel {c[:20]!r}")
            if len(set(chans)) != len(chans):
                raise InputError(path, f"line {ln}: repeated channel in {' '.join(chans)}")
            channels[stack[-1]] = chans
            i += 2 + n
        else:
            raise InputError(path, f"line {ln}: unexpected {tok[:20]!r} in HIERARCHY")
    if stack or pending is not None:
        raise InputError(path, "HIERARCHY ends inside a joint (unbalanced braces)")
    if not names:
        raise InputError(path, "HIERARCHY has no joints")
    return names, parents, offsets, channels


def _is_end(names, parents, j) -> bool:
    # End sites are the leaves named "<parent>_End" that we created ourselves.
    p = parents[j]
    return p >= 0 and names[j] == f"{names[p]}_End"


def _parse_motion(lines, motion_line, n_channels, path):
    i = motion_line + 1

    def header(prefix):
        nonlocal i
        while i < len(lines) and not lines[i].strip():
            i += 1
        if i >= len(lines) or not lines[i].strip().lower().startswith(prefix.lower()):
            raise InputError(path, f"line {i + 1}: expected '{prefix}'")
        value = lines[i].split(":", 1)[1].strip()
        i += 1
        return value

    frames_txt = header("Frames:")
    try:
        n_frames = int(frames_txt)
    except ValueError:
        raise InputError(path, f"line {i}: bad frame count {frames_txt[:20]!r}") from None
    ft_txt = header("Frame Time:")
    try:
        frame_time = float(ft_txt)
    except ValueError:
        raise InputError(path, f"line {i}: bad frame time {ft_txt[:20]!r}") from None
    if not (math.isfinite(frame_time) and frame_time > 0):
        raise InputError(path, f"line {i}: frame time must be positive, got {ft_txt}")
    if n_frames < 1:
        raise InputError(path, f"Frames: {n_frames} (no motion)")
    rows = []
    for k in range(i, len(lines)):
        line = lines[k]
        if not line.strip():
            continue
        parts = line.split()
        if len(parts) != n_channels:
            raise InputError(path, f"line {k + 1}: {len(parts)} values, the hierarchy declares "
                                   f"{n_channels} channels")
        try:
            row = np.array(parts, dtype=float)
        except ValueError:
            bad = next(p for p in parts if not is_float(p))
            raise InputError(path, f"line {k + 1}: value {bad[:20]!r} is not a number") from None
        if not np.all(np.isfinite(row)):
            raise InputError(path, f"line {k + 1}: non-finite value")
        rows.append(row)
    if len(rows) != n_frames:
        raise InputError(path, f"Frames: {n_frames} declared but {len(rows)} motion rows found")
    return np.array(rows).reshape(n_frames, n_channels), frame_time


def _guess_scale(clip: BvhClip) -> float:
    """Millimetres per unit: the named unit making the skeleton's longest leaf-to-leaf chain ≈ 1.7 m."""
    lengths = np.linalg.norm(clip.offsets, axis=1)
    J = len(clip.names)
    # Longest path between two leaves of the tree (its weighted diameter), by two passes of
    # depth-first distances: about the arm span or the height of a human skeleton.
    adj: list[list[int]] = [[] for _ in range(J)]
    for j, p in enumerate(clip.parents):
        if p >= 0:
            adj[j].append(p)
            adj[p].append(j)

    def farthest(src):
        dist = np.full(J, -1.0)
        dist[src] = 0.0
        todo = [src]
        while todo:
            a = todo.pop()
            for b in adj[a]:
                if dist[b] < 0:
                    dist[b] = dist[a] + (lengths[b] if clip.parents[b] == a else lengths[a])
                    todo.append(b)
        k = int(np.argmax(dist))
        return k, dist[k]

    far, _ = farthest(0)
    _, span = farthest(far)
    if span <= 0:
        raise InputError(clip.source, "skeleton has zero size; give the unit explicitly")
    return min(UNITS.values(), key=lambda s: abs(math.log(span * s / _TYPICAL_SIZE_MM)))


# ---------------------------------------------------------------------- writing
def write_bvh(path, clip: BvhClip, *, precision: int = 6) -> None:
    """Write a clip as BVH text (atomic). End sites are written as ``End Site`` blocks.

    Clips with pre-rotations (read from ASF/AMC) cannot be expressed in BVH and raise ValueError.
    """
    if clip.pre_rotation is not None and not np.allclose(clip.pre_rotation, np.eye(3)):
        raise ValueError("clip has joint pre-rotations (ASF/AMC); BVH cannot hold them")
    out = ["HIERARCHY"]

    def emit(j, depth):
        pad = "  " * depth
        is_end = _is_end(clip.names, list(clip.parents), j) and not clip.channels[j] \
            and not clip.children(j)
        if is_end:
            out.append(f"{pad}End Site")
        else:
            out.append(f"{pad}{'ROOT' if clip.parents[j] < 0 else 'JOINT'} {clip.names[j]}")
        out.append(f"{pad}{{")
        off = " ".join(f"{v:.{precision}f}" for v in clip.offsets[j])
        out.append(f"{pad}  OFFSET {off}")
        if not is_end:
            ch = clip.channels[j]
            out.append(f"{pad}  CHANNELS {len(ch)} {' '.join(ch)}".rstrip())
        for k in clip.children(j):
            emit(k, depth + 1)
        out.append(f"{pad}}}")

    for root in np.flatnonzero(clip.parents < 0):
        emit(int(root), 0)
    out += ["MOTION", f"Frames: {clip.n_frames}", f"Frame Time: {clip.frame_time:.8f}"]
    fmt = f"{{:.{precision}f}}"
    out += [" ".join(fmt.format(v) for v in row) for row in clip.motion]
    atomic_write_text(os.fspath(path), "\n".join(out) + "\n")
