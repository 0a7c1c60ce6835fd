"""EasyMocap's OpenCV calibration files ``intri.yml`` and ``extri.yml``.

Both are OpenCV ``FileStorage`` YAML (``%YAML:1.0``) with a ``names`` list of camera names and
per camera (EasyMocap ``mytools/camera_utils.read_camera``):

* ``intri.yml``: ``K_<name>`` (3×3), ``dist_<name>`` (1×5 ``k1 k2 p1 p2 k3``; ``D_<name>`` in
  older files), optionally ``H_<name>`` and ``W_<name>`` (image size);
* ``extri.yml``: ``R_<name>`` (3×1 Rodrigues vector, world→camera), ``Rot_<name>`` (the same as
  a 3×3 matrix, used when ``R_`` is missing), ``T_<name>`` (3×1, metres; ``X_cam = R X + T``).

Translations are converted to millimetres. A camera without ``H_``/``W_`` gets a placeholder size
and is listed as *unsized*: the project takes its size from its video.

>>> rig, unsized = read_easymocap("intri.yml", "extri.yml")         # doctest: +SKIP
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from ..camera import Camera, Rig
from ..errors import InputError
from ._atomic import atomic_write_text
from .calibration_checks import check_intrinsics

__all__ = ["read_easymocap", "write_easymocap"]

#: Size given to a camera whose ``intri.yml`` has no ``H_``/``W_`` (replaced by the video's).
PLACEHOLDER_SIZE = (1, 1)


class _Storage:
    """A read-only ``cv2.FileStorage`` whose failures are :class:`InputError` naming the file."""

    def __init__(self, path: Path):
        self.path = path
        if not path.is_file():
            raise InputError(path, "calibration file not found")
        text = _prescan(path)
        try:
            # From memory: the text checked is the text parsed (and the name need not be UTF-8)
            self.fs = cv2.FileStorage(text, cv2.FILE_STORAGE_READ | cv2.FILE_STORAGE_MEMORY)
        except (cv2.error, SystemError) as exc:
            # OpenCV 5's binding reports a parse error as a SystemError wrapping the cv2.error.
            cause = exc.__cause__ if isinstance(exc, SystemError) and exc.__cause__ else exc
            raise InputError(path, f"not an OpenCV YAML file ({_first_line(cause)})") from None
        if not self.fs.isOpened():
            raise InputError(path, "cannot read as an OpenCV YAML file")
        if not self.fs.root().isMap():
            # a list or a scalar at the top: OpenCV's getNode asserts instead of answering
            raise InputError(path, "not a map of named entries (names:, K_<camera>:, R_<camera>: …)")

    def names(self) -> list[str]:
        node = self.fs.getNode("names")
        if node.empty() or not node.isSeq():
            raise InputError(self.path, "no 'names' list of cameras")
        out = []
        for i in range(node.size()):
            item = node.at(i)
            if item.isString():
                value = item.string()
            else:
                number = item.real()
                if not (item.isInt() or (np.isfinite(number) and number == int(number))):
                    raise InputError(self.path, f"the 'names' list holds {number!r}, not a camera "
                                                "name")
                value = str(int(number))
            if value != "none":  # EasyMocap skips "none"
                out.append(value)
        if not out:
            raise InputError(self.path, "the 'names' list is empty")
        if len(set(out)) != len(out):
            raise InputError(self.path, f"camera names are not unique: {out}")
        return out

    def matrix(self, key: str, shape, *, required: bool = True):
        node = self.fs.getNode(key)
        if node.empty():
            if required:
                raise InputError(self.path, f"no {key!r}")
            return None
        try:
            value = node.mat()
        except (cv2.error, SystemError):
            value = None
        if value is None:
            raise InputError(self.path, f"{key!r} is not an opencv-matrix")
        value = np.asarray(value, dtype=float)
        if shape is not None and value.size != int(np.prod(shape)):
            raise InputError(self.path, f"{key!r} has {value.size} values, expected "
                                        f"{int(np.prod(shape))}")
        if not np.all(np.isfinite(value)):
            raise InputError(self.path, f"{key!r} contains NaN or infinite values")
        return value if shape is None else value.reshape(shape)

    def integer(self, key: str):
        node = self.fs.getNode(key)
        if node.empty():
            return None
        value = node.real()
        if not (np.isfinite(value) and value >= 1 and value == int(value)):
            raise InputError(self.path, f"{key!r} must be a positive integer, got {value!r}")
        return int(value)

    def close(self):
        self.fs.release()


#: Largest OpenCV YAML file read (bytes); EasyMocap's are a few kB per camera.
MAX_YAML_BYTES = 16 << 20
#: Deepest nesting of YAML sequences and mappings accepted (OpenCV's parser recurses per level
#: and crashed on 100 000; EasyMocap's files nest 2 deep).
MAX_YAML_DEPTH = 32


def _prescan(path: Path) -> str:
    """The file's text, refused in one line when too large, not UTF-8, or nested deeper than
    :data:`MAX_YAML_DEPTH` (flow brackets, block indentation or ``- - -`` sequence dashes),
    before OpenCV's parser sees it."""
    try:
        size = path.stat().st_size
        if size > MAX_YAML_BYTES:
            raise InputError(path, f"{size / 2**20:.0f} MB is too large for a calibration file")
        raw = path.read_bytes()
    except OSError as exc:
        raise InputError(path, f"cannot read ({exc.strerror or exc.__class__.__name__})") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InputError(path, f"not UTF-8 text (byte {exc.start + 1} is 0x{raw[exc.start]:02x})"
                         ) from None
    if "\0" in text:
        raise InputError(path, "holds a NUL byte: not a YAML file")
    flow = deepest = 0
    quote = None
    indents = [0]
    for line in text.splitlines():
        stripped = line.lstrip(" ")
        if quote is None and stripped and not stripped.startswith("#"):
            indent = len(line) - len(stripped)
            while indents and indent < indents[-1]:
                indents.pop()
            if indent > indents[-1]:
                indents.append(indent)
            dashes = len(stripped) - len(stripped.lstrip("- ")) if stripped.startswith("- ") \
                else 0
            deepest = max(deepest, len(indents) + stripped[:dashes].count("-"))
        for ch in line:
            if quote is not None:
                if ch == quote:
                    quote = None
            elif ch in "\"'":
                quote = ch
            elif ch == "#":
                break
            elif ch in "[{":
                flow += 1
                deepest = max(deepest, len(indents) + flow)
            elif ch in "]}":
                flow = max(0, flow - 1)
        if quote == "'":  # single-quoted scalars do not span lines in these files
            quote = None
        if deepest > MAX_YAML_DEPTH:
            raise InputError(path, f"sequences or mappings nested more than {MAX_YAML_DEPTH} "
                                   "deep: not an OpenCV calibration file")
    return text


