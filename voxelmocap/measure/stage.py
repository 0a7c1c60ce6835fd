"""The measurement stage, frame by frame: images → silhouettes → occupancy → one observation.

:class:`MeasurementStage` ties the background models (:mod:`voxelmocap.measure.silhouette`), a
:class:`~voxelmocap.measure.carving.Carver` and the surface maps together for one rig and grid, and returns
one :class:`~voxelmocap.measure.observation.VoxelObservation` per frame: the silhouettes, ``V^R``, ``V^S``,
``Ṽ^S`` and the likelihood's prefix sums, computed once and shared by ``dump`` and ``track``. It never
touches files: the caller decodes the frames (e.g. with :class:`voxelmocap.io.humaneva.Sequence`)
and hands over ``{camera name: image}``; :class:`voxelmocap.run.measurement.MeasurementRunner`
builds a stage from a sequence on disk.

Cameras that carry no picture. A camera whose frame is (nearly) all black, or whose silhouette
covers (nearly) the whole image (a black frame against a lit background, lights switched off, a
moved camera), says nothing about where the person is. Left in, it would stop constraining the
carving (every voxel it sees is "inside" its silhouette) or, under ``min_views``, vote for every
voxel. The stage leaves such a camera out of that frame's carving and names it in
:attr:`VoxelObservation.excluded <voxelmocap.measure.observation.VoxelObservation>`; the runner says so.

>>> stage = MeasurementStage(rig, grid, backgrounds, SilhouetteConfig())   # doctest: +SKIP
>>> obs = stage.measure(images)   # masks, occupancy, surface, smoothed, timings   # doctest: +SKIP
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from functools import cached_property

import numpy as np

from ..errors import InputError
from ..grid import VoxelGrid
from .carving import Carver
from .observation import VoxelObservation
from .silhouette import SilhouetteConfig, segment
from .threads import each

__all__ = ["BLACK_LEVEL", "BLACK_SHARE", "FULL_SHARE", "MeasurementStage", "VoxelObservation",
           "unusable_reason"]

#: A pixel value at or below this (of 255) is black: sensor noise of a capped lens stays under it.
BLACK_LEVEL = 16
#: A frame is black when at most this share of its pixel values is above :data:`BLACK_LEVEL`.
BLACK_SHARE = 0.005
#: A silhouette covering at least this share of its image says nothing about the person: a
#: capture rig sees the whole body, so a person never fills 90 % of a camera's view.
FULL_SHARE = 0.9


def unusable_reason(image: np.ndarray, mask: np.ndarray) -> str | None:
    """Why one camera's frame cannot constrain the carving, or None when it can.

    Parameters
    ----------
    image : (H, W) or (H, W, 3) uint8 ndarray
        The decoded frame.
    mask : (H, W) bool ndarray
        Its silhouette.

    Returns
    -------
    str or None
        ``"the image is black"``, ``"the silhouette covers <p> % of the image"`` or None.
    """
    img = np.asarray(image)
    if np.count_nonzero(img > BLACK_LEVEL) <= BLACK_SHARE * img.size:
        return "the image is black"
    share = float(np.count_nonzero(mask)) / max(mask.size, 1)
    if share >= FULL_SHARE:
        return f"the silhouette covers {100 * share:.0f} % of the image"
    return None


class MeasurementStage:
    """Silhouettes, carving and surface maps of one rig and grid, frame after frame.

    Parameters
    ----------
    rig : sequence of Camera
        The cameras (a :class:`~voxelmocap.camera.Rig`); their names key the images.
    grid : VoxelGrid
        The voxel grid.
    backgrounds : mapping of str to background model, or None
        One :class:`~voxelmocap.measure.silhouette.GaussianBackground` or
        :class:`~voxelmocap.measure.silhouette.Mog2Background` per camera name
        (:func:`~voxelmocap.measure.silhouette.build_backgrounds` makes them); None when every frame's
        silhouettes are given to :meth:`measure` (person masks from another tool).
    config : SilhouetteConfig, optional
        Thresholds (per camera), shadow suppression and clean-up.
    min_views : int, optional
        Carving rule (:meth:`voxelmocap.measure.carving.Carver.carve`); default every camera
        that sees a voxel.
    sigma : float
        Smoothing of the surface voxels (voxels).
    holes : int
        Silhouettes that may miss an occupied voxel (:meth:`Carver.carve_with_holes`).
    person_only : bool
        Keep only the largest 3D component of every frame.
    hole_reach : float
        With ``holes``: a silhouette may miss a voxel only within this share of its image
        diagonal (0: anywhere).

    Attributes
    ----------
    grid : VoxelGrid
    names : list of str
        Camera names in rig order (the order of the masks).
    carver : Carver
    """

    def __init__(self, rig, grid: VoxelGrid, backgrounds: Mapping, config: SilhouetteConfig | None
                 = None, *, min_views: int | None = None, sigma: float = 1.0, holes: int = 0,
                 person_only: bool = False, hole_reach: float = 0.0):
        self.cameras = list(rig)
        self.names = [c.name for c in self.cameras]
        missing = [] if backgrounds is None else [n for n in self.names if n not in backgrounds]
        if missing:
            raise InputError("backgrounds", f"no background model for camera(s) {', '.join(missing)}")
        if not sigma > 0:
            raise InputError("sigma", f"must be positive, got {sigma!r}")
        n_cam = len(self.cameras)
        if min_views is not None and (isinstance(min_views, bool) or min_views != int(min_views)
                                      or not 1 <= min_views <= n_cam):
            raise InputError("min_views", f"must be an integer between 1 and {n_cam} (the number "
                                          f"of cameras), got {min_views!r}")
        self.grid = grid
        self.backgrounds = None if backgrounds is None else dict(backgrounds)
        self.config = config or SilhouetteConfig()
        self.min_views = None if min_views is None else int(min_views)
        self.sigma = float(sigma)
        if isinstance(holes, bool) or holes != int(holes) or not 0 <= holes < max(n_cam - 1, 1):
            raise InputError("holes", f"must be an integer between 0 and {max(n_cam - 2, 0)}, "
                                      f"got {holes!r}")
        self.holes = int(holes)
        if not 0 <= hole_reach <= 1:
            raise InputError("hole_reach", f"must be between 0 and 1, got {hole_reach!r}")
        self.hole_reach = float(hole_reach)
        self.person_only = bool(person_only)
        self.carver = Carver(self.cameras, grid)

    def masks(self, images: Mapping) -> np.ndarray:
        """Silhouettes of one frame (adaptive background models learn from it).

        With learnt plates (:class:`~voxelmocap.measure.plate.PlateBackground`) the cameras are
        segmented side by side (:mod:`.threads`); the masks are the same either way.

        Parameters
        ----------
        images : mapping of str to (H, W) or (H, W, 3) uint8 ndarray
            One decoded image per camera name.

        Returns
        -------
        (N_C, H, W) bool ndarray
            In rig order; a list of ``(H_c, W_c)`` masks when the cameras differ in size.
        """
        if self.backgrounds is None:
            raise InputError("backgrounds", "this stage has no background model: give each "
                                            "frame's silhouettes to measure()")
        missing = [n for n in self.names if n not in images]
        if missing:
            raise InputError("images", f"no image for camera(s) {', '.join(missing)}")
        for cam in self.cameras:
            img = images[cam.name]
            w, h = cam.size
            if np.shape(img)[:2] != (h, w):
                raise InputError("images", f"image of {cam.name} is {np.shape(img)[1]}x"
                                           f"{np.shape(img)[0]}, its calibration says {w}x{h}")

        def one(cam):
            return segment(images[cam.name], self.backgrounds[cam.name], self.config,
                           camera=cam.name)

        # Learnt plates (GrabCut, one core each) segment their cameras side by side. The
        # Gaussian model's numba kernel already uses every core, and numba's fallback threading
        # layer refuses launches from two threads at once: such cameras go one after another.
        if all(getattr(self.backgrounds[c.name], "concurrent", False) for c in self.cameras):
            out = each(one, self.cameras)
        else:
            out = [one(cam) for cam in self.cameras]
        if len({m.shape for m in out}) == 1:
            return np.stack(out)
        return out  # cameras of different sizes: a list of (H_c, W_c) masks

    def carve(self, masks, excluded=()) -> tuple[np.ndarray, bool]:
        """Occupancy of one frame's silhouettes, leaving out the cameras named in ``excluded``.

        Parameters
        ----------
        masks : (N_C, H, W) bool ndarray or list of (H_c, W_c) bool ndarray
            Silhouettes in rig order.
        excluded : collection of str
            Cameras that must not constrain the carving.

        Returns
        -------
        occupancy : (nx, ny, nz) bool ndarray
        empty : bool
            No used camera has a foreground pixel (no person in view); the occupancy is empty.
        """
        use = [n not in excluded for n in self.names]
        if not any(m.any() for m, u in zip(masks, use, strict=True) if u):
            return np.zeros(self.grid.shape, dtype=bool), True
        if self.holes and self.min_views is None:
            occ = self.carver.carve_with_holes(
                [m if u else np.zeros(m.shape, bool) for m, u in zip(masks, use, strict=True)],
                self.holes, ignore=[i for i, u in enumerate(use) if not u],
                reach=self.hole_reach, abstain=self.abstain)
        else:
            occ = self._carve_rule(masks, use, excluded)
        if self.person_only:
            from .background import person_component

            occ = person_component(occ)
        return occ, False

    def _carve_rule(self, masks, use, excluded) -> np.ndarray:
        if not excluded:
            return self.carver.carve(masks, min_views=self.min_views)
        # An excluded camera votes for nothing under min_views (an empty mask) and vetoes nothing
        # under the every-view rule (a full mask); voxels that only it sees are then dropped.
        fill = self.min_views is None
        masks = [m if u else np.full(m.shape, fill) for m, u in zip(masks, use, strict=True)]
        occ = self.carver.carve(masks, min_views=self.min_views)
        if fill:
            seen = (self.carver.tables[np.flatnonzero(use)] >= 0).any(axis=0)
            occ &= seen.reshape(self.grid.shape)
        return occ

    def measure(self, images: Mapping, masks=None) -> VoxelObservation:
        """The observation of one frame: silhouettes, occupancy, surface maps and timings.

        Parameters
        ----------
        images : mapping of str to (H, W) or (H, W, 3) uint8 ndarray
            One decoded image per camera name.
        masks : sequence of (H_c, W_c) bool ndarray, optional
            The frame's silhouettes in rig order, given (person masks from another tool):
            no background subtraction.

        Returns
        -------
        VoxelObservation
            With ``masks``, ``timings`` (``"subtract"``, ``"carve"``, ``"surface"``, ``"smooth"``
            seconds), ``empty`` and ``excluded`` (camera name → reason) set.
        """
        t0 = time.perf_counter()
        if masks is None:
            masks = self.masks(images)
        else:
            masks = self._given(masks)
        t1 = time.perf_counter()
        excluded = {}
        for name, mask in zip(self.names, masks, strict=True):
            reason = unusable_reason(images[name], mask)
            if reason is not None:
                excluded[name] = reason
        occ, empty = self.carve(masks, excluded)
        t2 = time.perf_counter()
        return VoxelObservation(occ, self.grid, sigma=self.sigma, masks=masks,
                                timings={"subtract": t1 - t0, "carve": t2 - t1}, empty=empty,
                                excluded=excluded, images=[images[n] for n in self.names],
                                cameras=self.cameras, known=self.known)

    def _given(self, masks):
        """Given silhouettes checked against the rig (stacked when the cameras agree in size)."""
        masks = [np.asarray(m, bool) for m in masks]
        if len(masks) != len(self.cameras):
            raise InputError("masks", f"{len(masks)} silhouettes for {len(self.cameras)} cameras")
        for cam, m in zip(self.cameras, masks, strict=True):
            w, h = cam.size
            if m.shape != (h, w):
                raise InputError("masks", f"silhouette of {cam.name} is {m.shape[1]}x"
                                          f"{m.shape[0]}, its calibration says {w}x{h}")
        return np.stack(masks) if len({m.shape for m in masks}) == 1 else masks

    @cached_property
    def abstain(self) -> list | None:
        """Per camera, the pixels whose silhouette verdict the hole-tolerant carving does not
        count: a grey camera's never-seen pixels (None for the others; None overall when no
        camera has such pixels). There GrabCut decides from one channel's intensity, which a
        grey shirt shares with a grey wall: a camera that never saw the background there and
        has no colour to tell them apart abstains rather than cut the body away."""
        known = self.known
        if known is None:
            return None
        out = [None if k is None or np.shape(self.backgrounds[n].plate)[-1] != 1 else ~k
               for n, k in zip(self.names, known, strict=True)]
        return None if all(a is None for a in out) else out

    @cached_property
    def known(self) -> list | None:
        """Per camera, the pixels whose background a learnt plate has seen (None where all are,
        or the background is not a learnt plate); None when no camera has never-seen pixels.
        Computed once: the backgrounds are fixed when the stage is made."""
        if self.backgrounds is None:
            return None
        out = []
        for n in self.names:
            k = getattr(self.backgrounds[n], "known", None)
            out.append(None if k is None or k.all() else k)
        return None if all(k is None for k in out) else out
