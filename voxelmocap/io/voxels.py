"""Voxel dumps for inspection: HDF5 per-frame volumes and PLY exports of occupied voxels.

HDF5 layout (``format = "voxelmocap-voxels"``, ``version = 1``)::

    /                 attrs: format, version, grid_origin (3,) mm, grid_voxel_size mm,
                             grid_shape (3,), camera_names, plus any caller attributes
    /frames           (F,) int32     synchronised 1-based frame numbers, in write order
    /occupancy        (F, nx, ny, nz) uint8   V^R (0/1)
    /surface          (F, nx, ny, nz) uint8   V^S (0/1)             optional
    /smoothed         (F, nx, ny, nz) float32 Ṽ^S in [0, 1]         optional
    /masks            (F, N_C, H, W) uint8    silhouettes (0/1)      optional
                      attrs: sizes (N_C, 2) each camera's (W, H); a smaller image fills the
                      top-left of its plane, the rest 0 (H, W: the largest)
    /cameras/<name>   attrs: fc, cc, alpha_c, kc, R, T, size         optional (the rig used)

Volumes are chunked one frame per chunk (masks one camera image per chunk) and gzip-compressed,
so a viewer reads one frame without touching the others. :class:`VoxelDumpWriter` writes to a
temporary name and renames the file when it is closed without error (nothing half-written is
left under the final name). :class:`VoxelDump` reads it back and refuses files that are not HDF5,
are not voxel dumps or are inconsistent, with an :class:`~voxelmocap.errors.InputError` naming the
file. :func:`write_ply` exports occupied voxels as an Open3D voxel-grid PLY (or a point cloud of
their centres, for viewers that do not know Open3D's voxel elements).

>>> with VoxelDumpWriter("vox.h5", grid, cameras=rig) as out:   # doctest: +SKIP
...     out.write(12, occupancy, surface=surface, smoothed=smoothed, masks=masks)
>>> with VoxelDump("vox.h5") as dump:                           # doctest: +SKIP
...     occ = dump.occupancy(12)
"""

from __future__ import annotations

import contextlib
import json
import os
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..grid import VoxelGrid
from ._atomic import atomic_path, create_temporary, write_error
from ._hdf5 import WRITE_ERRORS, abandon

__all__ = ["FORMAT", "VERSION", "VoxelDump", "VoxelDumpWriter", "write_ply"]

FORMAT = "voxelmocap-voxels"
VERSION = 1
_VOLUMES = ("occupancy", "surface", "smoothed")
_CAMERA_KEYS = ("fc", "cc", "alpha_c", "kc", "R", "T", "size")


