"""A background plate with per-pixel noise, and a frame segmented against it.

:class:`PlateBackground` holds a plate (H, W, C), each pixel's noise σ and where the plate was
ever seen; a pixel of a frame is foreground when ``Σ_c (I_c − g·P_c)² / σ²`` exceeds the χ²
quantile with ``C`` degrees of freedom at ``false_alarm`` (``g`` is the frame's exposure gain
against the plate), cast shadows (darker, same chromaticity: Horprasert) are background, and a
pixel never seen empty is foreground. :func:`plate_from_frames` makes one from the frames at
hand (a per-pixel median, σ from the inter-quartile range); :mod:`.background` learns one around
the person a sequence shows.
"""

from __future__ import annotations

import cv2
import numpy as np
from scipy import stats

from ..camera import shrunk_size
from ..config import SilhouetteConfig
from ..errors import InputError
from .threads import each, width

__all__ = ["PlateBackground", "camera_at_most", "downscale_camera", "masked_median",
           "plate_from_frames"]

_DEFAULT = SilhouetteConfig()
#: Gains outside this range mean the frame is not comparable with the plate (lights switched).
_GAIN_RANGE = (0.5, 2.0)


# ---------------------------------------------------------------------- small helpers
def _channels(image) -> np.ndarray:
    img = np.asarray(image)
    return img[:, :, None] if img.ndim == 2 else img


def _gain(image: np.ndarray, plate: np.ndarray, known: np.ndarray | None = None) -> float:
    """Exposure gain of ``image`` against ``plate`` (median ratio on a pixel subsample)."""
    step = max(1, int(np.sqrt(image.shape[0] * image.shape[1] / 20000)))
    i = image[::step, ::step].astype(np.float32).sum(axis=2)
    p = plate[::step, ::step].astype(np.float32).sum(axis=2)
    ok = p > 30 * image.shape[2]
    if known is not None:
        ok &= known[::step, ::step]
    if ok.sum() < 50:
        return 1.0
    g = float(np.median(i[ok] / p[ok]))
    return float(np.clip(g, *_GAIN_RANGE))


def downscale_camera(camera, size):
    """The camera of the same view imaged at ``size = (W', H')`` pixels (pixel centres kept:
    :meth:`voxelmocap.camera.Camera.resized`)."""
    return camera.resized(size)


def camera_at_most(camera, max_side: int):
    """:func:`downscale_camera` to at most ``max_side`` pixels on a side (not enlarged)."""
    return downscale_camera(camera, shrunk_size(camera.size, max_side, smallest=8))


