"""Calibrated cameras: the Bouguet model of the HumanEva ``.cal`` files.

A world point ``X`` (mm) maps to the camera frame by ``Xc = R @ X + T`` (x right, y down, z forward),
then through the pinhole, five distortion terms ``kc = (k1, k2, p1, p2, k3)`` and the skew
``alpha_c`` to pixels ``(u, v) = (column, row)``, pixel ``(0, 0)`` being the centre of the upper-left
pixel (``HUMANEVA.md`` §2.2, Bouguet's ``project_points2``).

:func:`visible` is the one visibility rule (carving, grid derivation): a point is seen when it is
in front of the camera, within the trusted field of view (:func:`fov_radius`: beyond it the lens
polynomial folds far off-axis points back into the image) and rounds to a pixel of the image.

The camera model only: files (``.cal``, ``sizes.toml``, anipose / Pose2Sim TOML) are read and
written by :mod:`voxelmocap.io.calibration`. OpenCV's ``(K, dist, rvec, tvec)`` convert both ways
(:meth:`Camera.to_opencv`, :meth:`Camera.from_opencv`).

>>> cam = Camera("C1", fc=(800, 800), cc=(320, 240), R=np.eye(3), T=(0, 0, 4000))
>>> cam.project([[0.0, 0.0, 0.0]])
array([[320., 240.]])
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass, field

import cv2
import numpy as np

from .errors import InputError
from .portable import matmul

__all__ = [
    "CAMERA_ORDER",
    "FOV_MARGIN",
    "Camera",
    "Rig",
    "fov_radius",
    "shrunk_size",
    "sort_camera_names",
    "visible",
]

#: HumanEva-I's internal camera order (toolkit ``sync_stream``).
CAMERA_ORDER = ("C1", "C2", "C3", "C4", "BW1", "BW2", "BW3", "BW4")

#: Where the capture-area centre is assumed to be when checking that a camera looks at it (mm).
CAPTURE_CENTRE = (0.0, 0.0, 1000.0)

_ORTHONORMAL_TOL = 1e-4

#: A projection is trusted up to this factor times the largest undistorted radius of the image
#: border (beyond it the distortion polynomial may fold points back into the image).
FOV_MARGIN = 1.05


def sort_camera_names(names: Iterable[str]) -> list[str]:
    """Sort camera names in HumanEva order (C1, C2, C3, BW1..BW4), then any others alphabetically."""
    order = {name: i for i, name in enumerate(CAMERA_ORDER)}
    return sorted(names, key=lambda n: (order.get(n.upper(), len(order)), n))


def _as_vector(values, n: int, what: str, source) -> np.ndarray:
    arr = np.asarray(values, dtype=float).reshape(-1)
    if arr.shape != (n,):
        raise InputError(source, f"{what} must have {n} values, got {arr.size}")
    if not np.all(np.isfinite(arr)):
        raise InputError(source, f"{what} contains NaN or infinite values")
    return arr


@dataclass(frozen=True, eq=False)
class Camera:
    """One calibrated camera (Bouguet / HumanEva ``.cal`` model).

    Parameters
    ----------
    name : str
        Camera name, e.g. ``"C1"`` or ``"BW3"``.
    fc : (2,) array_like
        Focal lengths along x and y (pixels).
    cc : (2,) array_like
        Principal point (pixels), pixel ``(0, 0)`` centred at ``(0, 0)``.
    alpha_c : float
        Skew coefficient (dimensionless).
    kc : (5,) array_like
        Distortion ``(k1, k2, p1, p2, k3)`` in Bouguet order.
    R : (3, 3) array_like
        World→camera rotation (orthonormal, det +1).
    T : (3,) array_like
        World→camera translation (mm): ``Xc = R @ X + T``.
    size : (2,) tuple of int
        Image size ``(W, H)`` in pixels.
    source : str, optional
        Where the camera came from; names the file in error messages.

    Raises
    ------
    InputError
        On non-finite values, a non-orthonormal ``R`` or non-positive focal lengths.
    """

    name: str
    fc: np.ndarray
    cc: np.ndarray
    R: np.ndarray
    T: np.ndarray
    alpha_c: float = 0.0
    kc: np.ndarray = field(default_factory=lambda: np.zeros(5))
    size: tuple[int, int] = (640, 480)
    source: str | None = None

    def __post_init__(self):
        src = self.source or f"camera {self.name}"
        fc = _as_vector(self.fc, 2, "fc", src)
        if np.any(fc <= 0):
            raise InputError(src, f"focal lengths must be positive, got {fc.tolist()}")
        R = np.asarray(self.R, dtype=float)
        if R.size != 9:
            raise InputError(src, f"R must have 9 values, got {R.size}")
        R = R.reshape(3, 3)
        if not np.all(np.isfinite(R)):
            raise InputError(src, "R contains NaN or infinite values")
        err = np.abs(R @ R.T - np.eye(3)).max()
        if err > _ORTHONORMAL_TOL or np.linalg.det(R) < 0:
            raise InputError(src, f"R is not a rotation (|R Rᵀ − I| = {err:.2g}, det = "
                                  f"{np.linalg.det(R):.3f})")
        alpha = float(self.alpha_c)
        if not np.isfinite(alpha):
            raise InputError(src, "alpha_c is NaN or infinite")
        size = tuple(int(v) for v in self.size)
        if len(size) != 2 or min(size) < 1:
            raise InputError(src, f"image size must be two positive integers, got {self.size!r}")
        for key, value in (
            ("fc", fc),
            ("cc", _as_vector(self.cc, 2, "cc", src)),
            ("kc", _as_vector(self.kc, 5, "kc", src)),
            ("R", R),
            ("T", _as_vector(self.T, 3, "T", src)),
            ("alpha_c", alpha),
            ("size", size),
        ):
            if isinstance(value, np.ndarray):
                value = value.copy()
                value.flags.writeable = False
            object.__setattr__(self, key, value)

    # ------------------------------------------------------------------ geometry
    @property
    def width(self) -> int:
        """Image width W (pixels)."""
        return self.size[0]

    @property
    def height(self) -> int:
        """Image height H (pixels)."""
        return self.size[1]

    @property
    def center(self) -> np.ndarray:
        """(3,) camera centre in world coordinates (mm): ``C = -Rᵀ T``."""
        return -matmul(self.R.T, self.T)

    centre = center

    @property
    def optical_axis(self) -> np.ndarray:
        """(3,) unit vector of the viewing direction (camera +z) in world coordinates."""
        return self.R[2].copy()

    def world_to_camera(self, points) -> np.ndarray:
        """Camera-frame coordinates ``(N, 3)`` (mm) of world points ``(N, 3)`` (mm)."""
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        # Summed by NumPy in a fixed order, not by a BLAS kernel chosen by the CPU model: a
        # voxel on a pixel's border must fall on the same side on every machine
        return matmul(points, self.R.T) + self.T

    def distort(self, normalised) -> np.ndarray:
        """Apply the distortion to normalised pinhole coordinates ``(N, 2)`` → distorted ``(N, 2)``."""
        a, b = np.asarray(normalised, dtype=float).reshape(-1, 2).T
        k1, k2, p1, p2, k3 = self.kc
        r2 = a * a + b * b
        radial = 1.0 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2
        xd = a * radial + 2.0 * p1 * a * b + p2 * (r2 + 2.0 * a * a)
        yd = b * radial + p1 * (r2 + 2.0 * b * b) + 2.0 * p2 * a * b
        return np.stack([xd, yd], axis=1)

    def project(self, points, *, return_depth: bool = False):
        """Project world points to pixels with the full model (skew and all distortion terms).

        Parameters
        ----------
        points : (N, 3) array_like
            World points (mm).
        return_depth : bool
            Also return the camera-frame depth ``z`` (mm); points with ``z <= 0`` are behind the
            camera and their pixels are meaningless.

        Returns
        -------
        pixels : (N, 2) ndarray
            ``(u, v)`` = (column, row), pixel ``(0, 0)`` centred at ``(0, 0)``.
        depth : (N,) ndarray
            Only with ``return_depth``.
        """
        xc = self.world_to_camera(points)
        z = xc[:, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            ab = xc[:, :2] / z[:, None]
        xd, yd = self.distort(ab).T
        u = self.fc[0] * (xd + self.alpha_c * yd) + self.cc[0]
        v = self.fc[1] * yd + self.cc[1]
        pixels = np.stack([u, v], axis=1)
        return (pixels, z) if return_depth else pixels

    def undistort_pixels(self, pixels, *, iterations: int = 20) -> np.ndarray:
        """Normalised pinhole coordinates ``(N, 2)`` of pixels ``(N, 2)`` (inverse of the lens model).

        The skew is removed in closed form; the distortion is inverted by Newton's method with the
        analytic Jacobian, starting from the distorted coordinates (exact to ~1e-12 for the mild
        distortions of real lenses within the image).
        """
        pixels = np.asarray(pixels, dtype=float).reshape(-1, 2)
        yd = (pixels[:, 1] - self.cc[1]) / self.fc[1]
        xd = (pixels[:, 0] - self.cc[0]) / self.fc[0] - self.alpha_c * yd
        target = np.stack([xd, yd], axis=1)
        if not np.any(self.kc):
            return target
        k1, k2, p1, p2, k3 = self.kc
        ab = target.copy()
        for _ in range(iterations):
            a, b = ab.T
            r2 = a * a + b * b
            d = 1.0 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2
            dd = k1 + 2.0 * k2 * r2 + 3.0 * k3 * r2 * r2  # d(d)/d(r²)
            j11 = d + 2.0 * a * a * dd + 2.0 * p1 * b + 6.0 * p2 * a
            j12 = 2.0 * a * b * dd + 2.0 * p1 * a + 2.0 * p2 * b
            j22 = d + 2.0 * b * b * dd + 6.0 * p1 * b + 2.0 * p2 * a
            res = self.distort(ab) - target
            det = j11 * j22 - j12 * j12  # the Jacobian is symmetric
            step_a = (j22 * res[:, 0] - j12 * res[:, 1]) / det
            step_b = (j11 * res[:, 1] - j12 * res[:, 0]) / det
            ab -= np.stack([step_a, step_b], axis=1)
            if np.max(np.abs(res)) < 1e-15:
                break
        return ab

    def rays(self, pixels) -> tuple[np.ndarray, np.ndarray]:
        """Back-projection rays of pixels.

        Parameters
        ----------
        pixels : (N, 2) array_like
            ``(u, v)`` pixel positions.

        Returns
        -------
        origins : (N, 3) ndarray
            The camera centre (mm), repeated.
        directions : (N, 3) ndarray
            Unit world directions; ``origin + t * direction`` for ``t > 0`` projects onto the pixel.
        """
        norm = self.undistort_pixels(pixels)
        d_cam = np.concatenate([norm, np.ones((len(norm), 1))], axis=1)
        d_world = matmul(d_cam, self.R)  # Rᵀ applied to each row
        d_world /= np.linalg.norm(d_world, axis=1, keepdims=True)
        return np.broadcast_to(self.center, d_world.shape).copy(), d_world

    def in_image(self, pixels) -> np.ndarray:
        """Boolean ``(N,)``: pixel centres that round into the image ``[0, W) × [0, H)``."""
        pixels = np.asarray(pixels, dtype=float).reshape(-1, 2)
        u = np.round(pixels[:, 0])
        v = np.round(pixels[:, 1])
        return (u >= 0) & (u < self.width) & (v >= 0) & (v < self.height)

    def looks_at(self, point=CAPTURE_CENTRE) -> bool:
        """True when ``point`` (mm) lies in front of the camera (positive depth)."""
        return bool(self.world_to_camera(point)[0, 2] > 0)

    # ------------------------------------------------------------------ OpenCV
    @property
    def K(self) -> np.ndarray:
        """(3, 3) intrinsic matrix, skew included: ``[[fx, alpha_c·fx, cx], [0, fy, cy], [0, 0, 1]]``."""
        return np.array([
            [self.fc[0], self.alpha_c * self.fc[0], self.cc[0]],
            [0.0, self.fc[1], self.cc[1]],
            [0.0, 0.0, 1.0],
        ])

    def to_opencv(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(K (3, 3), dist (5,), rvec (3,), tvec (3,))`` for OpenCV.

        ``dist`` is ``(k1, k2, p1, p2, k3)`` (identical order to Bouguet's ``kc``). OpenCV's
        ``projectPoints`` ignores ``K[0, 1]``, so a camera with skew projects differently there.
        """
        rvec, _ = cv2.Rodrigues(self.R)
        return self.K, self.kc.copy(), rvec.reshape(3), self.T.copy()

    @classmethod
    def from_opencv(cls, name, K, dist, rvec, tvec, size=(640, 480), source=None) -> Camera:
        """Build a camera from OpenCV parameters (``dist`` with 4, 5 or more terms; the first 5 kept).

        Distortion terms beyond ``k3`` (rational or thin-prism models) cannot be represented and
        raise :class:`InputError` when non-zero.
        """
        src = source or f"camera {name}"
        K = np.asarray(K, dtype=float).reshape(3, 3)
        dist = np.asarray(dist, dtype=float).reshape(-1)
        if dist.size < 5:
            dist = np.concatenate([dist, np.zeros(5 - dist.size)])
        if np.any(dist[5:] != 0):
            raise InputError(src, "distortion terms beyond k3 are not supported by the .cal model")
        rvec = _as_vector(rvec, 3, "rotation vector", src)
        R, _ = cv2.Rodrigues(rvec.reshape(3, 1))
        fx = K[0, 0]
        alpha = K[0, 1] / fx if fx else 0.0
        return cls(name=name, fc=(K[0, 0], K[1, 1]), cc=(K[0, 2], K[1, 2]), alpha_c=alpha,
                   kc=dist[:5], R=R, T=tvec, size=size, source=source)

    def with_size(self, size) -> Camera:
        """A copy with another image size ``(W, H)``."""
        return Camera(self.name, self.fc, self.cc, self.R, self.T, self.alpha_c, self.kc, size,
                      self.source)

    def resized(self, size) -> Camera:
        """The camera of the same view imaged at ``size = (W', H')`` pixels (a resized image).

        The image's edges map onto each other (OpenCV's ``resize``), so pixel centres go as
        ``u' = (u + ½)·W'/W − ½`` (Bouguet's pixel (0, 0) is centred at (0, 0)): ``fc`` scales
        by ``W'/W`` and ``H'/H``, ``cc`` as a pixel centre; the skew and distortion, which act
        on normalised coordinates, stay.
        """
        w, h = self.size
        s = np.array([size[0] / w, size[1] / h])
        return Camera(self.name, np.asarray(self.fc) * s, (np.asarray(self.cc) + 0.5) * s - 0.5,
                      self.R, self.T, self.alpha_c, self.kc, (int(size[0]), int(size[1])),
                      self.source)

    def __repr__(self) -> str:
        c = self.center
        return (f"Camera({self.name!r}, f=({self.fc[0]:.1f}, {self.fc[1]:.1f}), "
                f"centre=({c[0]:.0f}, {c[1]:.0f}, {c[2]:.0f}) mm, size={self.size})")


