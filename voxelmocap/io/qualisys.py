"""Qualisys ``.qca.txt`` calibration files (QTM's XML export), read as Pose2Sim reads them.

A ``.qca.txt`` is an XML ``<calibration>`` with one ``<camera>`` per camera::

    <camera serial="cam01" model="none" viewrotation="0" avg-residual="0.40" …>
      <fov_video left="0" top="0" right="1087" bottom="1919"/>
      <transform x=… y=… z=… r11=… … r33=…/>
      <intrinsic focalLengthU=… focalLengthV=… centerPointU=… centerPointV=…
                 radialDistortion1=… radialDistortion2=… tangentalDistortion1=… …/>
    </camera>

The conventions, reproduced from Pose2Sim's ``calibration.read_qca`` / ``calib_qca_fun``
(v0.10.49) so that a project gives the same cameras in Pose2Sim and here:

* only video cameras are kept: ``model`` containing ``video`` or ``none`` (marker cameras are
  skipped), ordered by their ``serial`` in natural order; the camera name is the ``serial``;
* the image is the ``fov_video`` window: ``W = right − left + 1``, ``H = bottom − top + 1``;
* intrinsics are in sub-pixel units: focal lengths and principal point are divided by 64 (and by
  the binning factor), then the principal point is shifted by the window's ``left`` / ``top``;
  the distortion ``(k1, k2, p1, p2)`` is divided by 64 (and the binning factor) too, as Pose2Sim
  does; ``radialDistortion3`` and ``skew`` are not used (as in Pose2Sim) and a non-zero one is
  reported in ``notes``;
* ``transform`` holds the camera centre ``(x, y, z)`` in mm (not a translation) and a rotation
  ``M = [[r11, r12, r13], [r21, …], …]`` with QTM's camera axes (y up, z backwards): the
  world→camera rotation in OpenCV's axes (y down, z forward) is ``R = Rx(π) M`` and the
  translation ``T = −R C``. The world frame is the QTM lab frame, in mm.

``viewrotation`` (a camera mounted on its side, its video rotated by QTM) is refused when it is not
0: Pose2Sim ignores it, and whether the intrinsics then refer to the sensor or to the rotated
image is not stated by the file.

>>> rig = read_qca("calibration/Calib.qca.txt")                  # doctest: +SKIP
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import defusedxml
import defusedxml.ElementTree as SafeET
import numpy as np

from ..camera import Camera, Rig
from ..errors import InputError
from .calibration_checks import MAX_DISTORTION, MAX_SKEW, check_intrinsics

__all__ = ["QUALISYS_SUBPIXEL", "qca_to_opencv", "read_qca"]

#: QTM stores image coordinates in 1/64 pixel.
QUALISYS_SUBPIXEL = 64.0

#: π about the camera's x axis: QTM's camera axes (y up, z backwards) → OpenCV's (y down, z forward).
_FLIP_X = np.diag([1.0, -1.0, -1.0])


def _natural_key(text: str) -> list:
    # Pose2Sim's common.natural_sort_key, so that the camera order is the same as Pose2Sim's.
    return [int(c) if c.isdigit() else c.lower() for c in re.split(r"(\d+)", str(text))]


def _parse(path: Path):
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise InputError(path, "calibration file not found") from None
    except IsADirectoryError:
        raise InputError(path, "is a folder, not a calibration file") from None
    except OSError as exc:
        raise InputError(path, f"cannot read calibration file ({exc.__class__.__name__})") from None
    try:
        return SafeET.fromstring(raw, forbid_dtd=True, forbid_entities=True, forbid_external=True)
    except defusedxml.DefusedXmlException:
        raise InputError(path, "DTDs and entity declarations are not accepted") from None
    except (ET.ParseError, ValueError, LookupError) as exc:
        raise InputError(path, f"malformed XML ({exc})") from None


def _number(path: Path, element, attribute: str, where: str) -> float:
    text = element.get(attribute)
    if text is None:
        raise InputError(path, f"{where} <{element.tag}> lacks the attribute {attribute!r}")
    try:
        value = float(text)
    except ValueError:
        raise InputError(path, f"{where} <{element.tag}> {attribute}={text[:20]!r} is not a "
                               "number") from None
    if not math.isfinite(value):
        raise InputError(path, f"{where} <{element.tag}> {attribute}={text!r} is not finite")
    return value


def _child(path: Path, camera, tag: str, where: str):
    element = camera.find(tag)
    if element is None:
        raise InputError(path, f"{where} has no <{tag}>")
    return element


def qca_to_opencv(path, *, binning_factor: float = 1.0, notes: list[str] | None = None):
    """The cameras of a ``.qca.txt`` in OpenCV's terms, in Pose2Sim's order and conventions.

    Parameters
    ----------
    path : str or os.PathLike
        The ``.qca.txt`` file.
    binning_factor : float
        Pose2Sim's ``[calibration.convert.qualisys] binning_factor`` (1, or 2 for 540p binned
        video).
    notes : list of str, optional
        Receives one line per value read but not used (a non-zero ``radialDistortion3`` or
        ``skew``).

    Returns
    -------
    list of dict
        Per camera: ``name``, ``size`` (W, H), ``K`` (3, 3), ``dist`` (4,) ``(k1, k2, p1, p2)``,
        ``R`` (3, 3) world→camera, ``T`` (3,) mm, ``residual`` (QTM's average residual).

    Raises
    ------
    InputError
        Unreadable or malformed XML, a missing element or attribute, a value that is not a finite
        number, a non-zero ``viewrotation``, no video camera.
    """
    path = Path(path)
    binning = float(binning_factor)
    if not (math.isfinite(binning) and binning > 0):
        raise InputError(path, f"binning factor must be a positive number, got {binning_factor!r}")
    root = _parse(path)
    if root.tag != "calibration":
        raise InputError(path, f"root element is <{root.tag}>, expected <calibration> (a QTM "
                               ".qca.txt export)")
    elements = root.findall("cameras/camera")
    if not elements:
        raise InputError(path, "no <cameras>/<camera> elements")
    cameras = []
    for i, cam in enumerate(elements):
        name = cam.get("serial") or f"camera {i + 1}"
        where = f"camera {name!r}"
        if not any(m in cam.get("model", "").lower() for m in ("video", "none")):
            continue  # a marker camera: Pose2Sim keeps video cameras only
        rotation = cam.get("viewrotation", "0").strip()
        if rotation not in ("0", "0.0", ""):
            raise InputError(path, f"{where} has viewrotation={rotation}: a rotated video is not "
                                   "supported (Pose2Sim ignores it; re-export the calibration "
                                   "with the camera unrotated)")
        fov = _child(path, cam, "fov_video", where)
        left, top = (_number(path, fov, k, where) for k in ("left", "top"))
        right, bottom = (_number(path, fov, k, where) for k in ("right", "bottom"))
        w, h = (right - left + 1) / binning, (bottom - top + 1) / binning
        if w < 1 or h < 1:
            raise InputError(path, f"{where} <fov_video> is empty ({w:g}x{h:g} pixels)")
        if w > 100_000 or h > 100_000:
            raise InputError(path, f"{where} <fov_video> is {w:g}x{h:g} pixels: out of range")
        intr = _child(path, cam, "intrinsic", where)
        q = {k: _number(path, intr, k, where) / QUALISYS_SUBPIXEL / binning
             for k in ("focalLengthU", "focalLengthV", "centerPointU", "centerPointV",
                       "radialDistortion1", "radialDistortion2", "tangentalDistortion1",
                       "tangentalDistortion2")}
        for unused, limit in (("radialDistortion3", MAX_DISTORTION * QUALISYS_SUBPIXEL),
                              ("skew", MAX_SKEW * QUALISYS_SUBPIXEL)):
            text = intr.get(unused)
            if text is not None and _is_float(text) and not abs(float(text)) <= limit:
                # not used, but a value no calibration holds says the file is broken
                raise InputError(path, f"{where} <intrinsic> {unused}={text[:20]} is out of "
                                       "range")
            if notes is not None and text is not None and _is_nonzero(text):
                notes.append(f"{path.name}: {where} {unused}={text} is not used (as in Pose2Sim)")
        K = np.array([[q["focalLengthU"], 0.0, q["centerPointU"] - left],
                      [0.0, q["focalLengthV"], q["centerPointV"] - top],
                      [0.0, 0.0, 1.0]])
        dist = np.array([q["radialDistortion1"], q["radialDistortion2"],
                         q["tangentalDistortion1"], q["tangentalDistortion2"]])
        tr = _child(path, cam, "transform", where)
        centre = np.array([_number(path, tr, k, where) for k in ("x", "y", "z")])
        if np.max(np.abs(centre)) > 1e12:  # R·C would overflow; check_rig says the rest
            raise InputError(path, f"camera {name} is {np.max(np.abs(centre)) / 1000:.3g} m from "
                                   "the other cameras (its position is out of range): check its "
                                   "<transform>")
        check_intrinsics(path, name, (q["focalLengthU"], q["focalLengthV"]),
                         (q["centerPointU"] - left, q["centerPointV"] - top), 0.0,
                         [q[k] for k in ("radialDistortion1", "radialDistortion2",
                                         "tangentalDistortion1", "tangentalDistortion2")],
                         (int(round(w)), int(round(h))))
        M = np.array([[_number(path, tr, f"r{r}{c}", where) for c in (1, 2, 3)] for r in (1, 2, 3)])
        R = _FLIP_X @ M
        err = np.abs(R @ R.T - np.eye(3)).max()
        if err > 1e-4 or np.linalg.det(R) < 0:
            raise InputError(path, f"{where} <transform> r11..r33 is not a rotation "
                                   f"(|R Rᵀ − I| = {err:.2g}, det = {np.linalg.det(R):.3f})")
        residual = cam.get("avg-residual")
        cameras.append({"name": name, "size": (int(round(w)), int(round(h))), "K": K,
                        "dist": dist, "R": R, "T": -R @ centre,
                        "residual": float(residual) if _is_float(residual) else None})
    if not cameras:
        raise InputError(path, "no video camera (model 'video' or 'none'): only marker cameras")
    names = [c["name"] for c in cameras]
    if len(set(names)) != len(names):
        raise InputError(path, f"camera serials are not unique: {names}")
    return sorted(cameras, key=lambda c: _natural_key(c["name"]))


def _is_float(text) -> bool:
    try:
        float(text)
    except (TypeError, ValueError):
        return False
    return True


def _is_nonzero(text: str) -> bool:
    return _is_float(text) and float(text) != 0.0


def read_qca(path, *, binning_factor: float = 1.0, notes: list[str] | None = None) -> Rig:
    """Read a Qualisys ``.qca.txt`` calibration into a :class:`~voxelmocap.camera.Rig` (mm).

    See the module docstring for the conventions and :func:`qca_to_opencv` for the parameters.
    """
    path = Path(path)
    cameras = []
    for c in qca_to_opencv(path, binning_factor=binning_factor, notes=notes):
        K = c["K"]
        cameras.append(Camera(name=c["name"], fc=(K[0, 0], K[1, 1]), cc=(K[0, 2], K[1, 2]),
                              kc=np.concatenate([c["dist"], [0.0]]), R=c["R"], T=c["T"],
                              size=c["size"], source=f"{path} [{c['name']}]"))
    return Rig(cameras)
