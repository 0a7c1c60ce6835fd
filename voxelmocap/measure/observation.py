"""One measured frame: :class:`VoxelObservation`, what the measurement stage hands to the tracker.

A frame's observation holds the voxel reconstruction ``V^R`` on its grid and everything derived
from it once: the surface voxels ``V^S``, the smoothed surface ``Ṽ^S`` (:mod:`voxelmocap.measure.surface`),
the quantised ``Ṽ^S`` and the prefix sums along z that the likelihood kernels read
(:mod:`voxelmocap.score.likelihood`), and optionally the silhouettes it was carved from, the
measurement's timings and what the stage noticed about the frame (empty silhouettes, cameras left
out). :class:`voxelmocap.measure.stage.MeasurementStage` builds one per frame; ``voxelmocap dump``
writes its volumes and ``voxelmocap track`` scores poses against it, so both see the same numbers.

``Ṽ^S`` is quantised to integers ``round(Ṽ^S · QMAX)`` so that every likelihood sum is an exact
integer and the fast and reference implementations agree bit for bit. The quantised values and the
prefix sums are computed on first use (a dump never needs them) and kept.

>>> from voxelmocap.grid import VoxelGrid
>>> grid = VoxelGrid((0.0, 0.0, 0.0), 10.0, (5, 5, 5))
>>> occ = np.zeros(grid.shape, bool); occ[1:4, 1:4, 1:4] = True
>>> obs = VoxelObservation(occ, grid, sigma=1.0)
>>> i0, j0 = obs.prefix_lattice[3:]       # the prefix table's first column (all 5 × 5 here)
>>> int(obs.surface.sum()), int(obs.prefix[2 - i0, 2 - j0, -1, 1]), obs.prefix.shape
(26, 3, (5, 5, 6, 3))
"""

from __future__ import annotations

import time
from functools import cached_property

import numpy as np

from ..errors import InputError
from ..grid import VoxelGrid
from .surface import smooth_surface_box, smoothing_box, surface_voxels

__all__ = ["QMAX", "VoxelObservation", "no_voxels"]

#: Quantised value of Ṽ^S = 1.
QMAX = 65535