# ---------------------------------------------------------------------- rigs
class Rig(Sequence):
    """An ordered list of cameras with unique names.

    Parameters
    ----------
    cameras : iterable of Camera
        The cameras, in the order to use (HumanEva order when read from a folder).
    """

    def __init__(self, cameras: Iterable[Camera]):
        self.cameras = list(cameras)
        names = [c.name for c in self.cameras]
        if len(set(names)) != len(names):
            raise InputError("rig", f"camera names are not unique: {names}")

    @property
    def names(self) -> list[str]:
        """Camera names in rig order."""
        return [c.name for c in self.cameras]

    def __getitem__(self, key):
        if isinstance(key, str):
            for cam in self.cameras:
                if cam.name.upper() == key.upper():
                    return cam
            raise KeyError(key)
        if isinstance(key, slice):
            return Rig(self.cameras[key])
        return self.cameras[key]

    def __len__(self) -> int:
        return len(self.cameras)

    def __iter__(self) -> Iterator[Camera]:
        return iter(self.cameras)

    def select(self, names: Iterable[str]) -> Rig:
        """The sub-rig of the named cameras, in the given order (case-insensitive names)."""
        out = []
        for n in names:
            try:
                out.append(self[n])
            except KeyError:
                raise InputError("cameras", f"unknown camera {n!r} (have "
                                            f"{', '.join(self.names)})") from None
        return Rig(out)

    def __repr__(self) -> str:
        return f"Rig({', '.join(self.names)})"