class VoxelDumpWriter:
    """Write a voxel dump frame by frame (a context manager; atomic on success).

    Parameters
    ----------
    path : str or os.PathLike
        The ``.h5`` file to create (replaced if it exists, once complete).
    grid : VoxelGrid
        The grid of every volume.
    cameras : sequence of Camera, optional
        Stored under ``/cameras`` (names, in order, also as the ``camera_names`` attribute).
    attrs : dict, optional
        Extra root attributes (strings, numbers, arrays; dicts are stored as JSON text).
    compression : int
        gzip level (0–9).
    """

    def __init__(self, path, grid: VoxelGrid, *, cameras=None, attrs: dict | None = None,
                 compression: int = 4):
        import h5py

        self.path = Path(path)
        self.grid = grid
        self.cameras = list(cameras) if cameras is not None else []
        self._level = int(compression)
        # the temporary keeps the .h5 suffix and lives beside the target, so the rename is atomic;
        # creating it checks that the place can be written (InputError otherwise, nothing left)
        self._tmp = create_temporary(self.path)
        try:
            self._file = h5py.File(self._tmp, "w")
        except OSError as exc:
            self._tmp.unlink(missing_ok=True)
            raise InputError(self.path, f"cannot create the file ({exc})") from None
        f = self._file
        f.attrs["format"] = FORMAT
        f.attrs["version"] = VERSION
        f.attrs["grid_origin"] = np.asarray(grid.origin, dtype=float)
        f.attrs["grid_voxel_size"] = float(grid.voxel_size)
        f.attrs["grid_shape"] = np.asarray(grid.shape, dtype=np.int64)
        f.attrs["camera_names"] = json.dumps([c.name for c in self.cameras])
        for key, value in (attrs or {}).items():
            f.attrs[key] = json.dumps(value) if isinstance(value, dict) else value
        if self.cameras:
            group = f.create_group("cameras")
            for cam in self.cameras:
                g = group.create_group(cam.name)
                for key in _CAMERA_KEYS:
                    g.attrs[key] = np.asarray(getattr(cam, key))
        f.create_dataset("frames", shape=(0,), maxshape=(None,), dtype=np.int32, chunks=(1024,))
        self._n = 0
        self._present: tuple | None = None
        self._datasets: dict = {}

    def __enter__(self) -> VoxelDumpWriter:
        return self

    def __exit__(self, exc_type, exc, tb):
        if exc_type is None:
            self.close()
        else:
            self.abort()
        return False

    @property
    def n_frames(self) -> int:
        """Frames written so far."""
        return self._n

    def _dataset(self, name: str, shape: tuple, dtype, chunk: tuple):
        # handles held for the file's life (see io._hdf5: a failed write must not surface only
        # when a dropped handle is deallocated)
        if name not in self._datasets:
            f = self._file
            if name not in f:
                f.create_dataset(name, shape=(0, *shape), maxshape=(None, *shape), dtype=dtype,
                                 chunks=(1, *chunk), compression="gzip",
                                 compression_opts=self._level, shuffle=dtype == np.float32)
            self._datasets[name] = f[name]
        return self._datasets[name]

    def write(self, frame: int, occupancy, *, surface=None, smoothed=None, masks=None) -> None:
        """Append one frame.

        Parameters
        ----------
        frame : int
            Synchronised 1-based frame number.
        occupancy : (nx, ny, nz) array_like of bool
            ``V^R``.
        surface : (nx, ny, nz) array_like of bool, optional
            ``V^S``.
        smoothed : (nx, ny, nz) array_like of float, optional
            ``Ṽ^S``.
        masks : (N_C, H, W) array_like or sequence of (H_c, W_c) array_like of bool, optional
            Silhouettes in camera order (cameras may differ in size).

        Every frame of a file must carry the same optional volumes.
        """
        present = (surface is not None, smoothed is not None, masks is not None)
        if self._present is None:
            self._present = present
        elif present != self._present:
            raise InputError(self.path, "every frame must carry the same volumes "
                                        f"(surface, smoothed, masks present: {self._present})")
        shape = self.grid.shape
        items = [("occupancy", occupancy, np.uint8), ("surface", surface, np.uint8),
                 ("smoothed", smoothed, np.float32)]
        volumes = []
        for name, value, dtype in items:
            if value is None:
                continue
            arr = self.grid.check_volume(value, name)
            volumes.append((name, dtype, shape, shape,
                            (arr != 0).astype(np.uint8) if dtype == np.uint8
                            else arr.astype(np.float32)))
        if masks is not None:
            m, sizes = _padded_masks(masks, len(self.cameras))
            known = self._datasets.get("masks")
            if known is not None and not np.array_equal(known.attrs["sizes"], sizes):
                raise InputError("masks", f"sizes {sizes.tolist()} differ from earlier frames' "
                                          f"{known.attrs['sizes'].tolist()}")
            volumes.append(("masks", np.uint8, m.shape, (1, *m.shape[1:]), m))
        try:
            for name, dtype, row_shape, chunk, value in volumes:
                ds = self._dataset(name, row_shape, dtype, chunk)
                if name == "masks" and "sizes" not in ds.attrs:
                    ds.attrs["sizes"] = sizes
                ds.resize(self._n + 1, axis=0)
                ds[self._n] = value
            frames = self._dataset("frames", (), np.int32, ())
            frames.resize(self._n + 1, axis=0)
            frames[self._n] = int(frame)
            self._file.flush()  # a full disk is met here, not in a handle's deallocator
        except WRITE_ERRORS as exc:
            self._fail(exc)
        self._n += 1

    def _fail(self, exc: BaseException) -> None:
        self._datasets = {}
        abandon(self._file)
        self._file = None
        with contextlib.suppress(FileNotFoundError):
            self._tmp.unlink()
        raise write_error(self.path, exc) from None

    def close(self) -> None:
        """Finish the file and move it to its final name."""
        if self._file is None:
            return
        try:
            self._file.attrs["n_frames"] = self._n
            self._file.flush()
        except WRITE_ERRORS as exc:
            self._fail(exc)
        try:
            self._datasets = {}
            self._file.close()
            self._file = None
            os.replace(self._tmp, self.path)
        except OSError as exc:
            self.abort()
            raise InputError(self.path, f"cannot write the file ({exc})") from None

    def abort(self) -> None:
        """Discard the file (nothing is left under the final name, nor a temporary)."""
        if self._file is not None:
            self._datasets = {}
            abandon(self._file)  # its content is discarded: nothing more need reach the disk
            self._file = None
        with contextlib.suppress(FileNotFoundError):
            self._tmp.unlink()