def _first_line(exc: Exception) -> str:
    lines = [s.strip() for s in str(exc).splitlines() if s.strip()]
    return lines[-1][:120] if lines else exc.__class__.__name__


def read_easymocap(intri, extri) -> tuple[Rig, set[str]]:
    """Read EasyMocap's ``intri.yml`` + ``extri.yml`` into a rig in millimetres.

    Returns
    -------
    rig : Rig
        The cameras in ``intri.yml``'s ``names`` order.
    unsized : set of str
        Cameras without ``H_``/``W_`` (size :data:`PLACEHOLDER_SIZE`, to be taken from the video).

    Raises
    ------
    InputError
        A missing or unreadable file, a camera of ``intri.yml`` missing from ``extri.yml``, a
        missing or malformed matrix, distortion terms beyond ``k3``.
    """
    intri, extri = Path(intri), Path(extri)
    fi, fe = _Storage(intri), _Storage(extri)
    try:
        names = fi.names()
        cameras, unsized = [], set()
        for name in names:
            K = fi.matrix(f"K_{name}", (3, 3))
            dist = fi.matrix(f"dist_{name}", None, required=False)
            if dist is None:
                dist = fi.matrix(f"D_{name}", None, required=False)
            dist = np.zeros(5) if dist is None else dist.reshape(-1)
            if dist.size > 5 and np.any(dist[5:] != 0):
                raise InputError(intri, f"dist_{name} has terms beyond k3, which the camera model "
                                        "cannot hold")
            dist = np.concatenate([dist[:5], np.zeros(max(0, 5 - dist.size))])
            h, w = fi.integer(f"H_{name}"), fi.integer(f"W_{name}")
            rvec = fe.matrix(f"R_{name}", (3,), required=False)
            if rvec is None:
                rot = fe.matrix(f"Rot_{name}", (3, 3), required=False)
                if rot is None:
                    raise InputError(extri, f"no R_{name} or Rot_{name} for camera {name!r}")
                err = float(np.abs(rot @ rot.T - np.eye(3)).max())
                if err > 1e-4 or np.linalg.det(rot) < 0:
                    # Rodrigues would turn any matrix into some rotation, silently
                    raise InputError(extri, f"Rot_{name} is not a rotation (|R Rᵀ − I| = "
                                            f"{err:.2g}, det = {np.linalg.det(rot):.3g})")
                rvec = cv2.Rodrigues(rot)[0].reshape(3)
            elif np.linalg.norm(rvec) > 1e3:
                raise InputError(extri, f"R_{name} {rvec.tolist()} is not a rotation vector")
            tvec = fe.matrix(f"T_{name}", (3,))
            if np.max(np.abs(tvec)) > 1e9:  # metres; check_rig says the rest, once in mm
                raise InputError(extri, f"camera {name} is {np.max(np.abs(tvec)):.3g} m from the "
                                        "other cameras (T_{name} is out of range)")
            tvec = tvec * 1000.0
            check_intrinsics(intri, name, (K[0, 0], K[1, 1]), (K[0, 2], K[1, 2]),
                             K[0, 1] / K[0, 0] if K[0, 0] else 0.0, dist,
                             None if h is None or w is None else (w, h))
            size = (w, h) if h is not None and w is not None else PLACEHOLDER_SIZE
            if size == PLACEHOLDER_SIZE:
                unsized.add(name)
            cameras.append(Camera.from_opencv(name, K, dist, rvec, tvec, size=size,
                                              source=f"{intri} [{name}]"))
    finally:
        fi.close()
        fe.close()
    return Rig(cameras), unsized