# ---------------------------------------------------------------------- visibility
def shrunk_size(size, max_side: int, *, smallest: int = 1) -> tuple[int, int]:
    """``(W', H')``: ``size = (W, H)`` scaled to at most ``max_side`` pixels on a side (never
    enlarged), each side rounded and at least ``smallest``."""
    w, h = (int(v) for v in size)
    s = min(1.0, max_side / max(w, h))
    if s == 1.0:
        return w, h
    return max(smallest, int(round(w * s))), max(smallest, int(round(h * s)))


def fov_radius(camera) -> float:
    """Largest trusted undistorted normalised radius of ``camera`` (``FOV_MARGIN`` × the border's).

    Parameters
    ----------
    camera : Camera
        The camera.

    Returns
    -------
    float
        Radius in normalised pinhole coordinates (``x/z``, ``y/z``).
    """
    w, h = camera.size
    # The edge of what rounds into the image: half a pixel beyond the outermost pixel centres.
    t = np.linspace(0.0, 1.0, 65)
    us = t * w - 0.5
    vs = t * h - 0.5
    border = np.concatenate([
        np.stack([us, np.full_like(us, -0.5)], axis=1),
        np.stack([us, np.full_like(us, h - 0.5)], axis=1),
        np.stack([np.full_like(vs, -0.5), vs], axis=1),
        np.stack([np.full_like(vs, w - 0.5), vs], axis=1),
    ])
    k1, k2, _, _, k3 = camera.kc
    # Where the radial model stops being monotonic (r·(1 + k1 r² + k2 r⁴ + k3 r⁶) turns around).
    r = np.linspace(0.0, 10.0, 20001)
    rd = r * (1.0 + k1 * r**2 + k2 * r**4 + k3 * r**6)
    turn = np.flatnonzero(np.diff(rd) <= 0)
    r_fold = float(r[turn[0]]) if len(turn) else np.inf
    with np.errstate(invalid="ignore", over="ignore"):
        norm = camera.undistort_pixels(border)
        r_border = float(np.max(np.linalg.norm(norm, axis=1)))
    if not np.isfinite(r_border) or r_border > r_fold:
        # Image corners beyond the fold cannot be undistorted: trust the model up to the fold.
        return r_fold
    return min(FOV_MARGIN * r_border, r_fold)