class VoxelDump:
    """Read a voxel dump (a context manager; the file stays open until :meth:`close`).

    Parameters
    ----------
    path : str or os.PathLike
        The ``.h5`` file.

    Raises
    ------
    InputError
        Missing file, not HDF5 (or corrupt), not a voxel dump, a newer version, or datasets
        whose shapes disagree with the grid and frame list.
    """

    def __init__(self, path):
        import h5py

        self.path = Path(path)
        if not self.path.is_file():
            raise InputError(self.path, "voxel dump not found")
        try:
            self._file = h5py.File(self.path, "r")
        except OSError:
            raise InputError(self.path, "not a readable HDF5 file (corrupt or truncated?)") from None
        try:
            self._check()
        except InputError:
            self._file.close()
            raise
        except (KeyError, OSError, ValueError, TypeError) as exc:
            self._file.close()
            raise InputError(self.path, f"damaged voxel dump ({exc.__class__.__name__}: {exc})") \
                from None

    def _check(self) -> None:
        f = self._file
        fmt = f.attrs.get("format")
        if isinstance(fmt, bytes):
            fmt = fmt.decode()
        if fmt != FORMAT:
            raise InputError(self.path, f"not a voxelmocap voxel dump (format {fmt!r})")
        if int(f.attrs.get("version", 0)) > VERSION:
            raise InputError(self.path, f"written by a newer version ({f.attrs['version']}); "
                                        f"this reader knows version {VERSION}")
        self.grid = VoxelGrid.from_dict({"origin": f.attrs["grid_origin"],
                                         "voxel_size": f.attrs["grid_voxel_size"],
                                         "shape": f.attrs["grid_shape"]}, source=str(self.path))
        self.frames = np.asarray(f["frames"][...], dtype=np.int64)
        n = len(self.frames)
        if "occupancy" not in f:
            raise InputError(self.path, "has no occupancy dataset")
        for name in (*_VOLUMES, "masks"):
            if name not in f:
                continue
            shape = f[name].shape
            if shape[0] != n or (name != "masks" and tuple(shape[1:]) != self.grid.shape):
                raise InputError(self.path, f"dataset {name!r} has shape {shape}, expected "
                                            f"({n}, ...) on the grid {self.grid.shape}")
        self.camera_names = list(json.loads(f.attrs.get("camera_names", "[]")))
        self._index = {int(fr): i for i, fr in enumerate(self.frames)}

    def __enter__(self) -> VoxelDump:
        return self

    def __exit__(self, *exc):
        self.close()
        return False

    def close(self) -> None:
        """Close the file."""
        if self._file is not None:
            self._file.close()
            self._file = None

    @property
    def attrs(self) -> dict:
        """Root attributes as plain Python values."""
        out = {}
        for key, value in self._file.attrs.items():
            out[key] = value.decode() if isinstance(value, bytes) else value
        return out

    def has(self, name: str) -> bool:
        """Whether the dump holds ``name`` (``"surface"``, ``"smoothed"``, ``"masks"``, …)."""
        return name in self._file

    def cameras(self) -> list:
        """The stored :class:`~voxelmocap.camera.Camera` list ([] when none was stored)."""
        from ..camera import Camera

        if "cameras" not in self._file:
            return []
        group = self._file["cameras"]
        names = self.camera_names or list(group)
        out = []
        for name in names:
            a = group[name].attrs
            out.append(Camera(name, fc=a["fc"], cc=a["cc"], R=a["R"], T=a["T"],
                              alpha_c=float(a["alpha_c"]), kc=a["kc"],
                              size=tuple(int(v) for v in a["size"]), source=str(self.path)))
        return out

    def index(self, frame: int) -> int:
        """Position of synchronised ``frame`` in the file."""
        try:
            return self._index[int(frame)]
        except KeyError:
            have = (f"{self.frames.min()}..{self.frames.max()}" if len(self.frames) else "none")
            raise InputError("frame", f"frame {frame} is not in {self.path.name} (frames: {have}, "
                                      f"{len(self.frames)} in all)") from None

    def _read(self, name: str, frame: int) -> np.ndarray:
        if name not in self._file:
            raise InputError(self.path, f"holds no {name!r} volumes")
        i = self.index(frame)
        try:
            return self._file[name][i]
        except (OSError, ValueError) as exc:
            raise InputError(self.path, f"cannot read {name!r} of frame {frame} (damaged file: "
                                        f"{exc})") from None

    def occupancy(self, frame: int) -> np.ndarray:
        """``(nx, ny, nz)`` bool ``V^R`` of ``frame``."""
        return self._read("occupancy", frame).astype(bool)

    def surface(self, frame: int) -> np.ndarray:
        """``(nx, ny, nz)`` bool ``V^S`` of ``frame``."""
        return self._read("surface", frame).astype(bool)

    def smoothed(self, frame: int) -> np.ndarray:
        """``(nx, ny, nz)`` float32 ``Ṽ^S`` of ``frame``."""
        return self._read("smoothed", frame)

    def masks(self, frame: int):
        """The silhouettes of ``frame`` in camera order.

        Returns
        -------
        (N_C, H, W) bool ndarray, or list of (H_c, W_c) bool ndarray
            An array when every camera has the same image size, else one array per camera at
            its own size (the file stores them padded to the largest).
        """
        stacked = self._read("masks", frame).astype(bool)
        sizes = self._file["masks"].attrs.get("sizes")
        if sizes is None or (np.asarray(sizes) == sizes[0]).all():
            return stacked    # version-1 files before 2026-11-27 hold one size and no "sizes"
        return [m[:h, :w] for m, (w, h) in zip(stacked, sizes.tolist(), strict=True)]


