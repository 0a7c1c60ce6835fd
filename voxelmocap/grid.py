"""Axis-aligned voxel grids in world millimetres.

A :class:`VoxelGrid` is defined by its ``origin`` (the outer corner of voxel ``(0, 0, 0)``), a cubic
``voxel_size`` and a ``shape`` ``(nx, ny, nz)``. Voxel ``(i, j, k)`` has its centre at
``origin + (i + 0.5, j + 0.5, k + 0.5) * voxel_size``. Volumes are C-ordered ``(nx, ny, nz)`` arrays,
so the flat index of ``(i, j, k)`` is ``(i * ny + j) * nz + k`` and a column ``(i, j)`` is contiguous
along z.

>>> grid = VoxelGrid(origin=(-1000.0, -1000.0, 0.0), voxel_size=20.0, shape=(100, 100, 100))
>>> grid.centre_of((0, 0, 0))
array([-990., -990.,   10.])

:meth:`VoxelGrid.from_rig` derives the default capture volume from a camera rig: the floor-standing
box (floor at Z = 0 up to a head-room height) over the floor area that enough cameras see.
:meth:`VoxelGrid.check_memory` refuses grids whose per-voxel arrays would not fit in memory, naming
the size they would need.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from .camera import visible
from .errors import InputError

__all__ = ["MIN_VOXELS_PER_AXIS", "VoxelGrid", "available_memory"]

#: Share of the available memory a single grid's arrays may take before :meth:`VoxelGrid.check_memory`
#: refuses it (the rest is left to the images, the tracker and the other processes).
MEMORY_SHARE = 0.5

#: Fewest voxels along any axis of a measurement grid: below it a body part is smaller than a
#: voxel, and the 6-neighbour surface and its Gaussian smoothing have nothing to work on.
MIN_VOXELS_PER_AXIS = 8


def available_memory() -> int | None:
    """Bytes of memory available to new allocations (Linux ``MemAvailable``), or None if unknown."""
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return int(os.sysconf("SC_AVPHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return None


def _format_bytes(n: float) -> str:
    for unit in ("B", "kB", "MB", "GB", "TB"):
        if n < 1024 or unit == "TB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1024
    return f"{n:.1f} TB"  # pragma: no cover


#: Points per side of the floor lattice :meth:`VoxelGrid.from_rig` samples (at most).
_MAX_LATTICE = 1201


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

    @classmethod
    def from_rig(cls, rig, voxel_size: float = 20.0, *, height: float = 2200.0,
                 min_views: int | None = None, margin: float = 0.0, step: float = 50.0,
                 bytes_per_voxel: float | None = None,
                 probe_height: float | None = None) -> VoxelGrid:
        """The floor-standing box seen by the cameras of ``rig``.

        The floor (Z = 0) is sampled on a square lattice of pitch ``step`` around the cameras; a
        lattice point belongs to the capture area when both it and the point ``height`` above it
        are seen by at least ``min_views`` cameras (the carver's rule,
        :func:`voxelmocap.camera.visible`: in front, within the field of view, rounding into the
        image). The grid is
        the axis-aligned box over the capture area's bounding rectangle (grown by ``margin``), from
        the floor to ``height``, with its corner at the floor (x, y snapped down to multiples of
        ``voxel_size``).

        Parameters
        ----------
        rig : sequence of Camera
            The cameras (a :class:`voxelmocap.camera.Rig` or a list).
        voxel_size : float
            Voxel edge (mm).
        height : float
            Top of the box above the floor (mm); 2200 mm holds a standing adult with raised hands
            below shoulder level and room to spare.
        min_views : int, optional
            Cameras that must see a floor point and the point above it; default all cameras.
        margin : float
            Grows the rectangle on every side (mm); may be negative to shrink it.
        step : float
            Pitch of the floor lattice (mm).
        bytes_per_voxel : float, optional
            When given, :meth:`check_memory` is applied with this per-voxel cost.
        probe_height : float, optional
            Height (mm) of the upper point that must be seen with each floor point (default
            ``height``). Cameras mounted below ``height`` and tilted down see little at head-room
            height: a lower probe (e.g. 1000 mm) gives the floor area where a person's body is
            seen, which the coarse carve that places the grid around the person needs.

        Raises
        ------
        InputError
            When no floor area is seen by ``min_views`` cameras, the grid has fewer than
            :data:`MIN_VOXELS_PER_AXIS` voxels along an axis, or it would not fit in memory.
        """
        cameras = list(rig)
        if not cameras:
            raise InputError("rig", "no cameras to derive a grid from")
        n_req = len(cameras) if min_views is None else int(min_views)
        if not 1 <= n_req <= len(cameras):
            raise InputError("min_views", f"must be between 1 and {len(cameras)}, got {min_views!r}")
        if not height > 0 or not step > 0:
            raise InputError("grid", f"height and step must be positive, got {height!r}, {step!r}")
        centres = np.array([c.center for c in cameras], dtype=float)
        mid = centres[:, :2].mean(axis=0)
        # Everything a camera can see of the floor near the person lies well within the cameras'
        # horizontal spread; 1.5× the farthest camera is a generous search square.
        half = 1.5 * max(float(np.max(np.linalg.norm(centres[:, :2] - mid, axis=1))), 1000.0)
        # A lattice of at most _MAX_LATTICE² points: cameras tens of metres apart (a calibration
        # in the wrong unit) would otherwise allocate gigabytes before any check.
        step = max(float(step), 2 * half / (_MAX_LATTICE - 1))
        n = int(np.ceil(2 * half / step)) + 1
        xs = mid[0] - half + step * np.arange(n)
        ys = mid[1] - half + step * np.arange(n)
        gx, gy = np.meshgrid(xs, ys, indexing="ij")
        floor = np.stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)], axis=1)
        top = floor + np.array([0.0, 0.0, float(height if probe_height is None
                                                 else probe_height)])
        # the carver's visibility rule: in front, inside the trusted field of view (the lens
        # polynomial folds far off-axis points back into the image), rounding into the image
        views = np.zeros(len(floor), dtype=np.int32)
        for cam in cameras:
            views += visible(cam, floor)[2] & visible(cam, top)[2]
        inside = floor[views >= n_req]
        if len(inside) == 0:
            raise InputError("rig", f"no floor area is seen by {n_req} of the {len(cameras)} "
                                    f"cameras up to {height:g} mm; lower min_views or give the "
                                    "grid explicitly")
        low = np.array([*(inside[:, :2].min(axis=0) - 0.5 * step - margin), 0.0])
        high = np.array([*(inside[:, :2].max(axis=0) + 0.5 * step + margin), float(height)])
        # Snap the horizontal corner to whole voxels so that grids of one rig line up across runs.
        size = float(voxel_size)
        low[:2] = np.floor(low[:2] / size) * size
        grid = cls.from_bounds(low, high, voxel_size)
        if min(grid.shape) < MIN_VOXELS_PER_AXIS:
            nx, ny, nz = grid.shape
            raise InputError("measurement.voxel_size",
                             f"{size:g} mm voxels give a {nx}x{ny}x{nz} grid over the capture "
                             f"area ({high[0] - low[0]:.0f} x {high[1] - low[1]:.0f} x "
                             f"{high[2]:.0f} mm); at least {MIN_VOXELS_PER_AXIS} voxels along "
                             "every axis are needed: use smaller voxels")
        if bytes_per_voxel is not None:
            grid.check_memory(bytes_per_voxel)
        return grid

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

    def nbytes(self, bytes_per_voxel: float = 1.0) -> int:
        """Bytes needed by arrays costing ``bytes_per_voxel`` per voxel over this grid."""
        return int(np.ceil(float(self.n_voxels) * float(bytes_per_voxel)))

    def check_memory(self, bytes_per_voxel: float = 1.0, *, what: str = "arrays",
                     available: int | None = None) -> int:
        """Refuse grids whose arrays would not fit in memory.

        Parameters
        ----------
        bytes_per_voxel : float
            Cost of the caller's arrays per voxel (bytes), e.g. ``4 * N_C + 2`` for a carver.
        what : str
            What the memory is for, quoted in the message.
        available : int, optional
            Bytes available; default :func:`available_memory`. The grid may use at most
            ``MEMORY_SHARE`` of it.

        Returns
        -------
        int
            The bytes needed.

        Raises
        ------
        InputError
            ``"grid: … would need X GB for <what>, only Y GB available"``.
        """
        need = self.nbytes(bytes_per_voxel)
        avail = available_memory() if available is None else int(available)
        if avail is not None and need > MEMORY_SHARE * avail:
            nx, ny, nz = self.shape
            raise InputError("grid", f"{nx}x{ny}x{nz} voxels of {self.voxel_size:g} mm would need "
                                     f"{_format_bytes(need)} for {what}, but only "
                                     f"{_format_bytes(avail)} of memory is available; use larger "
                                     "voxels or a smaller box")
        return need

    def empty(self, dtype=bool) -> np.ndarray:
        """A zero-filled ``(nx, ny, nz)`` volume of this grid (refused if it cannot fit in memory)."""
        self.check_memory(np.dtype(dtype).itemsize, what="one volume")
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
