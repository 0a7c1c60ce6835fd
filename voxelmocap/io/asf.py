"""Acclaim ASF/AMC motion (CMU's original format) read into a :class:`~voxelmocap.io.bvh.BvhClip`.

An ASF file holds the skeleton: per bone a rest ``direction`` (unit vector, global axes), a
``length``, an ``axis`` (Euler angles of the bone's local frame C, ``XYZ`` = ``Rz·Ry·Rx``) and its
degrees of freedom (``dof rx ry rz``); ``:hierarchy`` links bones to parents. An AMC file holds
one block per frame: the frame number, then ``<bone> <values…>`` in each bone's dof order (the root:
``TX TY TZ RX RY RZ`` or its declared ``order``).

The Acclaim forward kinematics (as in CMU's viewer and the usual readers): a bone's global
rotation is ``W_b = W_parent · C_b · M_b · C_b⁻¹`` with ``M_b = Rz·Ry·Rx`` of its dof angles, and
its tip is ``tip_parent + length_b · W_b · direction_b``. It is rewritten as an equivalent BVH-like
clip so that everything built on :class:`BvhClip` (forward kinematics, slerp resampling, skeleton
mapping) applies unchanged: one joint per bone, placed at the bone's *start* (its parent's tip),
with world rotation ``G_b = W_b · C_b``, a constant pre-rotation ``C_parent⁻¹ · C_b`` and rotation
channels ``Zrotation Yrotation Xrotation`` for the bone's dofs; the tips of leaf bones become
``<bone>_End`` joints. Joint names are the bone names, so the joint called ``lfemur`` is the hip
and ``ltibia`` the knee.

Units: ``:units length L`` means file lengths are in units of 1/L inch (CMU: 0.45, i.e.
56.44 mm per unit); angles in degrees unless ``angle rad``. The world is Y up, converted to
HumanEva's Z up like BVH. AMC files carry no frame rate: pass ``fps`` (CMU: 120).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from ..errors import InputError
from ._files import read_text_file
from .bvh import UNITS, BvhClip, _guess_scale

__all__ = ["read_asf_amc"]

_ROT = {"rx": "Xrotation", "ry": "Yrotation", "rz": "Zrotation"}
_ROOT = {"tx": "Xposition", "ty": "Yposition", "tz": "Zposition", **_ROT}


def _read(path: Path) -> list[str]:
    return read_text_file(path, "file").splitlines()


def _floats(tokens, path, lineno, n=None):
    try:
        vals = [float(t) for t in tokens]
    except ValueError:
        raise InputError(path, f"line {lineno}: expected numbers, got {' '.join(tokens)[:40]!r}"
                         ) from None
    if n is not None and len(vals) != n:
        raise InputError(path, f"line {lineno}: expected {n} numbers, got {len(vals)}")
    if not all(math.isfinite(v) for v in vals):
        raise InputError(path, f"line {lineno}: non-finite value")
    return vals


def _euler_xyz(angles) -> np.ndarray:
    """``Rz(z)·Ry(y)·Rx(x)`` (Acclaim ``XYZ``: about fixed x, then y, then z)."""
    return Rotation.from_euler("xyz", angles).as_matrix()  # lower case: extrinsic


def _parse_asf(path: Path):
    lines = _read(path)
    section = None
    length_unit, degrees = None, True
    root = {"order": ["tx", "ty", "tz", "rx", "ry", "rz"], "axis": "XYZ",
            "position": [0.0, 0.0, 0.0], "orientation": [0.0, 0.0, 0.0]}
    bones: dict[str, dict] = {}
    children: dict[str, list[str]] = {}
    current = None
    for lineno, raw in enumerate(lines, start=1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        tok = line.split()
        if tok[0].startswith(":"):
            section = tok[0][1:].lower()
            continue
        key = tok[0].lower()
        if key in ("angle", "axis", "name") and len(tok) < 2:
            raise InputError(path, f"line {lineno}: {key!r} needs a value")
        if section == "units":
            if key == "length":
                length_unit = _floats(tok[1:2], path, lineno, 1)[0]
            elif key == "angle":
                degrees = tok[1].lower().startswith("deg")
        elif section == "root":
            if key == "order":
                root["order"] = [t.lower() for t in tok[1:]]
                if sorted(root["order"]) != sorted(_ROOT):
                    raise InputError(path, f"line {lineno}: root order must list TX TY TZ RX RY RZ")
            elif key == "axis":
                root["axis"] = tok[1].upper()
            elif key in ("position", "orientation"):
                root[key] = _floats(tok[1:4], path, lineno, 3)
        elif section == "bonedata":
            if key == "begin":
                current = {"dof": [], "axis": [0.0, 0.0, 0.0], "direction": None, "length": None}
            elif key == "end":
                if current is None or "name" not in current:
                    raise InputError(path, f"line {lineno}: bone without a name")
                if current["direction"] is None or current["length"] is None:
                    raise InputError(path, f"line {lineno}: bone {current['name']!r} lacks "
                                           "direction or length")
                bones[current["name"]] = current
                current = None
            elif current is not None:
                if key == "name":
                    current["name"] = tok[1]
                elif key == "direction":
                    current["direction"] = _floats(tok[1:4], path, lineno, 3)
                elif key == "length":
                    current["length"] = _floats(tok[1:2], path, lineno, 1)[0]
                elif key == "axis":
                    if len(tok) != 5 or tok[4].upper() != "XYZ":
                        raise InputError(path, f"line {lineno}: only 'axis x y z XYZ' is supported")
                    current["axis"] = _floats(tok[1:4], path, lineno, 3)
                elif key == "dof":
                    dof = [t.lower() for t in tok[1:]]
                    bad = [d for d in dof if d not in _ROT]
                    if bad:
                        raise InputError(path, f"line {lineno}: unsupported dof {bad[0]!r}")
                    current["dof"] = dof
        elif section == "hierarchy":
            if key in ("begin", "end"):
                continue
            children.setdefault(tok[0], []).extend(tok[1:])
    if not bones:
        raise InputError(path, "no :bonedata bones (not an ASF file?)")
    if root["axis"] != "XYZ":
        raise InputError(path, "only root 'axis XYZ' is supported")
    known = set(bones) | {"root"}
    for parent, kids in children.items():
        for name in [parent, *kids]:
            if name not in known:
                raise InputError(path, f":hierarchy names unknown bone {name!r}")
    return bones, children, root, length_unit, degrees


def read_asf_amc(asf_path, amc_path, *, fps: float = 120.0, unit="auto") -> BvhClip:
    """Read an ASF skeleton and an AMC motion as a :class:`~voxelmocap.io.bvh.BvhClip`.

    Parameters
    ----------
    asf_path, amc_path : str or os.PathLike
        The skeleton and motion files.
    fps : float
        Frame rate of the AMC file (not stored in it; CMU captures at 120 Hz).
    unit : "auto", a name of :data:`~voxelmocap.io.bvh.UNITS`, or float
        Millimetres per file unit; ``"auto"`` uses the ASF's ``:units length`` (1/L inch per
        unit) when present, else the BVH size heuristic.

    Raises
    ------
    InputError
        Unreadable files, malformed sections, unknown bones, wrong value counts in the AMC.
    """
    asf_path, amc_path = Path(asf_path), Path(amc_path)
    if not (math.isfinite(fps) and fps > 0):
        raise InputError("--fps", f"AMC frame rate must be positive, got {fps}")
    bones, children, root, length_unit, degrees = _parse_asf(asf_path)
    to_rad = math.pi / 180.0 if degrees else 1.0

    # Joint order: depth-first from the root; one joint per bone (at its start), End sites.
    names, parents, offsets, channels, pre = [], [], [], [], []
    C = {"root": _euler_xyz(np.asarray(root["orientation"]) * to_rad)}
    for name, b in bones.items():
        C[name] = _euler_xyz(np.asarray(b["axis"]) * to_rad)
    order = {c: _ROOT[c] for c in root["order"]}
    names.append("root")
    parents.append(-1)
    offsets.append(np.asarray(root["position"], dtype=float))
    rot_chans = [order[c] for c in ("rz", "ry", "rx")]
    channels.append(tuple(order[c] for c in ("tx", "ty", "tz")) + tuple(rot_chans))
    pre.append(C["root"])
    index = {"root": 0}

    def visit(bone: str, parent: str):
        b = bones[bone]
        j = len(names)
        index[bone] = j
        names.append(bone)
        parents.append(index[parent])
        if parent == "root":
            offsets.append(np.zeros(3))
        else:
            pb = bones[parent]
            offsets.append(pb["length"] * (C[parent].T @ np.asarray(pb["direction"], float)))
        channels.append(tuple(_ROT[d] for d in ("rz", "ry", "rx") if d in b["dof"]))
        pre.append(C[parent].T @ C[bone])
        kids = children.get(bone, [])
        for kid in kids:
            visit(kid, bone)
        if not kids:
            names.append(f"{bone}_End")
            parents.append(j)
            offsets.append(b["length"] * (C[bone].T @ np.asarray(b["direction"], float)))
            channels.append(())
            pre.append(np.eye(3))

    for kid in children.get("root", []):
        visit(kid, "root")
    missing = set(bones) - set(index)
    if missing:
        raise InputError(asf_path, f"bones not reachable from root in :hierarchy: "
                                   f"{', '.join(sorted(missing))}")
    start = np.zeros(len(names), dtype=int)
    n = 0
    for j, ch in enumerate(channels):
        start[j] = n
        n += len(ch)
    motion = _parse_amc(amc_path, names, index, bones, root, channels, start, n, to_rad)
    clip = BvhClip(names=names, parents=np.array(parents), offsets=np.array(offsets),
                   channels=channels, channel_start=start, motion=motion, frame_time=1.0 / fps,
                   source=str(amc_path), pre_rotation=np.array(pre))
    if isinstance(unit, str) and unit == "auto":
        clip.scale = 25.4 / length_unit if length_unit else _guess_scale(clip)
    elif isinstance(unit, str):
        if unit not in UNITS:
            raise InputError("unit", f"unknown unit {unit!r} (use auto, {', '.join(UNITS)})")
        clip.scale = UNITS[unit]
    else:
        clip.scale = float(unit)
    return clip


def _parse_amc(path, names, index, bones, root, channels, start, n_channels, to_rad):
    lines = _read(path)
    frames: list[np.ndarray] = []
    row = None
    seen: set[str] = set()
    for lineno, raw in enumerate(lines, start=1):
        line = raw.split("#", 1)[0].strip()
        if not line or line.startswith(":"):
            continue
        tok = line.split()
        if len(tok) == 1 and tok[0].isdigit():
            if row is not None:
                frames.append(row)
            row = np.zeros(n_channels)
            seen = set()
            continue
        if row is None:
            raise InputError(path, f"line {lineno}: values before the first frame number")
        name = tok[0]
        if name not in index:
            raise InputError(path, f"line {lineno}: unknown bone {name!r}")
        if name in seen:
            raise InputError(path, f"line {lineno}: bone {name!r} twice in one frame")
        seen.add(name)
        vals = _floats(tok[1:], path, lineno)
        j = index[name]
        if name == "root":
            dof = root["order"]
        else:
            dof = bones[name]["dof"]
        if len(vals) != len(dof):
            raise InputError(path, f"line {lineno}: {name} has {len(vals)} values, the ASF "
                                   f"declares {len(dof)} dof")
        chans = channels[j]
        for d, v in zip(dof, vals, strict=True):
            col = start[j] + chans.index(_ROOT[d] if name == "root" else _ROT[d])
            # Channels hold file units and degrees, as in BVH.
            row[col] = v if d.startswith("t") else math.degrees(v * to_rad)
    if row is not None:
        frames.append(row)
    if not frames:
        raise InputError(path, "no frames (not an AMC file?)")
    return np.array(frames)
