"""Finding and reading a project's calibration file, whatever its format.

Formats (by file name):

* ``*.toml``: a Pose2Sim or anipose calibration (:func:`voxelmocap.io.calibration.read_calibration_toml`).
  Pose2Sim writes translations in metres; anipose in the unit of its calibration board (mm in its
  tutorials). ``units="m"``/``"mm"`` says which; ``units="auto"`` decides from the camera spacing
  (cameras less than :data:`METRE_SPACING` units apart from their centroid, on median: metres)
  and says so in ``notes``;
* ``*.qca.txt``: a Qualisys calibration (:mod:`voxelmocap.io.qualisys`), mm;
* ``intri.yml`` + ``extri.yml``: EasyMocap (:mod:`voxelmocap.io.easymocap`), metres.

:func:`find_calibration` looks for one of them in a folder; :func:`read_calibration_file` reads it
into a :class:`~voxelmocap.camera.Rig` in millimetres.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from ..camera import Rig
from ..errors import InputError
from .calibration_checks import check_rig

__all__ = ["METRE_SPACING", "calibration_format", "find_calibration", "read_calibration_file"]

#: A calibration whose cameras are, on median, closer than this to their centroid is in metres.
#: (A capture volume's cameras stand metres apart: 2–10 in metres, 2000–10000 in mm.)
METRE_SPACING = 50.0

_FORMATS = "a Pose2Sim/anipose .toml, a Qualisys .qca.txt or EasyMocap intri.yml + extri.yml"


def calibration_format(path: Path) -> str | None:
    """``"toml"``, ``"qualisys"``, ``"easymocap"`` or None, from the file name."""
    name = path.name.lower()
    if name.endswith(".qca.txt") or name.endswith(".qca"):
        return "qualisys"
    if name.endswith(".toml") and name not in ("config.toml", "config_demo.toml"):
        return "toml"
    if name in ("intri.yml", "extri.yml", "intri.yaml", "extri.yaml"):
        return "easymocap"
    return None


def find_calibration(folder: Path) -> Path:
    """The calibration file of a folder.

    A TOML is preferred to a ``.qca.txt`` beside it (Pose2Sim converts the ``.qca.txt`` into the
    TOML it then uses); EasyMocap's pair is returned as its ``intri.yml``.

    Raises
    ------
    InputError
        No calibration file here (the message lists what the folder holds), or several of the
        preferred kind.
    """
    files = sorted(p for p in folder.iterdir() if p.is_file() and not p.name.startswith("."))
    by_format: dict[str, list[Path]] = {}
    for p in files:
        fmt = calibration_format(p)
        if fmt is not None:
            by_format.setdefault(fmt, []).append(p)
    for fmt in ("toml", "qualisys", "easymocap"):
        found = by_format.get(fmt, [])
        if fmt == "easymocap":
            found = [p for p in found if p.name.lower().startswith("intri")]
        if len(found) > 1:
            raise InputError(folder, f"several calibration files ({', '.join(p.name for p in found)}"
                                     "): choose one with --calibration")
        if found:
            return found[0]
    seen = ", ".join(p.name for p in files[:8]) or "nothing"
    raise InputError(folder, f"no calibration file ({_FORMATS}) in this folder (it holds {seen})")


def read_calibration_file(path, *, units: str = "auto", binning_factor: float = 1.0,
                          notes: list[str] | None = None) -> tuple[Rig, set[str]]:
    """Read a calibration file into a rig in millimetres.

    Parameters
    ----------
    path : str or os.PathLike
        A ``.toml``, ``.qca.txt``, ``intri.yml`` or ``extri.yml`` (the other of the pair is
        taken from the same folder).
    units : {"auto", "m", "mm"}
        Unit of a TOML's translations (see the module docstring); other formats state theirs.
    binning_factor : float
        Qualisys only (Pose2Sim's ``binning_factor``).
    notes : list of str, optional
        Receives one line per assumption made.

    Returns
    -------
    rig : Rig
        The cameras, in the file's order.
    unsized : set of str
        Cameras whose file states no image size (EasyMocap without ``H_``/``W_``): their size
        is a placeholder, to be taken from the videos.

    Raises
    ------
    InputError
        An unknown format (naming the file) or a bad file.
    """
    path = Path(path)
    notes = [] if notes is None else notes
    fmt = calibration_format(path)
    if not path.exists():
        raise InputError(path, "calibration file not found")
    if fmt is None:
        raise InputError(path, f"unknown calibration format (expected {_FORMATS})")
    if fmt == "qualisys":
        from .qualisys import read_qca

        rig = read_qca(path, binning_factor=binning_factor, notes=notes)
        check_rig(rig, path)
        return rig, set()
    if fmt == "easymocap":
        from .easymocap import read_easymocap

        folder = path.parent
        intri = _sibling(folder, "intri")
        extri = _sibling(folder, "extri")
        rig, unsized = read_easymocap(intri, extri)
        spacing = _spacing(rig) / 1000.0  # in the file's unit, metres by EasyMocap's convention
        if spacing >= METRE_SPACING:
            notes.append(_unit_note(extri, "EasyMocap writes metres", spacing))
            rig = Rig(dataclasses.replace(cam, T=np.asarray(cam.T) * 1e-3) for cam in rig)
        check_rig(rig, extri, intrinsics_source=intri)
        return rig, unsized
    from .calibration import read_calibration_toml

    if units not in ("auto", "m", "mm"):
        raise ValueError(f"units must be 'auto', 'm' or 'mm', got {units!r}")
    rig = read_calibration_toml(path)
    spacing = _spacing(rig)
    if units == "auto":
        units = "m" if spacing < METRE_SPACING else "mm"
        notes.append(f"{path.name}: translations taken as {'metres' if units == 'm' else 'mm'} "
                     f"(cameras {spacing:.3g} units from their centroid, on median)")
    elif units == "m" and spacing >= METRE_SPACING:
        # A Pose2Sim layout holding a calibration written in mm (FreeMoCap's): read as metres
        # its cameras would stand kilometres apart.
        notes.append(_unit_note(path, "Pose2Sim writes metres", spacing))
        units = "mm"
    if units == "m":
        rig = read_calibration_toml(path, translation_scale=1000.0)
    check_rig(rig, path)
    return rig, set()


def _unit_note(path: Path, convention: str, spacing: float) -> str:
    return (f"{path.name}: translations taken as mm although {convention} (the cameras stand "
            f"{spacing:.3g} units from their centroid, on median: {spacing / 1000:.3g} km in "
            "metres)")


def _spacing(rig: Rig) -> float:
    with np.errstate(all="ignore"):
        centres = np.array([cam.center for cam in rig])
    if not np.all(np.isfinite(centres)):
        return float("inf")
    if len(centres) < 2:
        return float(np.linalg.norm(centres[0])) if len(centres) else 0.0
    return float(np.median(np.linalg.norm(centres - centres.mean(axis=0), axis=1)))


def _sibling(folder: Path, stem: str) -> Path:
    for suffix in (".yml", ".yaml"):
        for p in folder.iterdir():
            if p.name.lower() == stem + suffix:
                return p
    raise InputError(folder / f"{stem}.yml", f"EasyMocap {stem}.yml not found (intri.yml and "
                                             "extri.yml go together)")
