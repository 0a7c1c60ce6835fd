"""The measurement stage, frame by frame: images → silhouettes → occupancy → surface maps.

:class:`MeasurementStage` ties the background models (:mod:`voxelmocap.silhouette`), a
:class:`~voxelmocap.carving.Carver` and the surface maps (:mod:`voxelmocap.surface`) together for one
rig and grid. It never touches files: the caller decodes the frames (e.g. with
:class:`voxelmocap.io.humaneva.Sequence`) and hands over ``{camera name: image}``.

>>> stage = MeasurementStage(rig, grid, backgrounds, SilhouetteConfig())   # doctest: +SKIP
>>> masks, occupancy = stage.process(images)                              # doctest: +SKIP
>>> m = stage.measure(images)        # masks, occupancy, surface, smoothed, timings  # doctest: +SKIP
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from .carving import Carver
from .errors import InputError
from .grid import VoxelGrid
from .silhouette import SilhouetteConfig, segment
from .surface import smooth_surface, surface_voxels

__all__ = ["FrameMeasurement", "MeasurementStage"]


@dataclass
class FrameMeasurement:
    """Everything the measurement stage computes for one frame.

    Attributes
    ----------
    masks : (N_C, H, W) bool ndarray
        Silhouettes in rig order.
    occupancy : (nx, ny, nz) bool ndarray
        ``V^R``.
    surface : (nx, ny, nz) bool ndarray
        ``V^S``.
    smoothed : (nx, ny, nz) float32 ndarray
        ``Ṽ^S`` in [0, 1].
    timings : dict of str to float
        Seconds spent in ``"subtract"``, ``"carve"``, ``"surface"`` and ``"smooth"``.
    """

    masks: np.ndarray
    occupancy: np.ndarray
    surface: np.ndarray
    smoothed: np.ndarray
    timings: dict = field(default_factory=dict)


class MeasurementStage:
    """Silhouettes, carving and surface maps of one rig and grid, frame after frame.

    Parameters
    ----------
    rig : sequence of Camera
        The cameras (a :class:`~voxelmocap.camera.Rig`); their names key the images.
    grid : VoxelGrid
        The voxel grid.
    backgrounds : mapping of str to background model
        One :class:`~voxelmocap.silhouette.GaussianBackground` or
        :class:`~voxelmocap.silhouette.Mog2Background` per camera name
        (:func:`~voxelmocap.silhouette.build_backgrounds` makes them).
    config : SilhouetteConfig, optional
        Thresholds (per camera), shadow suppression and clean-up.
    min_views : int, optional
        Carving rule (:meth:`voxelmocap.carving.Carver.carve`); default every camera that sees a voxel.
    sigma : float
        Smoothing of the surface voxels (voxels).
    """

    def __init__(self, rig, grid: VoxelGrid, backgrounds: Mapping, config: SilhouetteConfig | None
                 = None, *, min_views: int | None = None, sigma: float = 1.0):
        self.cameras = list(rig)
        self.names = [c.name for c in self.cameras]
        missing = [n for n in self.names if n not in backgrounds]
        if missing:
            raise InputError("backgrounds", f"no background model for camera(s) {', '.join(missing)}")
        if not sigma > 0:
            raise InputError("sigma", f"must be positive, got {sigma!r}")
        self.grid = grid
        self.backgrounds = dict(backgrounds)
        self.config = config or SilhouetteConfig()
        self.min_views = min_views
        self.sigma = float(sigma)
        self.carver = Carver(self.cameras, grid)

    def masks(self, images: Mapping) -> np.ndarray:
        """``(N_C, H, W)`` bool silhouettes of one frame (``images``: camera name → image)."""
        missing = [n for n in self.names if n not in images]
        if missing:
            raise InputError("images", f"no image for camera(s) {', '.join(missing)}")
        out = []
        for cam in self.cameras:
            img = images[cam.name]
            w, h = cam.size
            if np.shape(img)[:2] != (h, w):
                raise InputError("images", f"image of {cam.name} is {np.shape(img)[1]}x"
                                           f"{np.shape(img)[0]}, its calibration says {w}x{h}")
            out.append(segment(img, self.backgrounds[cam.name], self.config, camera=cam.name))
        if len({m.shape for m in out}) == 1:
            return np.stack(out)
        return out  # cameras of different sizes: a list of (H_c, W_c) masks

    def process(self, images: Mapping) -> tuple[np.ndarray, np.ndarray]:
        """Silhouettes and occupancy of one frame.

        Parameters
        ----------
        images : mapping of str to (H, W) or (H, W, 3) uint8 ndarray
            One decoded image per camera name.

        Returns
        -------
        masks : (N_C, H, W) bool ndarray
        occupancy : (nx, ny, nz) bool ndarray
        """
        masks = self.masks(images)
        return masks, self.carver.carve(masks, min_views=self.min_views)

    def measure(self, images: Mapping) -> FrameMeasurement:
        """Silhouettes, occupancy, surface and smoothed surface of one frame, with timings."""
        t0 = time.perf_counter()
        masks = self.masks(images)
        t1 = time.perf_counter()
        occ = self.carver.carve(masks, min_views=self.min_views)
        t2 = time.perf_counter()
        surf = surface_voxels(occ)
        t3 = time.perf_counter()
        smooth = smooth_surface(surf, self.sigma)
        t4 = time.perf_counter()
        timings = {"subtract": t1 - t0, "carve": t2 - t1, "surface": t3 - t2, "smooth": t4 - t3}
        return FrameMeasurement(masks, occ, surf, smooth, timings)
