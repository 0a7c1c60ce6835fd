"""Shape-from-silhouette carving: silhouettes of calibrated views → voxel occupancy ``V^R``.

A voxel is occupied when its centre projects inside the silhouette of every camera that sees it
(:func:`carve`, default), or of at least ``min_views`` cameras (to survive holes in the masks).
The centre is projected with the full camera model (:meth:`voxelmocap.camera.Camera.project`:
skew and all five distortion terms); its pixel is ``(round(u), round(v))``, pixel ``(0, 0)`` being
centred at ``(u, v) = (0, 0)`` (Bouguet). A camera does not see a voxel — and so never carves it —
when the centre is behind the camera, rounds to a pixel outside the image, or lies outside the
camera's field of view (see below). A voxel that no camera sees is empty.

Field of view. A polynomial lens model is only valid over the image it was calibrated on: far off
axis, ``1 + k1 r² + k2 r⁴ + k3 r⁶`` turns around and folds points from outside the field of view back
into the image. Projections whose undistorted normalised radius exceeds ``FOV_MARGIN`` × the
largest radius of the image border (or the radius where the radial polynomial stops increasing,
if smaller) are therefore treated as outside the image. The rule is
:func:`voxelmocap.camera.visible` (re-exported here with :func:`~voxelmocap.camera.fov_radius`).

Cameras are static, so :class:`Carver` projects every voxel centre once per (rig, grid) into an
``(N_C, n_voxels)`` int32 table of flat pixel indices (-1 = not seen); each frame is then a gather
and an AND in a numba kernel (:mod:`voxelmocap.measure._carving_kernels`) with an early exit at the first
empty view. Before that, whole bricks of 6×6×6 voxels are rejected at once: each brick's pixel
rectangle per camera is stored with the tables, and a rectangle without silhouette pixels (one
look-up in the mask's integral image) proves the camera carves the whole brick, so the empty room
around the person costs one test per brick instead of one per voxel (~1 ms per 3.8 M-voxel frame,
serial; see ``docs/benchmarks.md``). :func:`carve` keeps the last
two carvers in a cache. :func:`carve_reference` is the plain NumPy implementation (straight through
``Camera.project``) that the tests compare against voxel for voxel.

>>> from voxelmocap.io.calibration import read_rig
>>> rig = read_rig("calib/humaneva_i_like")                      # doctest: +SKIP
>>> grid = VoxelGrid.from_rig(rig, 20.0)                                # doctest: +SKIP
>>> carver = Carver(rig, grid)                                          # doctest: +SKIP
>>> occupancy = carver.carve(masks)          # masks: (7, 480, 640) bool  # doctest: +SKIP
"""

from __future__ import annotations

import warnings
from collections import OrderedDict

import cv2
import numpy as np

from ..camera import FOV_MARGIN, fov_radius, visible
from ..errors import InputError
from ..grid import VoxelGrid
from . import _carving_kernels as _k

__all__ = [
    "FOV_MARGIN",
    "Carver",
    "EmptySilhouetteWarning",
    "carve",
    "carve_reference",
    "fov_radius",
    "visible",
]

#: Edge (voxels) of the bricks rejected as a whole when a camera sees only background there.
BRICK = 6

_CACHE: OrderedDict = OrderedDict()
_CACHE_SIZE = 2


class EmptySilhouetteWarning(UserWarning):
    """Every silhouette of a frame is empty (no person in view): the occupancy is empty."""


def _check_cameras(cameras) -> list:
    cameras = list(cameras)
    if not cameras:
        raise InputError("cameras", "no cameras given")
    for cam in cameras:
        if not hasattr(cam, "project") or not hasattr(cam, "size"):
            raise InputError("cameras", f"{cam!r} is not a Camera")
    return cameras


def _check_min_views(min_views, n_cam: int) -> int | None:
    if min_views is None:
        return None
    try:
        k = int(min_views)
    except (TypeError, ValueError):
        raise InputError("min_views", f"must be an integer, got {min_views!r}") from None
    if k != min_views or not 1 <= k <= n_cam:
        raise InputError("min_views", f"must be an integer between 1 and {n_cam} (the number of "
                                      f"cameras), got {min_views!r}")
    return k