def _matrix(key: str, value: np.ndarray) -> str:
    value = np.atleast_2d(np.asarray(value, dtype=float))
    data = ", ".join(f"{v:.17g}" for v in value.reshape(-1))
    return (f"{key}: !!opencv-matrix\n  rows: {value.shape[0]}\n  cols: {value.shape[1]}\n"
            f"  dt: d\n  data: [{data}]\n")


def write_easymocap(rig, folder, *, sizes: bool = True) -> tuple[Path, Path]:
    """Write a rig as EasyMocap's ``intri.yml`` and ``extri.yml`` in ``folder`` (atomically).

    Values are written with 17 significant digits (exact round trip); translations in metres.
    ``sizes=False`` leaves out ``H_``/``W_`` as EasyMocap's own calibration tools do.
    """
    folder = Path(folder)
    cameras = list(rig)
    names = "names:\n" + "".join(f'  - "{c.name}"\n' for c in cameras)
    intri, extri = ["%YAML:1.0\n---\n", names], ["%YAML:1.0\n---\n", names]
    for cam in cameras:
        K, dist, rvec, tvec = cam.to_opencv()
        intri.append(_matrix(f"K_{cam.name}", K))
        intri.append(_matrix(f"dist_{cam.name}", dist.reshape(1, -1)))
        if sizes:
            intri.append(f"H_{cam.name}: {int(cam.size[1])}\nW_{cam.name}: {int(cam.size[0])}\n")
        extri.append(_matrix(f"R_{cam.name}", rvec.reshape(3, 1)))
        extri.append(_matrix(f"Rot_{cam.name}", cam.R))
        extri.append(_matrix(f"T_{cam.name}", (tvec / 1000.0).reshape(3, 1)))
    paths = folder / "intri.yml", folder / "extri.yml"
    atomic_write_text(paths[0], "".join(intri))
    atomic_write_text(paths[1], "".join(extri))
    return paths
