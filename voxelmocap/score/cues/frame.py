"""One frame's images prepared once for every cue: grey levels, colour bins, Canny distance maps.

:class:`CueFrame` wraps a :class:`~voxelmocap.measure.observation.VoxelObservation` that carries its
camera images (``observation.images``, ``observation.cameras``, set by the measurement stage) and
computes, on first use and once per frame, what the cues read:

* ``grey(c)`` — float32 grey levels (OpenCV's BGR → grey weights for colour cameras);
* ``colour(c)`` — float32 ``(H, W, C)`` channels (C = 3, or 1 for a grey camera);
* ``bins(c, n)`` — int32 histogram bin of every pixel, ``n`` levels per channel (``n³`` bins for
  colour, ``n²`` grey levels for a grey camera so that both have comparable resolution);
* ``distance(c)`` — float32 distance (pixels) to the nearest Canny edge pixel
  (``cv2.Canny`` then ``cv2.distanceTransform`` of its complement, L2, exact mask);
* ``extremities`` — :func:`voxelmocap.measure.detect.find_extremities` of the voxels;
* ``silhouette(c, size)`` — the frame's silhouette of camera ``c`` reduced to ``size`` pixels
  along the longer side (area average ≥ ½).

Cameras the measurement stage left out of the frame (``observation.excluded``: a black frame, a
silhouette covering the image) are not used by the image cues.
"""

from __future__ import annotations

from functools import cached_property

import numpy as np

from ...errors import InputError

__all__ = ["CueFrame", "image_bins"]


def image_bins(image: np.ndarray, n: int) -> tuple[np.ndarray, int]:
    """Histogram bin of every pixel: ``(bins (H, W) int32, number of bins)``.

    Colour ``(H, W, 3)``: ``n`` levels per channel, ``n³`` bins; grey ``(H, W)``: ``n²`` levels.
    """
    img = np.asarray(image)
    if img.ndim == 3:
        q = (img.astype(np.int32) * n) >> 8
        return np.ascontiguousarray((q[..., 0] * n + q[..., 1]) * n + q[..., 2], np.int32), n ** 3
    m = n * n
    return np.ascontiguousarray((img.astype(np.int32) * m) >> 8, np.int32), m