def _mask_buffer(masks, cameras) -> np.ndarray:
    """Check the masks against the cameras and return them as one flat uint8 buffer."""
    n_cam = len(cameras)
    if isinstance(masks, np.ndarray):
        if masks.ndim != 3:
            raise InputError("masks", f"expected an (N_C, H, W) array, got shape {masks.shape}")
        items = masks
    else:
        items = list(masks)
    if len(items) != n_cam:
        raise InputError("masks", f"got {len(items)} masks for {n_cam} cameras "
                                  f"({', '.join(getattr(c, 'name', '?') for c in cameras)})")
    for mask, cam in zip(items, cameras, strict=True):
        shape = np.shape(mask)
        w, h = cam.size
        if shape != (h, w):
            raise InputError("masks", f"mask of camera {cam.name} is {shape[1] if len(shape) > 1 else '?'}"
                                      f"x{shape[0] if shape else '?'} pixels but the camera's "
                                      f"image is {w}x{h}")
    if isinstance(items, np.ndarray) and items.dtype == np.bool_:
        return np.ascontiguousarray(items).reshape(-1).view(np.uint8)
    return np.concatenate([np.asarray(m).reshape(-1) != 0 for m in items]).view(np.uint8)


class Carver:
    """Carve frame after frame for one set of static cameras and one grid.

    Parameters
    ----------
    cameras : sequence of Camera
        The cameras, in the order of the masks that will be given (a ``Rig`` works).
    grid : VoxelGrid
        The voxel grid.
    check_memory : bool
        Refuse (``InputError``) grids whose tables would not fit in memory.

    Attributes
    ----------
    tables : (N_C, n_voxels) int32 ndarray, read-only
        Flat index of each voxel centre's pixel in the concatenated masks, -1 where not seen.

    Notes
    -----
    A carver reuses one work buffer between frames: give each thread its own carver.
    """

    def __init__(self, cameras, grid: VoxelGrid, *, check_memory: bool = True):
        if not isinstance(grid, VoxelGrid):
            raise InputError("grid", f"expected a VoxelGrid, got {type(grid).__name__}")
        self.cameras = _check_cameras(cameras)
        self.grid = grid
        n_cam = len(self.cameras)
        if check_memory:
            # tables + occupancy + the counts of diagnostics; the build adds ~100 MB of chunks
            grid.check_memory(4 * n_cam + 3, what=f"the voxel→pixel tables of {n_cam} cameras")
        sizes = [int(c.size[0]) * int(c.size[1]) for c in self.cameras]
        self._offsets = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
        if self._offsets[-1] >= np.iinfo(np.int32).max:
            raise InputError("cameras", "too many pixels in total for int32 tables")
        self.tables = self._build_tables()
        self.tables.flags.writeable = False
        self._build_bricks()
        #: Use the brick rejection (True) or the plain per-voxel kernels (for benchmarks).
        self.use_bricks = True
        # (abstain list, cameras left out, per-voxel count of abstaining views) of the last call
        self._abstained = None

    @property
    def names(self) -> list[str]:
        """Camera names in table order."""
        return [c.name for c in self.cameras]

    def _build_tables(self) -> np.ndarray:
        grid = self.grid
        nx, ny, nz = grid.shape
        tables = np.empty((len(self.cameras), grid.n_voxels), dtype=np.int32)
        for c, cam in enumerate(self.cameras):
            # the kernel is Camera.project written out per voxel centre (see visible() for the
            # NumPy form); tests compare the tables with Camera.project voxel for voxel
            _k.project_table(np.ascontiguousarray(cam.R, dtype=float),
                             np.ascontiguousarray(cam.T, dtype=float),
                             np.ascontiguousarray(cam.fc, dtype=float),
                             np.ascontiguousarray(cam.cc, dtype=float), float(cam.alpha_c),
                             np.ascontiguousarray(cam.kc, dtype=float), fov_radius(cam),
                             grid.low, float(grid.voxel_size), nx, ny, nz, int(cam.size[0]),
                             int(cam.size[1]), int(self._offsets[c]), tables[c])
        return tables

    def _build_bricks(self) -> None:
        nx, ny, nz = self.grid.shape
        n_bricks = (-(-nx // BRICK)) * (-(-ny // BRICK)) * (-(-nz // BRICK))
        n_cam = len(self.cameras)
        self._rects = np.empty((n_cam, n_bricks, 4), dtype=np.int32)
        self._full = np.empty((n_cam, n_bricks), dtype=np.bool_)
        for c, cam in enumerate(self.cameras):
            _k.brick_bounds(self.tables[c], int(self._offsets[c]), int(cam.size[0]), nx, ny, nz,
                            BRICK, self._rects[c], self._full[c])
        sizes = [(int(c.size[0]) + 1) * (int(c.size[1]) + 1) for c in self.cameras]
        self._int_offsets = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64)
        self._int_widths = np.array([int(c.size[0]) + 1 for c in self.cameras], dtype=np.int64)
        self._integral_buf: np.ndarray | None = None

    def _integrals(self, buf: np.ndarray) -> np.ndarray:
        """Concatenated ``(H + 1, W + 1)`` int32 integral images of the flat mask buffer.

        Written into one buffer allocated once per carver (a fresh 8 MB array per frame costs
        more in page faults than the integrals themselves).
        """
        if self._integral_buf is None:
            total = int(self._int_offsets[-1] + self._int_widths[-1] *
                        (int(self.cameras[-1].size[1]) + 1))
            self._integral_buf = np.empty(total, dtype=np.int32)
        for c, cam in enumerate(self.cameras):
            w, h = int(cam.size[0]), int(cam.size[1])
            start = int(self._offsets[c])
            mask = buf[start:start + w * h].reshape(h, w)
            o = int(self._int_offsets[c])
            dst = self._integral_buf[o:o + (w + 1) * (h + 1)].reshape(h + 1, w + 1)
            cv2.integral(mask, sum=dst, sdepth=cv2.CV_32S)
        return self._integral_buf

    def coverage(self) -> np.ndarray:
        """``(nx, ny, nz)`` uint8: how many cameras see each voxel."""
        return (self.tables >= 0).sum(axis=0, dtype=np.uint8).reshape(self.grid.shape)

    def counts(self, masks) -> tuple[np.ndarray, np.ndarray]:
        """Per voxel, cameras that see it and cameras whose silhouette contains it.

        Parameters
        ----------
        masks : (N_C, H, W) array_like of bool
            Silhouettes in camera order.

        Returns
        -------
        seen, inside : (nx, ny, nz) uint8 ndarray
        """
        buf = _mask_buffer(masks, self.cameras)
        seen = np.empty(self.grid.n_voxels, dtype=np.uint8)
        inside = np.empty_like(seen)
        _k.count_views(self.tables, buf, seen, inside)
        return seen.reshape(self.grid.shape), inside.reshape(self.grid.shape)

    def carve(self, masks, *, min_views: int | None = None) -> np.ndarray:
        """Occupancy ``V^R`` of one frame.

        Parameters
        ----------
        masks : (N_C, H, W) array_like of bool, or a sequence of (H_c, W_c) masks
            Silhouettes in camera order; each must match its camera's image size.
        min_views : int, optional
            Occupied when inside at least this many silhouettes; default: inside every silhouette
            of the cameras that see the voxel.

        Returns
        -------
        (nx, ny, nz) bool ndarray

        Warns
        -----
        EmptySilhouetteWarning
            When every mask is empty; the occupancy is then empty.
        """
        k = _check_min_views(min_views, len(self.cameras))
        buf = _mask_buffer(masks, self.cameras)
        out = np.zeros(self.grid.n_voxels, dtype=np.bool_)
        if not buf.any():
            warnings.warn("every silhouette is empty (no person in view): empty occupancy",
                          EmptySilhouetteWarning, stacklevel=2)
            return out.reshape(self.grid.shape)
        if self.use_bricks:
            nx, ny, nz = self.grid.shape
            _k.carve_bricks(self.tables, buf, self._integrals(buf), self._int_offsets,
                            self._int_widths, self._rects, self._full, nx, ny, nz, BRICK,
                            0 if k is None else k, out)
        elif k is None:
            _k.carve_all_views(self.tables, buf, out)
        else:
            _k.carve_min_views(self.tables, buf, k, out)
        return out.reshape(self.grid.shape)


    def carve_with_holes(self, masks, holes: int = 1, *, ignore=(),
                         reach: float = 0.0, abstain=None) -> np.ndarray:
        """Occupancy tolerating ``holes`` silhouettes that miss an occupied voxel.

        A voxel is occupied when at least ``holes + 2`` cameras see it and at most ``holes`` of
        them have it outside their silhouette. With four or more cameras and ``holes = 1``, a
        segmentation hole in one view (dark clothing on a dark floor) no longer cuts the body,
        while every voxel still needs three agreeing views.

        Parameters
        ----------
        masks : (N_C, H, W) array_like of bool, or a sequence of (H_c, W_c) masks
            Silhouettes in camera order.
        holes : int
            Silhouettes allowed to miss a voxel, >= 0 (0: every camera that sees it, and at
            least two of them).
        ignore : sequence of int
            Cameras left out (they neither see nor vote).
        reach : float
            A silhouette may miss a voxel only when the voxel projects within ``reach`` × its
            image diagonal of that silhouette (0: at any distance): a hole inside the person is
            tolerated, a voxel far outside one view is not.
        abstain : sequence of (H_c, W_c) bool ndarray or None, optional
            Per camera, pixels whose verdict does not count: a voxel projecting there is as if
            that camera did not see it (None: every pixel counts).

        Returns
        -------
        (nx, ny, nz) bool ndarray
        """
        seen, inside = self.counts(masks)
        seen = seen.astype(np.int16)
        for c in ignore:
            seen -= (self.tables[c] >= 0).reshape(self.grid.shape)
        if abstain is not None and any(a is not None for a in abstain):
            # a camera left out already neither sees nor votes: it cannot abstain again
            off = [np.zeros(np.shape(m), bool) if a is None or c in ignore
                   else np.asarray(a, bool)
                   for c, (m, a) in enumerate(zip(masks, abstain, strict=True))]
            seen -= self._abstaining_views(abstain, ignore, off)
            inside = inside.astype(np.int16) - self.counts(
                [np.asarray(m, bool) & a for m, a in zip(masks, off, strict=True)])[1]
        occ = (seen >= int(holes) + 2) & (inside.astype(np.int16) >= seen - int(holes))
        if reach > 0 and holes > 0 and occ.any():
            near = []
            for m, cam in zip(masks, self.cameras, strict=True):
                m = np.asarray(m, np.uint8)
                r = max(1, int(round(reach * np.hypot(*cam.size))))
                disk = (np.hypot(*np.mgrid[-r:r + 1, -r:r + 1]) <= r).astype(np.uint8)
                near.append(_dilated(m, disk, r))
            _, near_inside = self.counts(near)
            occ &= near_inside.astype(np.int16) >= seen
        return occ

    def _abstaining_views(self, abstain, ignore, off) -> np.ndarray:
        """Per voxel, how many cameras abstain on it. It depends on the abstaining pixels and
        the cameras left out only, not on the frame: a stage passes the same ``abstain`` list
        every frame, so it is counted once per list and set of cameras left out."""
        key = tuple(int(c) for c in ignore)
        cached = self._abstained
        if cached is None or cached[0] is not abstain or cached[1] != key:
            cached = self._abstained = (abstain, key, self.counts(off)[1])
        return cached[2]


def _cached_carver(cameras: list, grid: VoxelGrid) -> Carver:
    # Cameras are immutable and compared by identity, so the key holds them (and keeps them alive).
    key = (grid, *cameras)
    carver = _CACHE.get(key)
    if carver is None:
        carver = Carver(cameras, grid)
        _CACHE[key] = carver
        while len(_CACHE) > _CACHE_SIZE:
            _CACHE.popitem(last=False)
    else:
        _CACHE.move_to_end(key)
    return carver


def carve(masks, cameras, grid: VoxelGrid, *, min_views: int | None = None) -> np.ndarray:
    """Carve one frame's silhouettes into an occupancy grid.

    Parameters
    ----------
    masks : (N_C, H, W) array_like of bool
        Silhouettes, one per camera, in the order of ``cameras``.
    cameras : sequence of Camera
        The calibrated cameras.
    grid : VoxelGrid
        The voxel grid.
    min_views : int, optional
        Keep voxels inside at least this many silhouettes; default every camera that sees them.

    Returns
    -------
    (nx, ny, nz) bool ndarray
        ``V^R``.

    Raises
    ------
    InputError
        Mask count or sizes not matching the cameras, a bad ``min_views``, a grid too large.

    Notes
    -----
    The per-camera tables of the last two (cameras, grid) pairs are cached; for many frames prefer
    an explicit :class:`Carver`.
    """
    cameras = _check_cameras(cameras)
    if not isinstance(grid, VoxelGrid):
        raise InputError("grid", f"expected a VoxelGrid, got {type(grid).__name__}")
    _check_min_views(min_views, len(cameras))
    _mask_buffer(masks, cameras)  # validate before the (possibly long) table build
    return _cached_carver(cameras, grid).carve(masks, min_views=min_views)


def carve_reference(masks, cameras, grid: VoxelGrid, *, min_views: int | None = None) -> np.ndarray:
    """Plain NumPy carving, camera by camera over all voxel centres (the tests' reference; slow).

    Same parameters, rules and result as :func:`carve`, without tables or kernels, projecting
    through :meth:`Camera.project` itself.
    """
    cameras = _check_cameras(cameras)
    k = _check_min_views(min_views, len(cameras))
    items = list(masks)
    _mask_buffer(masks, cameras)
    centres = grid.centres()
    seen = np.zeros(len(centres), dtype=int)
    inside = np.zeros(len(centres), dtype=int)
    for mask, cam in zip(items, cameras, strict=True):
        mask = np.asarray(mask) != 0
        # straight through Camera.project (not the table builder's fast path)
        pix, depth = cam.project(centres, return_depth=True)
        xc = cam.world_to_camera(centres)
        r_max = fov_radius(cam)
        with np.errstate(invalid="ignore", divide="ignore"):
            r2 = (xc[:, 0] ** 2 + xc[:, 1] ** 2) / xc[:, 2] ** 2
            ok = (depth > 0) & (r2 <= r_max**2)
        u = np.rint(np.where(ok, pix[:, 0], -1.0)).astype(np.int64)
        v = np.rint(np.where(ok, pix[:, 1], -1.0)).astype(np.int64)
        ok &= (u >= 0) & (u < cam.width) & (v >= 0) & (v < cam.height)
        seen += ok
        inside[ok] += mask[v[ok], u[ok]]
    occ = (inside == seen) & (seen > 0) if k is None else inside >= k
    return occ.reshape(grid.shape)


def _dilated(mask: np.ndarray, disk: np.ndarray, r: int) -> np.ndarray:
    """``cv2.dilate(mask, disk) != 0`` computed on the mask's bounding box grown by ``r`` (the
    disk's radius): nothing farther from the silhouette can be reached, and OpenCV's dilation
    reads no pixel beyond the image, so the result is the same at a fraction of the pixels."""
    out = np.zeros(mask.shape, bool)
    x, y, w, h = cv2.boundingRect(mask)
    if w == 0:
        return out
    box = (slice(max(y - r, 0), y + h + r), slice(max(x - r, 0), x + w + r))
    out[box] = cv2.dilate(np.ascontiguousarray(mask[box]), disk) != 0
    return out