def masked_median(frames: np.ndarray, keep: np.ndarray | None = None, *,
                  quartiles: bool = False):
    """Per-pixel median of the frames where ``keep`` is True.

    The order statistics come from a histogram of each pixel's samples
    (:func:`~voxelmocap.measure._plate_kernels.order_statistics`, blocks of rows side by side
    on the threads of :func:`~voxelmocap.measure.threads.each`);
    a quantile between two samples is interpolated linearly, as NumPy's default percentile.

    Parameters
    ----------
    frames : (F, H, W, C) uint8 ndarray
    keep : (F, H, W) bool ndarray, optional
        Samples to use (default all).
    quartiles : bool
        Also return the robust σ = (Q3 − Q1) / 1.349 of the kept samples (per pixel, the root
        mean square over the channels).

    Returns
    -------
    median : (H, W, C) float32
    count : (H, W) int
        Samples kept per pixel (0: no median, the value is 0).
    sigma : (H, W) float32, only with ``quartiles``
    """
    from ._plate_kernels import order_statistics

    frames = np.asarray(frames)
    if frames.ndim != 4 or frames.dtype != np.uint8:
        raise InputError("background frames", f"expected (F, H, W, C) uint8 frames, got "
                                              f"{frames.dtype} of shape {frames.shape}")
    f, h, w, c = frames.shape
    med = np.zeros((h, w, c), np.float32)
    sig = np.zeros((h, w), np.float32)
    count = np.zeros((h, w), np.int64)
    use_keep = keep is not None
    keep = (np.ascontiguousarray(keep, bool) if use_keep else np.zeros((1, 1, 1), bool))
    if use_keep and keep.shape != (f, h, w):
        raise InputError("background frames", f"keep mask {keep.shape} differs from the "
                                              f"frames' {(f, h, w)}")
    frames = np.ascontiguousarray(frames)
    step = max(1, -(-h // (4 * width())))    # a few blocks a thread: their costs differ
    each(lambda r0: order_statistics(frames, keep, use_keep, bool(quartiles), med, count, sig,
                                     r0, min(r0 + step, h)), range(0, h, step))
    return (med, count, sig) if quartiles else (med, count)


# ---------------------------------------------------------------------- the background model
class PlateBackground:
    """A static plate with a per-pixel noise level: the foreground test of a learnt background.

    Parameters
    ----------
    plate : (H, W) or (H, W, C) array_like
        Background image (0–255).
    sigma : (H, W) array_like or float
        Noise standard deviation per pixel (grey levels, per channel).
    known : (H, W) bool array_like, optional
        Pixels whose background was seen; the others are always foreground (default: all known).
    false_alarm : float
        Probability that noise alone makes a pixel foreground (χ² tail with C degrees of freedom).
    shadows : bool
        Cast shadows (brightness ratio in ``shadow_brightness``, chromaticity distortion below
        ``shadow_chromaticity``) are background.
    unknown_margin : bool
        The never-seen region is a margin around where the person may be (wider than them, as
        :func:`~voxelmocap.measure.background.person_column` leaves it), not where the person
        stood throughout: :meth:`refine` then decides a blob of never-seen pixels alone too.

    Attributes
    ----------
    threshold : float
        The χ² quantile that ``Σ_c (I_c − g P_c)² / σ²`` must exceed.
    camera_sigma : float
        The median of ``sigma`` over the known pixels: the camera's noise level.
    concurrent : bool
        True: segmenting with it (numpy and OpenCV, GrabCut on one core) may run beside other
        cameras' in threads (:meth:`~voxelmocap.measure.stage.MeasurementStage.masks`).
    """

    #: numpy, OpenCV and serial numba kernels free of the GIL: several cameras may be
    #: segmented at once
    concurrent = True

    def __init__(self, plate, sigma, known=None, *, false_alarm: float = _DEFAULT.false_alarm,
                 shadows: bool = _DEFAULT.shadows,
                 shadow_brightness=_DEFAULT.shadow_brightness,
                 shadow_chromaticity: float = _DEFAULT.shadow_chromaticity,
                 unknown_margin: bool = False):
        self.unknown_margin = bool(unknown_margin)
        self.plate = np.ascontiguousarray(_channels(np.asarray(plate, np.float32)))
        h, w, c = self.plate.shape
        sigma = np.broadcast_to(np.asarray(sigma, np.float32), (h, w))
        self.known = (np.ones((h, w), bool) if known is None
                      else np.ascontiguousarray(known, bool))
        if self.known.shape != (h, w):
            raise InputError("background", f"known mask {self.known.shape} differs from the "
                                           f"plate's {(h, w)}")
        if not 0 < false_alarm < 1:
            raise InputError("false_alarm", f"must be in (0, 1), got {false_alarm!r}")
        self.sigma = np.maximum(sigma, 0.5).astype(np.float32)
        self.camera_sigma = float(np.median(self.sigma[self.known])) if self.known.any() else 0.5
        self.false_alarm = float(false_alarm)
        self.threshold = float(stats.chi2.isf(false_alarm, c))
        self._inv_var = (1.0 / self.sigma ** 2).astype(np.float32)
        self.shadows = bool(shadows)
        # Python floats: NumPy then compares the float32 α with them in float32, as the kernel
        self.shadow_brightness = tuple(float(b) for b in shadow_brightness)
        self.shadow_chromaticity = float(shadow_chromaticity)

    @property
    def shape(self) -> tuple[int, int]:
        """Image size ``(H, W)``."""
        return self.plate.shape[:2]

    def distance(self, image) -> tuple[np.ndarray, float]:
        """``Σ_c (I_c − g P_c)² / σ²`` per pixel (H, W) float32, and the exposure gain ``g``."""
        img = _channels(np.asarray(image))
        if img.shape[:2] != self.shape:
            raise InputError("image", f"size {img.shape[1]}x{img.shape[0]} differs from the "
                                      f"background plate's {self.shape[1]}x{self.shape[0]}")
        if img.shape[2] != self.plate.shape[2]:
            img = (cv2.cvtColor(np.ascontiguousarray(img), cv2.COLOR_BGR2GRAY)[:, :, None]
                   if self.plate.shape[2] == 1 else np.repeat(img, 3, axis=2))
        g = _gain(img, self.plate, self.known)
        d = img.astype(np.float32) - np.float32(g) * self.plate
        return np.einsum("ijc,ijc->ij", d, d) * self._inv_var, g

    def foreground(self, image) -> np.ndarray:
        """Raw foreground (H, W) bool of one image: unlike the plate beyond noise, not a shadow,
        or never seen empty."""
        img = _channels(np.asarray(image))
        if img.dtype != np.uint8 or img.shape != self.plate.shape or img.shape[2] > 3:
            # another size (refused there), other channels, or four (NumPy pairs their sums)
            return self._foreground_numpy(image)
        from ._plate_kernels import plate_foreground

        img = np.ascontiguousarray(img)
        f32 = np.float32
        mask = np.empty(self.shape, bool)
        # NumPy compares float32 arrays with Python floats in float32: so does the kernel
        plate_foreground(img, self.plate, self._inv_var, self.known,
                         f32(_gain(img, self.plate, self.known)), f32(self.threshold),
                         self.shadows, f32(self.shadow_brightness[0]),
                         f32(self.shadow_brightness[1]), f32(self.shadow_chromaticity), mask)
        return mask

    def _foreground_numpy(self, image) -> np.ndarray:
        """:meth:`foreground` in NumPy: any channels (the kernel's reference in the tests)."""
        dist, g = self.distance(image)
        mask = dist > self.threshold
        if self.shadows and mask.any():
            rows, cols = np.nonzero(mask & self.known)
            x = _channels(np.asarray(image))[rows, cols].astype(np.float32)
            bg = g * self.plate[rows, cols]
            if x.shape[1] != bg.shape[1]:
                x = x.mean(axis=1, keepdims=True) if bg.shape[1] == 1 else x
            shadow = _shadow(x, bg, self.shadow_brightness, self.shadow_chromaticity)
            mask[rows[shadow], cols[shadow]] = False
        mask |= ~self.known
        return mask

    def refine(self, image, mask, config: SilhouetteConfig | None = None) -> np.ndarray:
        """Decide the never-seen pixels of a cleaned silhouette from this frame's colours.

        :meth:`foreground` calls every pixel whose background was never seen foreground. With
        ``config.plate_unknown == "grabcut"`` each 8-connected blob of ``mask`` holding such
        pixels is cropped (its box grown by a quarter of its size) and handed to OpenCV's GrabCut
        at ``grabcut_scale`` of the resolution: known foreground pixels are fixed foreground,
        known background fixed background, the never-seen ones *probably foreground*, so GrabCut
        labels only them, from colour models of this frame's person and background in the crop
        and its edge-aware smoothness. A crop without known background is left as it is; so is
        one without known foreground, unless the never-seen region is a margin wider than the
        person (``unknown_margin``: GrabCut then starts from the never-seen pixels alone). Where
        the never-seen region is where the person stood throughout, such a blob is mostly the
        person (a standing leg) and stays whole.

        Parameters
        ----------
        image : (H, W, 3) or (H, W) uint8 array_like
        mask : (H, W) bool array_like
            The cleaned silhouette of ``image`` against this plate.
        config : SilhouetteConfig, optional

        Returns
        -------
        (H, W) bool ndarray
            ``mask`` with its never-seen pixels decided (a new array).
        """
        config = config or _DEFAULT
        mask = np.array(mask, bool)
        unknown = mask & ~self.known
        if config.plate_unknown != "grabcut" or not unknown.any():
            return mask
        img = _channels(np.asarray(image))
        if img.shape[2] == 1:
            img = np.repeat(img, 3, axis=2)
        img = np.ascontiguousarray(img.astype(np.uint8, copy=False))
        # Labelled on the mask's bounding box: every blob lies inside it, and the labels come in
        # the same raster order as on the whole image (the blobs are decided in that order)
        m8 = mask.astype(np.uint8)
        bx, by, bw_, bh_ = cv2.boundingRect(m8)
        n, labels, st, _ = cv2.connectedComponentsWithStats(
            np.ascontiguousarray(m8[by:by + bh_, bx:bx + bw_]), connectivity=8)
        has_unknown = np.bincount(labels[unknown[by:by + bh_, bx:bx + bw_]], minlength=n) > 0
        h, w = mask.shape
        for k in np.flatnonzero(has_unknown[1:]) + 1:
            x, y, bw, bh = (int(st[k, i]) for i in (0, 1, 2, 3))
            x, y = x + bx, y + by
            pad = max(bw, bh) // 4 + 8
            box = (slice(max(y - pad, 0), min(y + bh + pad, h)),
                   slice(max(x - pad, 0), min(x + bw + pad, w)))
            mask[box] = _grabcut(img[box], mask[box], self.known[box],
                                 config.grabcut_scale, config.grabcut_iterations,
                                 unknown_alone=self.unknown_margin)
        return mask


def _grabcut(image: np.ndarray, mask: np.ndarray, known: np.ndarray, scale: float,
             iterations: int, *, unknown_alone: bool = False) -> np.ndarray:
    """GrabCut of one crop: known pixels fixed, never-seen foreground pixels to decide (with
    ``unknown_alone``, also when the crop holds no known foreground pixel)."""
    unknown = mask & ~known
    sure_fg = mask & known
    sure_bg = ~mask
    person_model = unknown if unknown_alone else sure_fg
    if not (person_model.any() and sure_bg.any()):
        return mask                       # no colour model for one of the two sides
    h, w = mask.shape
    size = (max(8, int(round(w * scale))), max(8, int(round(h * scale))))
    labels = np.full((h, w), cv2.GC_BGD, np.uint8)
    labels[sure_fg] = cv2.GC_FGD
    labels[unknown] = cv2.GC_PR_FGD
    small = cv2.resize(labels, size, interpolation=cv2.INTER_NEAREST)
    seeds = (small != cv2.GC_BGD) if unknown_alone else (small == cv2.GC_FGD)
    if not (seeds.any() and (small == cv2.GC_BGD).any()):
        return mask
    crop = cv2.resize(image, size, interpolation=cv2.INTER_AREA)
    bgd, fgd = np.zeros((1, 65)), np.zeros((1, 65))
    cv2.setRNGSeed(0)                     # GrabCut's k-means start: same frame, same mask
    cv2.grabCut(crop, small, None, bgd, fgd, int(iterations), cv2.GC_INIT_WITH_MASK)
    person = (small == cv2.GC_FGD) | (small == cv2.GC_PR_FGD)
    person = cv2.resize(person.astype(np.uint8), (w, h), interpolation=cv2.INTER_NEAREST)
    return np.where(unknown, person.astype(bool), mask)


def _shadow(x, bg, brightness, chromaticity) -> np.ndarray:
    """Horprasert's test on (K, C) pixels: darker by α in ``brightness``, same chromaticity."""
    from .silhouette import _shadow_pixels

    return _shadow_pixels(x, bg, brightness, chromaticity)


def plate_from_frames(frames: np.ndarray, config: SilhouetteConfig | None = None, *,
                      keep: np.ndarray | None = None, unstable: bool = True,
                      unknown_margin: bool = False) -> PlateBackground:
    """A :class:`PlateBackground` from frames: the median plate and its robust noise.

    Parameters
    ----------
    frames : (F, H, W, C) or (F, H, W) uint8 ndarray
        Background frames (e.g. an empty background video), or a sequence with ``keep``.
    config : SilhouetteConfig, optional
        ``false_alarm`` and the shadow settings.
    keep : (F, H, W) bool ndarray, optional
        The samples showing the background (default all).
    unstable : bool
        Pixels whose kept samples spread beyond ``config.plate_unstable`` × the camera's noise
        are unknown (foreground). The passes of :func:`learn_plates` leave it off (a region the
        person crossed would otherwise turn foreground and grow the carved person pass after
        pass); the final plate sets it.
    unknown_margin : bool
        See :class:`PlateBackground`.
    """
    config = config or _DEFAULT
    frames = np.asarray(frames)
    if frames.ndim == 3:
        frames = frames[..., None]
    if frames.ndim != 4 or len(frames) == 0:
        raise InputError("background frames", f"expected (F, H, W, C) frames, got shape "
                                              f"{frames.shape}")
    plate, count, sigma = masked_median(frames, keep, quartiles=True)
    known = count >= max(1, config.plate_min_seen)
    if len(frames) >= 4:
        # The per-pixel σ of a few samples is noisy: smooth it, and floor it at the camera's σ
        # (compression noise is lowest on flat areas, never below the sensor's).
        good = known & (count >= 4)
        floor = float(np.median(sigma[good])) if good.any() else 1.0
        # A pixel whose background samples spread far beyond the camera's noise is not a
        # background: a person who never left it (moving, so it flickers) or a moving object.
        # Unknown, hence foreground; the carving keeps what the other views confirm.
        if unstable:
            known &= ~(good & (sigma > config.plate_unstable * floor))
        sigma = cv2.GaussianBlur(np.where(good, sigma, floor).astype(np.float32), (0, 0), 2.0)
        sigma = np.clip(sigma, floor, config.plate_unstable * floor)
    else:
        sigma = np.full(plate.shape[:2], 2.0, np.float32)
    return PlateBackground(plate, sigma, known, false_alarm=config.false_alarm,
                           shadows=config.shadows, shadow_brightness=config.shadow_brightness,
                           shadow_chromaticity=config.shadow_chromaticity,
                           unknown_margin=unknown_margin)
