"""The HumanEva ``body_pose`` XML interchange format (toolkit ``exportXML`` / ``importXML``).

One ``SEQUENCE`` root whose attributes describe the sequence (``DatasetName``, ``SubjectName``,
``ActionType``, ``Trial``, ``FrameStart``, ``FrameEnd``, ``Partition`` …), a ``Camera`` element (``N/A``
for 3-D poses) and one ``Frame`` per pose: ``Number`` (the 1-based synchronised frame F), a ``Pose`` of
20 ``Joint`` elements (``Name``, ``Enabled``, ``X``, ``Y`` and, in 3-D, ``Z``) in the order of
:data:`voxelmocap.joints.ENDPOINT_NAMES`, and ``Error`` (a number or ``N/A``). See ``HUMANEVA.md`` §6.

Unlike the toolkit's importer, :func:`read_body_pose_xml` accepts 2-D files (no ``Z``) and keeps the
root attributes. Parsing goes through ``defusedxml`` with DTDs forbidden, so a document with a DTD,
an entity declaration or an external reference is refused whatever its encoding or where the
declaration stands (no "billion laughs", no external entities). Writing builds an ElementTree, so
every name and value is escaped by the standard library.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import defusedxml
import defusedxml.ElementTree as SafeET
import numpy as np

from ..errors import InputError
from ..joints import ENDPOINT_NAMES
from ._atomic import atomic_write_bytes

__all__ = ["MAX_COORDINATE", "BodyPoseSequence", "read_body_pose_xml", "write_body_pose_xml"]

#: Largest accepted coordinate (10 km in mm, or 10 million pixels). Larger values are corrupt
#: data, and squaring them in the error measures overflows to infinity.
MAX_COORDINATE = 1e7


@dataclass
class BodyPoseSequence:
    """Poses of one sequence as stored in a body_pose XML file.

    Attributes
    ----------
    frames : (F,) int ndarray
        1-based synchronised frame numbers.
    endpoints : (F, 20, D) float ndarray
        Endpoint positions (mm for D = 3, pixels for D = 2), in ``ENDPOINT_NAMES`` order.
    enabled : (F, 20) bool ndarray
        ``<name>Enabled`` flags.
    attributes : dict of str to str
        The ``SEQUENCE`` root attributes.
    camera : str or None
        The ``Camera`` element (None for ``N/A``: 3-D results).
    errors : (F,) float ndarray
        The ``Error`` values; −1 where missing, non-numeric or negative (as the toolkit's importer).
    """

    frames: np.ndarray
    endpoints: np.ndarray
    enabled: np.ndarray
    attributes: dict = field(default_factory=dict)
    camera: str | None = None
    errors: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.frames)

    def index_of(self, frame_numbers) -> np.ndarray:
        """Row indices of the given 1-based frame numbers; −1 where a frame is absent."""
        lookup = {int(f): i for i, f in enumerate(self.frames)}
        return np.array([lookup.get(int(f), -1) for f in np.atleast_1d(frame_numbers)], dtype=int)


def _text(elem: ET.Element, tag: str, path, where: str) -> str:
    child = elem.find(tag)
    if child is None or child.text is None:
        raise InputError(path, f"{where}: missing <{tag}>")
    return child.text.strip()


def _number(text: str, path, where: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise InputError(path, f"{where}: {text[:30]!r} is not a number") from None
    if not math.isfinite(value):
        raise InputError(path, f"{where}: value {text!r} is not finite")
    if abs(value) > MAX_COORDINATE:
        raise InputError(path, f"{where}: value {text[:30]} is beyond ±{MAX_COORDINATE:g} "
                               "(mm or pixels): not a position")
    return value


def read_body_pose_xml(path) -> BodyPoseSequence:
    """Read a HumanEva body_pose XML file (3-D or 2-D).

    Parameters
    ----------
    path : str or os.PathLike
        The XML file.

    Returns
    -------
    BodyPoseSequence

    Raises
    ------
    InputError
        Missing or unreadable file, malformed XML, a DTD/entity declaration, a frame without
        20 joints in the standard order, or a coordinate that is not a finite number.
    """
    path = Path(path)
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise InputError(path, "XML file not found") from None
    except OSError as exc:
        raise InputError(path, f"cannot read XML file ({exc.__class__.__name__})") from None
    try:
        root = SafeET.fromstring(raw, forbid_dtd=True, forbid_entities=True,
                                 forbid_external=True)
    except defusedxml.DefusedXmlException:
        raise InputError(path, "DTDs and entity declarations are not accepted in body_pose XML") \
            from None
    except ET.ParseError as exc:
        raise InputError(path, f"malformed XML ({exc})") from None
    except (ValueError, LookupError) as exc:  # e.g. an encoding the parser does not know
        raise InputError(path, f"malformed XML ({exc})") from None
    if root.tag != "SEQUENCE":
        raise InputError(path, f"root element is <{root.tag}>, expected <SEQUENCE>")
    cam_elem = root.find("Camera")
    camera = None
    if cam_elem is not None and cam_elem.text and cam_elem.text.strip() not in ("", "N/A"):
        camera = cam_elem.text.strip()

    frames, points, flags, errors = [], [], [], []
    dims = None
    for fi, frame in enumerate(root.findall("Frame")):
        where = f"frame #{fi + 1}"
        number = _number(_text(frame, "Number", path, where), path, where)
        if number != int(number):
            raise InputError(path, f"{where}: frame number {number} is not an integer")
        where = f"frame {int(number)}"
        pose = frame.find("Pose")
        if pose is None:
            raise InputError(path, f"{where}: missing <Pose>")
        joints = pose.findall("Joint")
        if len(joints) != 20:
            raise InputError(path, f"{where}: expected 20 joints, found {len(joints)}")
        pts = np.empty((20, 3))
        en = np.empty(20, dtype=bool)
        has_z = []
        for j, (joint, expected) in enumerate(zip(joints, ENDPOINT_NAMES, strict=True)):
            name = _text(joint, "Name", path, f"{where} joint {j + 1}")
            if name != expected:
                raise InputError(path, f"{where}: joint {j + 1} is {name!r}, expected {expected!r}")
            jw = f"{where} {name}"
            en[j] = _number(_text(joint, "Enabled", path, jw), path, jw) != 0
            pts[j, 0] = _number(_text(joint, "X", path, jw), path, jw)
            pts[j, 1] = _number(_text(joint, "Y", path, jw), path, jw)
            z = joint.find("Z")
            has_z.append(z is not None)
            pts[j, 2] = _number(_text(joint, "Z", path, jw), path, jw) if z is not None else 0.0
        frame_dims = 3 if all(has_z) else 2 if not any(has_z) else None
        if frame_dims is None or (dims is not None and frame_dims != dims):
            raise InputError(path, f"{where}: mixes 2-D and 3-D joints")
        dims = frame_dims
        err_elem = frame.find("Error")
        err = -1.0
        if err_elem is not None and err_elem.text:
            try:
                err = float(err_elem.text)
            except ValueError:
                err = -1.0
            if not math.isfinite(err) or err < 0:
                err = -1.0
        frames.append(int(number))
        points.append(pts)
        flags.append(en)
        errors.append(err)
    dims = dims or 3
    endpoints = np.array(points, dtype=float).reshape(-1, 20, 3)[:, :, :dims]
    return BodyPoseSequence(
        frames=np.array(frames, dtype=int),
        endpoints=endpoints,
        enabled=np.array(flags, dtype=bool).reshape(-1, 20),
        attributes=dict(root.attrib),
        camera=camera,
        errors=np.array(errors, dtype=float),
    )


def write_body_pose_xml(path, frames, endpoints, enabled=None, *, attributes=None, camera=None,
                        errors=None) -> None:
    """Write poses as a HumanEva body_pose XML file (atomically).

    Parameters
    ----------
    path : str or os.PathLike
        Output file; as in the toolkit, a three-letter extension must be ``xml``, and ``.xml`` is
        appended to any other name.
    frames : (F,) array_like of int
        1-based synchronised frame numbers.
    endpoints : (F, 20, D) array_like
        D = 3 (mm) or 2 (pixels).
    enabled : (F, 20) array_like of bool, optional
        Endpoint flags (all enabled by default).
    attributes : dict, optional
        ``SEQUENCE`` root attributes (``SubjectName``, ``ActionType``, ``Trial`` …), written as strings.
    camera : str, optional
        Camera name for 2-D poses; ``N/A`` when None.
    errors : (F,) array_like, optional
        Per-frame errors; ``N/A`` where None or NaN.
    """
    path = Path(path)
    # The toolkit's rule: a name whose 4th character from the end is a dot must end in xml/XML;
    # any other name gets ".xml" appended.
    if len(path.name) >= 4 and path.name[-4] == ".":
        if path.name[-3:] not in ("xml", "XML"):
            raise InputError(path, "a body_pose XML file name must end in .xml")
    else:
        path = path.with_name(path.name + ".xml")
    frames = np.asarray(frames).reshape(-1)
    endpoints = np.asarray(endpoints, dtype=float)
    if endpoints.ndim != 3 or endpoints.shape[1] != 20 or endpoints.shape[2] not in (2, 3):
        raise ValueError(f"endpoints must be (F, 20, 2|3), got {endpoints.shape}")
    if len(frames) != len(endpoints):
        raise ValueError(f"{len(frames)} frame numbers for {len(endpoints)} poses")
    if not np.all(np.isfinite(endpoints)):
        raise ValueError("endpoints contain NaN or infinite values")
    if enabled is None:
        enabled = np.ones(endpoints.shape[:2], dtype=bool)
    enabled = np.asarray(enabled, dtype=bool).reshape(endpoints.shape[:2])
    dims = "XYZ"[: endpoints.shape[2]]

    root = ET.Element("SEQUENCE", {str(k): str(v) for k, v in (attributes or {}).items()})
    ET.SubElement(root, "Camera").text = str(camera) if camera else "N/A"
    for i, number in enumerate(frames):
        frame = ET.SubElement(root, "Frame")
        ET.SubElement(frame, "Number").text = str(int(number))
        pose = ET.SubElement(frame, "Pose")
        for j, name in enumerate(ENDPOINT_NAMES):
            joint = ET.SubElement(pose, "Joint")
            ET.SubElement(joint, "Name").text = name
            ET.SubElement(joint, "Enabled").text = str(int(enabled[i, j]))
            for k, d in enumerate(dims):
                ET.SubElement(joint, d).text = f"{endpoints[i, j, k]:f}"
        err = None if errors is None else errors[i]
        ET.SubElement(frame, "Error").text = \
            "N/A" if err is None or not np.isfinite(err) else f"{float(err):f}"
    ET.indent(root, space="")
    atomic_write_bytes(path, ET.tostring(root, encoding="UTF-8", xml_declaration=True) + b"\n")