def _is_colour(image: np.ndarray) -> bool:
    """A 3-channel image whose channels differ (a grey camera may be stored as BGR)."""
    if image.ndim != 3:
        return False
    step = max(1, image.shape[0] // 64)
    sub = image[::step, ::step].astype(np.int16)
    return bool(np.abs(sub[..., 0] - sub[..., 1]).max() > 2 or
                np.abs(sub[..., 1] - sub[..., 2]).max() > 2)


class CueFrame:
    """The images of one observation, prepared lazily once for all cues.

    Parameters
    ----------
    observation : VoxelObservation
        With ``images`` (one ``(H, W)`` or ``(H, W, 3)`` uint8 array per camera, rig order) and
        ``cameras``.
    canny : (float, float)
        Canny hysteresis thresholds (grey levels) of the distance map.

    Attributes
    ----------
    observation
    cameras : list of Camera
        The cameras used by the image cues (those not excluded from the frame).
    images : list of ndarray
        Their images.
    """

    def __init__(self, observation, *, canny=(50.0, 150.0)):
        images = getattr(observation, "images", None)
        cameras = getattr(observation, "cameras", None)
        if images is None or cameras is None:
            raise InputError("observation", "the image cues need the camera images of the frame "
                                            "(the observation carries none)")
        excluded = getattr(observation, "excluded", {}) or {}
        keep = [i for i, c in enumerate(cameras) if c.name not in excluded]
        self.observation = observation
        self.cameras = [cameras[i] for i in keep]
        self.images = [np.asarray(images[i]) for i in keep]
        for cam, img in zip(self.cameras, self.images, strict=True):
            w, h = cam.size
            if img.shape[:2] != (h, w):
                raise InputError("images", f"image of {cam.name} is {img.shape[1]}x{img.shape[0]},"
                                           f" its calibration says {w}x{h}")
        self.canny = (float(canny[0]), float(canny[1]))
        self._grey: dict[int, np.ndarray] = {}
        self._colour: dict[int, np.ndarray] = {}
        self._bins: dict[tuple[int, int], tuple[np.ndarray, int]] = {}
        self._distance: dict[int, np.ndarray] = {}
        self._silhouette: dict[tuple[int, int], tuple[np.ndarray, np.ndarray]] = {}
        self._prefix: dict[tuple[int, int], np.ndarray] = {}
        masks = getattr(observation, "masks", None)
        self.masks = None if masks is None else [np.asarray(masks[i]) for i in keep]
        known = getattr(observation, "known", None)
        self.known = None if known is None else [known[i] for i in keep]
        self._known: dict[tuple[int, int], np.ndarray | None] = {}

    def __len__(self) -> int:
        return len(self.cameras)

    def is_colour(self, c: int) -> bool:
        """Camera ``c`` gives colour (three channels that differ)."""
        return _is_colour(self.images[c])

    def grey(self, c: int) -> np.ndarray:
        """``(H, W)`` float32 grey levels of camera ``c``."""
        if c not in self._grey:
            import cv2

            img = self.images[c]
            g = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY) if img.ndim == 3 else img
            self._grey[c] = np.ascontiguousarray(g, dtype=np.float32)
        return self._grey[c]

    def colour(self, c: int) -> np.ndarray:
        """``(H, W, C)`` float32 channels of camera ``c`` (C = 1 for a grey camera)."""
        if c not in self._colour:
            img = self.images[c]
            if img.ndim == 3 and not self.is_colour(c):
                img = img[..., 0]
            self._colour[c] = np.ascontiguousarray(
                img.reshape(img.shape[0], img.shape[1], -1), dtype=np.float32)
        return self._colour[c]

    def bins(self, c: int, n: int) -> tuple[np.ndarray, int]:
        """``(bins (H, W) int32, number of bins)`` of camera ``c`` at ``n`` levels per channel."""
        key = (c, int(n))
        if key not in self._bins:
            img = self.images[c]
            if img.ndim == 3 and not self.is_colour(c):
                img = img[..., 0]
            self._bins[key] = image_bins(img, int(n))
        return self._bins[key]

    def distance(self, c: int) -> np.ndarray:
        """``(H, W)`` float32 distance (pixels) to the nearest Canny edge of camera ``c``."""
        if c not in self._distance:
            import cv2

            grey = self.grey(c).astype(np.uint8)
            edges = cv2.Canny(grey, self.canny[0], self.canny[1])
            if not edges.any():  # no edge at all: every pixel is as far as the image is wide
                dt = np.full(grey.shape, float(max(grey.shape)), np.float32)
            else:
                dt = cv2.distanceTransform(np.where(edges > 0, 0, 255).astype(np.uint8),
                                           cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
            self._distance[c] = np.ascontiguousarray(dt, dtype=np.float32)
        return self._distance[c]

    def silhouette(self, c: int, size: int) -> tuple[np.ndarray, np.ndarray]:
        """``(mask (h, w) bool, scale (2,))``: camera ``c``'s silhouette with ``size`` pixels along
        the longer side (never enlarged); a pixel ``(u, v)`` of the image is at
        ``(u + ½, v + ½) · scale − ½`` in the mask."""
        key = (c, int(size))
        if key not in self._silhouette:
            import cv2

            if self.masks is None:
                raise InputError("observation", "the silhouette cue needs the frame's silhouettes "
                                                "(the observation carries none)")
            full = self.masks[c]
            h, w = full.shape
            scale = min(1.0, float(size) / max(h, w))
            small = (max(1, round(w * scale)), max(1, round(h * scale)))
            area = cv2.resize(full.astype(np.float32), small, interpolation=cv2.INTER_AREA)
            self._silhouette[key] = (np.ascontiguousarray(area >= 0.5),
                                     np.array([small[0] / w, small[1] / h]))
        return self._silhouette[key]

    def silhouette_prefix(self, c: int, size: int) -> np.ndarray:
        """``(h, w + 1)`` int64 row prefix sums of :meth:`silhouette`'s mask
        (:func:`~voxelmocap.measure._silhouette_kernels.row_prefix`): once a frame, not once
        per scored batch of poses."""
        key = (c, int(size))
        if key not in self._prefix:
            from ...measure._silhouette_kernels import row_prefix

            self._prefix[key] = row_prefix(self.silhouette(c, size)[0])
        return self._prefix[key]

    def silhouette_known(self, c: int, size: int) -> np.ndarray | None:
        """``(h, w) bool``: the pixels of :meth:`silhouette`'s mask whose background the learnt
        plate has seen (area average ≥ ½), or None when all of camera ``c``'s are."""
        key = (c, int(size))
        if key not in self._known:
            known = None if self.known is None else self.known[c]
            if known is not None:
                import cv2

                mask, _ = self.silhouette(c, size)
                known = np.ascontiguousarray(cv2.resize(
                    np.asarray(known, np.float32), mask.shape[::-1],
                    interpolation=cv2.INTER_AREA) >= 0.5)
            self._known[key] = known
        return self._known[key]

    @cached_property
    def extremities(self) -> np.ndarray:
        """``(K, 3)`` voxel extremities (mm) of the frame (head, hands, feet tips; K may be 0)."""
        from ...measure.detect import find_extremities

        obs = self.observation
        ex = find_extremities(obs.occupancy, obs.grid)
        return np.empty((0, 3)) if ex is None else np.asarray(ex.points, dtype=float)
