"""The boundary check every calibration reader applies: numbers in range, a rig that can be real.

A calibration file is user input: a focal length of 1e308 pixels, a distortion coefficient of
1e300 or a camera 1e12 mm away parse as numbers, and then overflow in the projection (NumPy
warnings before the error line) or size a voxel grid of hundreds of GiB. Every reader
(``.cal``, Pose2Sim/anipose TOML, Qualisys ``.qca.txt``, EasyMocap YAML) passes its cameras,
in millimetres, through :func:`check_rig`, which refuses in one line naming the file and the
camera:

* intrinsics out of range (:func:`check_intrinsics`): focal lengths in (0, :data:`MAX_FOCAL_PX`],
  the principal point within :data:`MAX_CC_IMAGES` image sizes of the image, a skew of at most
  :data:`MAX_SKEW`, distortion coefficients of at most :data:`MAX_DISTORTION` in magnitude;
* camera names that are not unique;
* a camera farther than :data:`MAX_DISTANCE_MM` (a few hundred metres) from the other cameras
  (the median of its distances to them) or from the scene (the point nearest to every camera's
  optical axis; the world origin for one camera).

Units are decided before (``voxelmocap.io.calibration_files``): a Pose2Sim TOML written in mm,
read as metres, puts its cameras kilometres apart and is taken as mm, with a note.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError

__all__ = ["MAX_CC_IMAGES", "MAX_DISTANCE_MM", "MAX_DISTORTION", "MAX_FOCAL_PX", "MAX_SKEW",
           "check_intrinsics", "check_rig", "scene_point"]

#: Farthest a camera may stand from the other cameras or from the scene (mm).
MAX_DISTANCE_MM = 300_000.0
#: Largest focal length accepted (pixels).
MAX_FOCAL_PX = 1e6
#: The principal point may lie this many image widths / heights outside the image.
MAX_CC_IMAGES = 10.0
#: Largest skew coefficient (Bouguet's alpha_c, dimensionless; 0 for every real camera).
MAX_SKEW = 1.0
#: Largest magnitude of a distortion coefficient.
MAX_DISTORTION = 1e3


def check_intrinsics(source, name: str, fc, cc, alpha, kc, size=None) -> None:
    """Refuse intrinsics out of range (module docstring), naming ``source`` and the camera."""
    where = f"camera {name!r}"
    fc, cc, kc = (np.asarray(v, dtype=float).reshape(-1) for v in (fc, cc, kc))
    values = np.concatenate([fc, cc, [float(alpha)], kc])
    if not np.all(np.isfinite(values)):
        raise InputError(source, f"{where}: intrinsics hold NaN or infinite values")
    if not np.all((fc > 0) & (fc <= MAX_FOCAL_PX)):
        raise InputError(source, f"{where}: focal length {fc[0]:.6g}, {fc[1]:.6g} px is not in "
                                 f"(0, {MAX_FOCAL_PX:g}]")
    if size is not None and min(size) > 1:
        limit = MAX_CC_IMAGES * np.asarray(size, dtype=float)
        if np.any(np.abs(cc) > limit):
            raise InputError(source, f"{where}: principal point ({cc[0]:.6g}, {cc[1]:.6g}) px is "
                                     f"far outside its {size[0]}x{size[1]} image")
    elif np.any(np.abs(cc) > MAX_FOCAL_PX):
        raise InputError(source, f"{where}: principal point ({cc[0]:.6g}, {cc[1]:.6g}) px is out "
                                 "of range")
    if abs(float(alpha)) > MAX_SKEW:
        raise InputError(source, f"{where}: skew {float(alpha):.6g} is out of range (|skew| ≤ "
                                 f"{MAX_SKEW:g})")
    if np.any(np.abs(kc) > MAX_DISTORTION):
        raise InputError(source, f"{where}: distortion coefficient {kc[np.argmax(np.abs(kc))]:.6g}"
                                 f" is out of range (|k| ≤ {MAX_DISTORTION:g})")


def scene_point(cameras) -> np.ndarray | None:
    """The world point nearest to every camera's optical axis (least squares), in mm; None when
    the axes are (nearly) parallel."""
    A = np.zeros((3, 3))
    b = np.zeros(3)
    for cam in cameras:
        d = np.asarray(cam.R, dtype=float)[2]  # the optical axis in the world
        P = np.eye(3) - np.outer(d, d)
        A += P
        b += P @ np.asarray(cam.center, dtype=float)
    if np.linalg.cond(A) > 1e8:
        return None
    return np.linalg.solve(A, b)


def check_rig(cameras, source, *, intrinsics_source=None, geometry: bool = True) -> None:
    """Refuse a rig no capture can have (module docstring); ``cameras`` in mm.

    Parameters
    ----------
    cameras : iterable of Camera
    source : str or os.PathLike
        The calibration file (named in errors about names and positions).
    intrinsics_source : str or os.PathLike, optional
        The file of the intrinsics when they live apart (EasyMocap's ``intri.yml``).
    geometry : bool
        Check the positions too (not before the units are known).

    Raises
    ------
    InputError
        Naming the file and the camera at fault.
    """
    cameras = list(cameras)
    names = [cam.name for cam in cameras]
    repeated = sorted({n for n in names if names.count(n) > 1})
    if repeated:
        raise InputError(source, f"camera names are not unique: {', '.join(repeated)} appears "
                                 "twice")
    for cam in cameras:
        check_intrinsics(intrinsics_source or source, cam.name, cam.fc, cam.cc, cam.alpha_c,
                         cam.kc, cam.size)
    if not geometry:
        return
    with np.errstate(all="ignore"):
        centres = np.array([cam.center for cam in cameras], dtype=float)
    for cam, c in zip(cameras, centres, strict=True):
        if not np.all(np.isfinite(c)) or np.max(np.abs(c)) > 1e12:
            raise InputError(source, f"camera {cam.name} is {_far(c)} from the other cameras "
                                     "(its position is out of range): check its translation and "
                                     "the units")
    if len(cameras) > 1:
        # The odd one out is the camera farthest from the rig's median position (robust to it);
        # of two cameras, the one farther from the world's origin.
        middle = np.median(centres, axis=0)
        far = np.linalg.norm(centres - middle, axis=1)
        i = int(np.argmax(far))
        if len(cameras) == 2:
            i = int(np.argmax(np.linalg.norm(centres, axis=1)))
        others = np.delete(centres, i, axis=0)
        d = float(np.median(np.linalg.norm(others - centres[i], axis=1)))
        if d > MAX_DISTANCE_MM:
            raise InputError(source, f"camera {cameras[i].name} is {d / 1000:.4g} m from the "
                                     f"other cameras (at most {MAX_DISTANCE_MM / 1000:g} m): "
                                     "check its translation and the units")
    scene = scene_point(cameras) if len(cameras) > 1 else np.zeros(3)
    if scene is None:
        return
    for cam, c in zip(cameras, centres, strict=True):
        d = float(np.linalg.norm(c - scene))
        if d > MAX_DISTANCE_MM:
            raise InputError(source, f"camera {cam.name} is {d / 1000:.4g} m from the scene "
                                     f"(at most {MAX_DISTANCE_MM / 1000:g} m): check its "
                                     "translation and the units")


def _far(c) -> str:
    with np.errstate(all="ignore"):
        norm = float(np.linalg.norm(c))
    return f"{norm / 1000:.3g} m" if np.isfinite(norm) else "infinitely far"