class VoxelObservation:
    """The data of one frame: ``V^R``, ``V^S``, ``Ṽ^S``, the analysed scene and the silhouettes.

    Parameters
    ----------
    occupancy : (nx, ny, nz) array_like of bool
        Voxel reconstruction ``V^R`` on ``grid`` (non-bool values: non-zero is occupied).
    grid : VoxelGrid
        The grid of ``occupancy``.
    sigma : float
        Standard deviation (voxels) of the Gaussian that smooths the surface into ``Ṽ^S``.
    scene : (nx, ny, nz) array_like of bool, optional
        The analysed scene; default the whole grid. Occupancy outside the scene is ignored.
    masks : (N_C, H, W) bool ndarray or list of (H_c, W_c) bool ndarray, optional
        The silhouettes ``occupancy`` was carved from, in rig order.
    timings : dict of str to float, optional
        Seconds spent so far on this frame (the stage's ``"subtract"`` and ``"carve"``);
        ``"surface"`` and ``"smooth"`` are added here.
    empty : bool
        Every silhouette was empty (no person in view).
    excluded : dict of str to str, optional
        Cameras left out of the carving of this frame, with the reason (e.g. ``"all black"``).
    images : list of (H_c, W_c) or (H_c, W_c, 3) uint8 ndarray, optional
        The camera images of the frame, in rig order (the image cues of ``voxelmocap.score.cues``).
    cameras : list of Camera, optional
        The cameras of ``images`` (and of ``masks``), in rig order.

    Attributes
    ----------
    grid : VoxelGrid
    sigma : float
    occupancy, surface, scene : (nx, ny, nz) bool ndarray
        ``V^R`` (restricted to the scene), ``V^S`` and the scene mask.
    smoothed : (nx, ny, nz) float32 ndarray
        ``Ṽ^S`` in [0, 1], 0 outside the scene.
    smoothed_q : (nx, ny, nz) int32 ndarray
        ``round(Ṽ^S · QMAX)``, the values both likelihood implementations use (computed on first
        use).
    prefix : (ni, nj, nz + 1, 3) int32 ndarray
        Prefix sums along z of ``scene``, ``occupancy`` and ``smoothed_q`` over the columns
        ``[i0, i0 + ni) × [j0, j0 + nj)`` that hold an occupied voxel, a non-zero ``Ṽ^S`` or a
        voxel outside the scene (computed on first use); every other column is empty and wholly
        in the scene.
    prefix_lattice : (5,) int64 ndarray
        ``nx, ny, nz, i0, j0``: the grid's shape and where ``prefix`` starts.
    masks, timings, empty, excluded, images, cameras
        As given (``timings`` with the surface timings added; ``excluded`` a dict).
    known : list of ((H_c, W_c) bool ndarray or None), optional
        Per camera (rig order), the pixels whose background the learnt plate has seen (None: all
        of them, or not a learnt plate): the rest of a silhouette there is GrabCut's guess.
    """

    def __init__(self, occupancy, grid: VoxelGrid, *, sigma: float = 1.0, scene=None,
                 masks=None, timings: dict | None = None, empty: bool = False,
                 excluded: dict | None = None, images=None, cameras=None, known=None):
        if not isinstance(grid, VoxelGrid):
            raise InputError("grid", f"expected a VoxelGrid, got {type(grid).__name__}")
        occ = np.asarray(occupancy)
        if occ.shape != grid.shape:
            raise InputError("occupancy", f"shape {occ.shape} does not match the grid {grid.shape}")
        if occ.dtype != bool:
            if occ.dtype.kind == "f" and not np.all(np.isfinite(occ)):
                raise InputError("occupancy", "contains NaN or infinite values")
            occ = occ != 0
        try:
            sigma = float(sigma)
        except (TypeError, ValueError):
            raise InputError("sigma", f"must be a number, got {sigma!r}") from None
        if not (np.isfinite(sigma) and sigma > 0):
            raise InputError("sigma", f"must be a positive number of voxels, got {sigma!r}")
        if scene is None:
            scene_mask = np.ones(grid.shape, dtype=bool)
        else:
            scene_mask = np.asarray(scene)
            if scene_mask.shape != grid.shape:
                raise InputError("scene", f"shape {scene_mask.shape} does not match the grid "
                                          f"{grid.shape}")
            scene_mask = scene_mask.astype(bool)
        if grid.shape[2] * QMAX >= 2**31:
            raise InputError("grid", f"too many layers ({grid.shape[2]}) for int32 prefix sums")
        self.grid = grid
        self.sigma = sigma
        self.scene = scene_mask
        self.occupancy = occ & scene_mask  # a copy too: the caller's array may change later
        self.masks = masks
        self.timings = dict(timings or {})
        self.empty = bool(empty)
        self.excluded = dict(excluded or {})
        self.images = None if images is None else list(images)
        self.cameras = None if cameras is None else list(cameras)
        self.known = None if known is None else list(known)
        t0 = time.perf_counter()
        self.surface = surface_voxels(self.occupancy)
        t1 = time.perf_counter()
        # Ṽ^S over the box where it may be non-zero (which holds the occupancy, as the surface
        # does); the whole-grid array is made on first use (dumps, the reference): the tracker
        # reads the box alone
        self._smoothed_box, self._smoothed_values = smooth_surface_box(self.surface, sigma)
        self._scene_box = None if scene is None else smoothing_box(~scene_mask, 0.0)
        if scene is not None and self._smoothed_box is not None:
            self._smoothed_values[~scene_mask[self._smoothed_box]] = 0.0
        t2 = time.perf_counter()
        self.timings["surface"] = t1 - t0
        self.timings["smooth"] = t2 - t1

    @cached_property
    def n_occupied(self) -> int:
        """Number of occupied voxels of ``V^R`` (at least 1, a divisor)."""
        return max(int(np.count_nonzero(self.occupancy)), 1)

    @cached_property
    def smoothed(self) -> np.ndarray:
        """``(nx, ny, nz)`` float32 ``Ṽ^S`` in [0, 1], 0 outside the scene."""
        out = np.zeros(self.grid.shape, dtype=np.float32)
        if self._smoothed_box is not None:
            out[self._smoothed_box] = self._smoothed_values
        return out

    @cached_property
    def smoothed_q(self) -> np.ndarray:
        """``(nx, ny, nz)`` int32 ``round(Ṽ^S · QMAX)``."""
        return np.rint(self.smoothed.astype(np.float64) * QMAX).astype(np.int32)

    @cached_property
    def prefix_lattice(self) -> np.ndarray:
        """``(nx, ny, nz, i0, j0)`` int64: the grid's shape and the first column of ``prefix``."""
        boxes = [b for b in (self._smoothed_box, self._scene_box) if b is not None]
        if boxes:
            i0 = min(b[0].start for b in boxes)
            j0 = min(b[1].start for b in boxes)
        else:
            i0 = j0 = 0
        return np.array([*self.grid.shape, i0, j0], dtype=np.int64)

    @cached_property
    def prefix(self) -> np.ndarray:
        """``(ni, nj, nz + 1, 3)`` int32 prefix sums along z of scene, occupancy, ``smoothed_q``
        over the columns that need them (see the class's attributes)."""
        from ._observation_kernels import prefix_sums

        nz = self.grid.shape[2]
        boxes = [b for b in (self._smoothed_box, self._scene_box) if b is not None]
        i0, j0 = (int(v) for v in self.prefix_lattice[3:])
        i1 = max((b[0].stop for b in boxes), default=i0)
        j1 = max((b[1].stop for b in boxes), default=j0)
        cols = (slice(i0, i1), slice(j0, j1))
        # A person fills a small part of the grid: the table (and its page faults: 45 MB a
        # frame over the whole grid at 20 mm) covers only the columns the kernels can find
        # anything in. One parallel pass instead of NumPy's four serial ones.
        prefix = np.empty((i1 - i0, j1 - j0, nz + 1, 3), dtype=np.int32)
        prefix_sums(self.scene[cols], self.occupancy[cols], self._smoothed_columns(cols), QMAX,
                    prefix)
        return prefix

    def _smoothed_columns(self, cols) -> np.ndarray:
        """``Ṽ^S`` over the columns ``cols`` (two slices holding the smoothing box), from the
        whole-grid array when it was made (and perhaps written to), else from the box."""
        if "smoothed" in self.__dict__:
            return self.smoothed[cols]
        nz = self.grid.shape[2]
        out = np.zeros((cols[0].stop - cols[0].start, cols[1].stop - cols[1].start, nz),
                       dtype=np.float32)
        if self._smoothed_box is not None:
            bx, by, bz = self._smoothed_box
            out[bx.start - cols[0].start:bx.stop - cols[0].start,
                by.start - cols[1].start:by.stop - cols[1].start, bz] = self._smoothed_values
        return out

    def __repr__(self) -> str:
        return (f"VoxelObservation(grid shape {self.grid.shape}, {self.grid.voxel_size:g} mm, "
                f"{int(self.occupancy.sum())} occupied voxels)")


def no_voxels(where, what: str) -> InputError:
    """The one error of a frame without an occupied voxel where a step needed some.

    Parameters
    ----------
    where : str
        The frame (e.g. ``"frame 12"``).
    what : str
        What could not be done, e.g. ``"initialise from the voxels"``.
    """
    return InputError(where, f"no occupied voxel: cannot {what} (is the person in view? is the "
                             "background model right? without background videos it is learnt "
                             "from the sequence, see the log above)")