def _padded_masks(masks, n_cameras: int) -> tuple[np.ndarray, np.ndarray]:
    """``(N_C, H_max, W_max)`` uint8 0/1 masks padded with 0, and their ``(N_C, 2)`` (W, H)."""
    arrays = [np.asarray(m) for m in masks]
    if (not arrays or any(a.ndim != 2 for a in arrays)
            or (n_cameras and len(arrays) != n_cameras)):
        got = [a.shape for a in arrays]
        raise InputError("masks", f"expected {n_cameras or 'N_C'} (H, W) masks, got shapes {got}")
    sizes = np.array([(a.shape[1], a.shape[0]) for a in arrays], dtype=np.int64)
    out = np.zeros((len(arrays), sizes[:, 1].max(), sizes[:, 0].max()), np.uint8)
    for plane, a in zip(out, arrays, strict=True):
        plane[:a.shape[0], :a.shape[1]] = a != 0
    return out, sizes


def write_ply(path, grid: VoxelGrid, occupancy, *, values=None, points: bool = False) -> int:
    """Write the occupied voxels of one volume as a PLY file (Open3D), atomically.

    Parameters
    ----------
    path : str or os.PathLike
        The ``.ply`` file.
    grid : VoxelGrid
        The volume's grid.
    occupancy : (nx, ny, nz) array_like of bool
        Voxels to write.
    values : (nx, ny, nz) array_like of float, optional
        Colours the voxels through the viridis colour map (values in [0, 1]); default: by height.
    points : bool
        Write a point cloud of voxel centres instead of an Open3D voxel grid.

    Returns
    -------
    int
        Number of voxels written.
    """
    import open3d as o3d
    from matplotlib import colormaps

    occ = grid.check_volume(occupancy, "occupancy").astype(bool)
    idx = np.argwhere(occ)
    centres = grid.centre_of(idx) if len(idx) else np.zeros((0, 3))
    if values is not None:
        level = np.clip(grid.check_volume(values, "values")[occ].astype(float), 0.0, 1.0)
    else:
        span = max(grid.high[2] - grid.low[2], 1e-9)
        level = (centres[:, 2] - grid.low[2]) / span
    colours = colormaps["viridis"](level)[:, :3] if len(idx) else np.zeros((0, 3))
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(centres))
    cloud.colors = o3d.utility.Vector3dVector(colours)
    path = Path(path)
    with atomic_path(path) as tmp:
        if len(idx) == 0:
            # Open3D refuses to write nothing; an empty frame still gets a valid (empty) PLY
            tmp.write_text("ply\nformat ascii 1.0\ncomment voxelmocap: no occupied voxels\n"
                           "element vertex 0\nproperty double x\nproperty double y\n"
                           "property double z\nend_header\n")
            return 0
        if points:
            ok = o3d.io.write_point_cloud(str(tmp), cloud, write_ascii=False)
        else:
            vg = o3d.geometry.VoxelGrid.create_from_point_cloud_within_bounds(
                cloud, grid.voxel_size, grid.low, grid.high)
            ok = o3d.io.write_voxel_grid(str(tmp), vg, write_ascii=False)
        if not ok:
            raise InputError(path, "Open3D could not write the PLY file")
    return len(idx)