def visible(camera, points, *, r_max: float | None = None):
    """Pixels of ``points`` in ``camera`` and whether the camera sees them.

    Parameters
    ----------
    camera : Camera
        The camera.
    points : (N, 3) array_like
        World points (mm).
    r_max : float, optional
        Trusted normalised radius; default :func:`fov_radius` of the camera.

    Returns
    -------
    u, v : (N,) int64 ndarray
        ``round(u)``, ``round(v)`` (meaningless where not seen).
    seen : (N,) bool ndarray
        In front of the camera, within the field of view and rounding into the image.
    """
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    r_max = fov_radius(camera) if r_max is None else r_max
    # Camera.project's model step by step (its distortion code included). The rigid transform is
    # written out element-wise: a BLAS matmul of (N, 3) by (3, 3) is slow on the transposed R and
    # collapses when its threads compete for busy cores.
    R, T = camera.R, camera.T
    x, y, w = points[:, 0], points[:, 1], points[:, 2]
    xc0 = R[0, 0] * x + R[0, 1] * y + R[0, 2] * w + T[0]
    xc1 = R[1, 0] * x + R[1, 1] * y + R[1, 2] * w + T[1]
    z = R[2, 0] * x + R[2, 1] * y + R[2, 2] * w + T[2]
    front = z > 0
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        ab = np.stack([xc0 / z, xc1 / z], axis=1)
        r2 = np.einsum("ij,ij->i", ab, ab)
        xd, yd = camera.distort(ab).T
        pix = np.stack([camera.fc[0] * (xd + camera.alpha_c * yd) + camera.cc[0],
                        camera.fc[1] * yd + camera.cc[1]], axis=1)
    ok = front & (r2 <= r_max * r_max)
    pix = np.where(ok[:, None], pix, -1.0)
    u = np.rint(pix[:, 0]).astype(np.int64)
    v = np.rint(pix[:, 1]).astype(np.int64)
    w, h = camera.size
    seen = ok & (u >= 0) & (u < w) & (v >= 0) & (v < h)
    return u, v, seen
