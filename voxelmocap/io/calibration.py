"""Camera calibration files: HumanEva ``.cal`` (+ ``sizes.toml``) and anipose / Pose2Sim TOML.

The camera model itself is :class:`voxelmocap.camera.Camera`; this module only turns files into
cameras and back.

* HumanEva ``.cal`` (``HUMANEVA.md`` §2.1): 22 whitespace-separated numbers ``fc(2) cc(2)
  alpha_c kc(5) R(9, row-major) T(3)``; :func:`read_cal`, :func:`write_cal`.
* A calibration folder: one ``<CAM>.cal`` per camera plus an optional ``sizes.toml``
  (``C1 = [640, 480]`` …; ``.cal`` files do not store the image size); :func:`read_rig`,
  :func:`write_rig`.
* anipose / Pose2Sim calibration TOML (``[cam_0] name, size, matrix, distortions, rotation,
  translation``): :func:`read_calibration_toml`, :func:`write_calibration_toml`.

Every writer is atomic; every reader raises :class:`~voxelmocap.errors.InputError` naming the
file and the problem.

>>> rig = read_rig("calib/humaneva_i_like")                         # doctest: +SKIP
>>> write_calibration_toml(rig, "calib.toml", translation_scale=1000.0)  # doctest: +SKIP
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import numpy as np

from ..camera import CAPTURE_CENTRE, Camera, Rig, sort_camera_names
from ..errors import InputError
from ._atomic import atomic_write_text
from ._files import is_float, read_text_file
from .calibration_checks import check_rig
from .toml import read_toml, write_toml

__all__ = [
    "read_cal",
    "read_calibration_toml",
    "read_rig",
    "read_sizes",
    "write_cal",
    "write_calibration_toml",
    "write_rig",
]

#: Image size ``(W, H)`` assumed for a ``.cal`` camera without a ``sizes.toml`` entry (HumanEva-I).
DEFAULT_SIZE = (640, 480)


# ---------------------------------------------------------------------- .cal
def read_cal(path, name: str | None = None, size=DEFAULT_SIZE, *,
             check_facing=CAPTURE_CENTRE) -> Camera:
    """Read a HumanEva ``.cal`` file.

    Parameters
    ----------
    path : str or os.PathLike
        The ``.cal`` file: 22 whitespace-separated numbers (``HUMANEVA.md`` §2.1).
    name : str, optional
        Camera name; by default the file stem (``C1.cal`` → ``"C1"``).
    size : (2,) tuple of int
        Image size ``(W, H)``; ``.cal`` files do not store it.
    check_facing : (3,) array_like or None
        A world point (mm) that must lie in front of the camera; ``None`` skips the check.

    Raises
    ------
    InputError
        Missing or unreadable file, wrong number of values, text, NaN/inf, a non-orthonormal
        R, or a camera facing away from ``check_facing``.
    """
    path = Path(path)
    tokens = read_text_file(path, "calibration file", encoding="ascii").split()
    if len(tokens) != 22:
        raise InputError(path, f"expected 22 numbers in a .cal file, found {len(tokens)} values")
    try:
        values = np.array([float(t) for t in tokens])
    except ValueError:
        bad = next(t for t in tokens if not is_float(t))
        raise InputError(path, f"value {bad[:20]!r} is not a number") from None
    if not np.all(np.isfinite(values)):
        raise InputError(path, "contains NaN or infinite values")
    cam = Camera(name=name or path.stem, fc=values[0:2], cc=values[2:4], alpha_c=values[4],
                 kc=values[5:10], R=values[10:19].reshape(3, 3), T=values[19:22], size=size,
                 source=str(path))
    if check_facing is not None and not cam.looks_at(check_facing):
        raise InputError(path, f"the capture-area centre {tuple(check_facing)} mm is behind "
                               "the camera (check R and T)")
    return cam


def write_cal(camera: Camera, path) -> None:
    """Write a HumanEva ``.cal`` file (one value per line, as the toolkit's writer), atomically.

    ``%.10g`` keeps 10 significant digits: a round trip changes a value by at most 5e-10 of itself.
    """
    values = np.concatenate([camera.fc, camera.cc, [camera.alpha_c], camera.kc,
                             camera.R.reshape(-1), camera.T])
    atomic_write_text(Path(path), "".join(f"{v:.10g}\n" for v in values))


# ---------------------------------------------------------------------- calibration folders
def read_sizes(path) -> dict[str, tuple[int, int]]:
    """The image sizes of a ``sizes.toml`` (``C1 = [640, 480]`` …); ``{}`` when it does not exist.

    Raises
    ------
    InputError
        Unreadable or invalid TOML, or an entry that is not ``[W, H]`` with positive integers.
    """
    path = Path(path)
    if not path.exists():
        return {}
    sizes = {}
    for name, value in read_toml(path).items():
        if not (isinstance(value, list) and len(value) == 2
                and all(isinstance(v, int) and not isinstance(v, bool) and v > 0 for v in value)):
            raise InputError(path, f"size of {name!r} must be [W, H] with two positive integers, "
                                   f"got {value!r}")
        sizes[name] = (value[0], value[1])
    return sizes


def read_rig(folder, size=DEFAULT_SIZE, names: Iterable[str] | None = None) -> Rig:
    """Read every ``*.cal`` of ``folder`` (HumanEva camera order), or only ``names`` when given.

    Parameters
    ----------
    folder : str or os.PathLike
        The calibration folder (e.g. ``S1/Calibration_Data``).
    size : (2,) tuple of int
        Image size ``(W, H)`` of cameras that ``sizes.toml`` does not list.
    names : iterable of str, optional
        Cameras to read, in this order (case-insensitive).

    Raises
    ------
    InputError
        A missing folder, no ``.cal`` file, a named camera without one, or a bad file.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError(folder, "calibration folder not found")
    files = {p.stem: p for p in folder.iterdir() if p.suffix.lower() == ".cal" and p.is_file()}
    if not files:
        raise InputError(folder, "no .cal camera files in this folder")
    sizes = read_sizes(folder / "sizes.toml")
    if names is None:
        selected = sort_camera_names(files)
    else:
        by_upper = {k.upper(): k for k in files}
        selected = []
        for n in names:
            if n.upper() not in by_upper:
                raise InputError(folder, f"no calibration for camera {n!r} "
                                         f"(have {', '.join(sort_camera_names(files))})")
            selected.append(by_upper[n.upper()])
    cameras = [read_cal(files[n], name=n, size=sizes.get(n, size)) for n in selected]
    check_rig(cameras, folder)
    return Rig(cameras)


def write_rig(rig: Iterable[Camera], folder) -> None:
    """Write one ``<name>.cal`` per camera and a ``sizes.toml`` into ``folder`` (each atomically)."""
    folder = Path(folder)
    cameras = list(rig)
    for cam in cameras:
        write_cal(cam, folder / f"{cam.name}.cal")
    write_toml(folder / "sizes.toml", {c.name: [int(v) for v in c.size] for c in cameras})


# ---------------------------------------------------------------------- anipose / Pose2Sim TOML
def read_calibration_toml(path, *, translation_scale: float = 1.0) -> Rig:
    """Read an anipose / Pose2Sim calibration TOML into a :class:`~voxelmocap.camera.Rig`.

    Every table with ``matrix``, ``distortions``, ``rotation`` (Rodrigues vector) and
    ``translation`` is a camera; ``[metadata]`` and other tables are ignored. Fisheye cameras are
    refused (the ``.cal`` model cannot hold them).

    Parameters
    ----------
    path : str or os.PathLike
        The TOML file.
    translation_scale : float
        Multiplies the translations to get millimetres: 1 for anipose boards measured in mm,
        1000 for Pose2Sim files (metres).
    """
    path = Path(path)
    data = read_toml(path)
    cameras = []
    for key, table in data.items():
        if not isinstance(table, dict) or "matrix" not in table:
            continue
        if table.get("fisheye", False):
            raise InputError(path, f"[{key}] is a fisheye camera, which the .cal model cannot hold")
        try:
            name = str(table.get("name", key))
            size = tuple(int(round(float(v))) for v in table["size"])
            if len(size) != 2 or not all(0 < v <= 100_000 for v in size):
                raise ValueError(f"size {table['size']!r:.40} is not [W, H] in pixels")
            K = np.asarray(table["matrix"], dtype=float)
            dist = np.asarray(table["distortions"], dtype=float)
            rvec = np.asarray(table["rotation"], dtype=float)
            tvec = np.asarray(table["translation"], dtype=float) * float(translation_scale)
        except KeyError as exc:
            raise InputError(path, f"[{key}] lacks {exc.args[0]!r}") from None
        except (TypeError, ValueError, OverflowError) as exc:
            raise InputError(path, f"[{key}] has a malformed value ({exc})") from None
        if K.shape != (3, 3):
            raise InputError(path, f"[{key}] matrix must be 3x3")
        cameras.append(Camera.from_opencv(name, K, dist, rvec, tvec, size=size,
                                          source=f"{path} [{key}]"))
    if not cameras:
        raise InputError(path, "no camera tables (with 'matrix') in this calibration TOML")
    # Units are not known here (read_calibration_file decides them): the rig's geometry is
    # checked there, the numbers and names now.
    check_rig(cameras, path, geometry=False)
    return Rig(cameras)


def write_calibration_toml(rig: Iterable[Camera], path, *, translation_scale: float = 1.0) -> None:
    """Write cameras as an anipose-style calibration TOML (``[cam_0]`` … plus ``[metadata]``).

    Translations are divided by ``translation_scale`` (1000 writes metres, as Pose2Sim expects).
    Skew is folded into ``matrix[0][1]``, which anipose ignores.
    """
    out = {}
    for i, cam in enumerate(rig):
        K, dist, rvec, tvec = cam.to_opencv()
        out[f"cam_{i}"] = {
            "name": cam.name,
            "size": [int(cam.size[0]), int(cam.size[1])],
            "matrix": K.tolist(),
            "distortions": dist.tolist(),
            "rotation": rvec.tolist(),
            "translation": (tvec / float(translation_scale)).tolist(),
            "fisheye": False,
        }
    out["metadata"] = {"adjusted": False, "error": 0.0, "written_by": "voxelmocap"}
    write_toml(path, out)
