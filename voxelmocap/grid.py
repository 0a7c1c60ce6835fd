"""Axis-aligned voxel grids in world millimetres.

A :class:`VoxelGrid` is defined by its ``origin`` (the outer corner of voxel ``(0, 0, 0)``), a cubic
``voxel_size`` and a ``shape`` ``(nx, ny, nz)``. Voxel ``(i, j, k)`` has its centre at
``origin + (i + 0.5, j + 0.5, k + 0.5) * voxel_size``. Volumes are C-ordered ``(nx, ny, nz)`` arrays,
so the flat index of ``(i, j, k)`` is ``(i * ny + j) * nz + k`` and a column ``(i, j)`` is contiguous
along z.

>>> grid = VoxelGrid(origin=(-1000.0, -1000.0, 0.0), voxel_size=20.0, shape=(100, 100, 100))
>>> grid.centre_of((0, 0, 0))
array([-990., -990.,   10.])
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import InputError

__all__ = ["VoxelGrid"]


@dataclass(frozen=True)
class VoxelGrid:
    """A regular grid of cubic voxels.

    Parameters
    ----------
    origin : (3,) array_like
        World position (mm) of the outer corner of voxel ``(0, 0, 0)``.
    voxel_size : float
        Edge length of a voxel (mm), > 0.
    shape : (3,) tuple of int
        Number of voxels ``(nx, ny, nz)`` along x, y and z, each >= 1.
    """

    origin: tuple[float, float, float]
    voxel_size: float
    shape: tuple[int, int, int]

    def __post_init__(self):
        origin = tuple(float(v) for v in np.asarray(self.origin, dtype=float).reshape(-1))
        shape = tuple(int(v) for v in np.asarray(self.shape).reshape(-1))
        if len(origin) != 3 or not np.all(np.isfinite(origin)):
            raise InputError("grid", f"origin must be 3 finite numbers, got {self.origin!r}")
        if len(shape) != 3 or min(shape) < 1:
            raise InputError("grid", f"shape must be 3 positive integers, got {self.shape!r}")
        size = float(self.voxel_size)
        if not np.isfinite(size) or size <= 0:
            raise InputError("grid", f"voxel_size must be a positive number, got {self.voxel_size!r}")
        object.__setattr__(self, "origin", origin)
        object.__setattr__(self, "shape", shape)
        object.__setattr__(self, "voxel_size", size)

    @classmethod
    def from_bounds(cls, low, high, voxel_size: float) -> VoxelGrid:
        """The smallest grid with corner ``low`` whose voxels cover the box ``[low, high]`` (mm)."""
        low = np.asarray(low, dtype=float)
        high = np.asarray(high, dtype=float)
        if low.shape != (3,) or high.shape != (3,) or np.any(high <= low):
            raise InputError("grid", f"bounds must satisfy low < high per axis, got {low} and {high}")
        shape = np.ceil((high - low) / float(voxel_size) - 1e-9).astype(int)
        return cls(origin=tuple(low), voxel_size=voxel_size, shape=tuple(np.maximum(shape, 1)))

    @property
    def n_voxels(self) -> int:
        """Total number of voxels ``nx * ny * nz``."""
        nx, ny, nz = self.shape
        return nx * ny * nz

    @property
    def low(self) -> np.ndarray:
        """(3,) world position (mm) of the grid's lower corner (the origin)."""
        return np.asarray(self.origin, dtype=float)

    @property
    def high(self) -> np.ndarray:
        """(3,) world position (mm) of the grid's upper corner."""
        return self.low + np.asarray(self.shape, dtype=float) * self.voxel_size

    def axis_centres(self, axis: int) -> np.ndarray:
        """(n,) world coordinates (mm) of the voxel centres along one axis (0 = x, 1 = y, 2 = z)."""
        n = self.shape[axis]
        return self.origin[axis] + (np.arange(n, dtype=float) + 0.5) * self.voxel_size

    def centres(self) -> np.ndarray:
        """(nx * ny * nz, 3) world positions (mm) of all voxel centres, in C (flat-index) order."""
        xs, ys, zs = (self.axis_centres(a) for a in range(3))
        gx, gy, gz = np.meshgrid(xs, ys, zs, indexing="ij")
        return np.stack([gx.ravel(), gy.ravel(), gz.ravel()], axis=1)

    def centre_of(self, index) -> np.ndarray:
        """World position (mm) of the centre of voxel ``index`` = ``(i, j, k)``; (..., 3) for (..., 3)."""
        index = np.asarray(index, dtype=float)
        return self.low + (index + 0.5) * self.voxel_size

    def index_of(self, points) -> np.ndarray:
        """Integer voxel indices ``(N, 3)`` of world points ``(N, 3)`` (mm); may be out of range."""
        points = np.asarray(points, dtype=float)
        return np.floor((points - self.low) / self.voxel_size).astype(np.int64)

    def contains_index(self, index) -> np.ndarray:
        """Boolean ``(N,)``: which integer indices ``(N, 3)`` lie inside the grid."""
        index = np.asarray(index)
        return np.all((index >= 0) & (index < np.asarray(self.shape)), axis=-1)

    def empty(self, dtype=bool) -> np.ndarray:
        """A zero-filled ``(nx, ny, nz)`` volume of this grid."""
        return np.zeros(self.shape, dtype=dtype)

    def check_volume(self, volume, name: str = "volume") -> np.ndarray:
        """Return ``volume`` as an array after checking that its shape is this grid's shape."""
        volume = np.asarray(volume)
        if volume.shape != self.shape:
            raise InputError(name, f"shape {volume.shape} does not match the grid {self.shape}")
        return volume

    def to_dict(self) -> dict:
        """Plain-type description for TOML / HDF5 attributes."""
        return {"origin": list(self.origin), "voxel_size": self.voxel_size, "shape": list(self.shape)}

    @classmethod
    def from_dict(cls, data: dict, source: str = "grid") -> VoxelGrid:
        """Inverse of :meth:`to_dict`; ``source`` names the file in error messages."""
        try:
            return cls(origin=data["origin"], voxel_size=data["voxel_size"], shape=data["shape"])
        except KeyError as exc:
            raise InputError(source, f"grid description lacks {exc.args[0]!r}") from None
        except (TypeError, ValueError) as exc:
            raise InputError(source, f"bad grid description ({exc})") from None
