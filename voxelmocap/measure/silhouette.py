"""Background subtraction: camera images → clean boolean silhouettes.

Two background models, both used frame by frame on decoded images (``(H, W)`` grayscale or
``(H, W, 3)`` BGR ``uint8``, intensities 0–255):

* :class:`GaussianBackground` — the HumanEva toolkit's model (``HUMANEVA.md`` §7): per pixel and
  channel a Gaussian (mean, variance) learnt from each background video; the background
  likelihood is the equal-weight mixture over videos of the product over channels. A pixel is
  foreground when that likelihood is below ``1 / (256^C · risk)`` (``C`` channels; the toolkit's
  uniform-foreground decision, on the 0–255 scale). Variances are floored at ``min_variance``
  (the toolkit's 1e-3 is available; the default 4 suits compressed video).
* :class:`Mog2Background` — OpenCV's ``BackgroundSubtractorMOG2`` (Zivkovic's adaptive
  Stauffer–Grimson mixture, the reference of paper 002), learnt from background frames and/or online.

:func:`suppress_shadows` removes cast shadows from a Gaussian model's foreground with Horprasert's
brightness / chromaticity distortion: a shadow darkens the background (brightness ratio α in
``shadow_brightness``) without changing its colour (normalised chromaticity distortion below
``shadow_chromaticity``). Grayscale images carry no chromaticity; there (``shadow_gray``, off by
default) a shadow must also keep the background's texture: the normalised cross-correlation of
image and background over a small window must exceed ``shadow_ncc`` (Jacques et al. 2005), which
tells a darkened textured floor from dark clothing. :func:`clean_mask` then opens, closes, keeps the largest
component if asked, removes small 4-connected blobs (the toolkit's ``min_area``) and fills holes.

:class:`~voxelmocap.config.SilhouetteConfig` (in :mod:`voxelmocap.config`, re-exported here) holds
every setting and states every default once, with per-camera thresholds; the keyword defaults of
the functions here are read from it. :func:`segment` applies a model and the configuration to one
image; :func:`build_backgrounds` makes one model per camera. Images come from
:mod:`voxelmocap.io.humaneva` (this module reads no file).

>>> bg = GaussianBackground.fit(background_frames)          # doctest: +SKIP
>>> mask = segment(image, bg, SilhouetteConfig(), camera="C1")   # doctest: +SKIP
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping

import cv2
import numpy as np

from ..config import SilhouetteConfig
from ..errors import InputError
from ..portable import exp, log

__all__ = [
    "GaussianBackground",
    "Mog2Background",
    "SilhouetteConfig",
    "build_backgrounds",
    "clean_mask",
    "segment",
    "suppress_shadows",
]

#: The settings' defaults, stated once in :class:`voxelmocap.config.SilhouetteConfig`; the
#: keyword defaults of the functions below are read from it.
_DEFAULT = SilhouetteConfig()


# ---------------------------------------------------------------------- images
def _as_image(image, channels: int | None = None, what: str = "image", *,
              keep_uint8: bool = False) -> np.ndarray:
    """``image`` as (H, W, C) float32 with C = ``channels`` (BGR → gray when the model is gray);
    with ``keep_uint8`` a uint8 image stays uint8 (no full-image copy)."""
    img = np.asarray(image)
    if img.ndim == 2:
        img = img[:, :, None]
    if img.ndim != 3 or img.shape[2] not in (1, 3):
        raise InputError(what, f"expected an (H, W) or (H, W, 3) image, got shape {np.shape(image)}")
    if channels == 1 and img.shape[2] == 3:
        img = cv2.cvtColor(np.ascontiguousarray(img.astype(np.uint8, copy=False)),
                           cv2.COLOR_BGR2GRAY)[:, :, None]
    elif channels == 3 and img.shape[2] == 1:
        img = np.repeat(img, 3, axis=2)
    if keep_uint8 and img.dtype == np.uint8:
        return img
    return img.astype(np.float32, copy=False)


def _is_gray(image) -> bool:
    img = np.asarray(image)
    return img.ndim == 2 or img.shape[2] == 1 or (
        np.array_equal(img[..., 0], img[..., 1]) and np.array_equal(img[..., 0], img[..., 2]))


# ---------------------------------------------------------------------- Gaussian model
class GaussianBackground:
    """Equal-weight mixture of per-pixel diagonal Gaussians (HumanEva toolkit model).

    Parameters
    ----------
    means, variances : sequence of (H, W, C) array_like
        One mean and variance image (0–255 intensity scale) per background set (mixture component).
    min_variance : float
        Floor of the variances (intensity²).
    """

    def __init__(self, means, variances, *, min_variance: float = _DEFAULT.min_variance):
        means = [np.asarray(m, dtype=np.float32) for m in means]
        variances = [np.asarray(v, dtype=np.float32) for v in variances]
        if not means or len(means) != len(variances):
            raise InputError("background", "need one variance image per mean image (at least one)")
        means = [m[:, :, None] if m.ndim == 2 else m for m in means]
        variances = [v[:, :, None] if v.ndim == 2 else v for v in variances]
        shape = means[0].shape
        if len(shape) != 3 or shape[2] not in (1, 3) or any(
                a.shape != shape for a in means + variances):
            raise InputError("background", "means and variances must all be (H, W, C) images of "
                                           "one size with C = 1 or 3")
        self.means = np.stack(means)                                    # (M, H, W, C)
        self.variances = np.maximum(np.stack(variances), np.float32(min_variance))
        self.min_variance = float(min_variance)
        m = len(means)
        # Per-pixel constant of each component: log(1/M) − ½ Σ_c log(2π σ²).
        self._inv_var = (1.0 / self.variances).astype(np.float32)
        # (in float64 through voxelmocap.portable: NumPy's float32 log depends on the CPU)
        self._const = (-math.log(m) - 0.5 * log(2 * np.pi * self.variances.astype(np.float64))
                       .sum(axis=3)).astype(np.float32)

    @property
    def shape(self) -> tuple[int, int]:
        """Image size ``(H, W)``."""
        return self.means.shape[1:3]

    @property
    def channels(self) -> int:
        """1 (grayscale) or 3 (BGR)."""
        return self.means.shape[3]

    @property
    def n_components(self) -> int:
        """Number of mixture components (background sets)."""
        return self.means.shape[0]

    @staticmethod
    def _moments(frames, grayscale: bool | None, source: str):
        s = s2 = None
        n = 0
        for frame in frames:
            img = np.asarray(frame)
            if grayscale is None:
                grayscale = _is_gray(img)
            x = _as_image(img, 1 if grayscale else 3, what=source).astype(np.float64)
            if s is None:
                s = np.zeros_like(x)
                s2 = np.zeros_like(x)
            elif x.shape != s.shape:
                raise InputError(source, f"frame {n + 1} is {x.shape[1]}x{x.shape[0]}, the first "
                                         f"was {s.shape[1]}x{s.shape[0]}")
            s += x
            s2 += x * x
            n += 1
        if n == 0:
            raise InputError(source, "no background frames")
        mean = s / n
        var = np.maximum(s2 / n - mean * mean, 0.0)
        return mean, var

    @classmethod
    def fit(cls, frames: Iterable, *, min_variance: float = _DEFAULT.min_variance,
            grayscale: bool | None = None) -> GaussianBackground:
        """One-component model from background frames.

        Parameters
        ----------
        frames : iterable of (H, W) or (H, W, 3) uint8 ndarray
            Background-only images.
        min_variance : float
            Floor of the variances.
        grayscale : bool, optional
            Model gray levels; default: when the first frame is gray (one channel or equal channels).
        """
        mean, var = cls._moments(frames, grayscale, "background frames")
        return cls([mean], [var], min_variance=min_variance)

    @classmethod
    def fit_sets(cls, frame_sets: Iterable[Iterable], *,
                 min_variance: float = _DEFAULT.min_variance,
                 grayscale: bool | None = None) -> GaussianBackground:
        """Mixture model: one component per set of background frames (e.g. per video)."""
        means, variances = [], []
        for i, frames in enumerate(frame_sets):
            mean, var = cls._moments(frames, grayscale, f"background set {i + 1}")
            grayscale = mean.shape[2] == 1
            means.append(mean)
            variances.append(var)
        if not means:
            raise InputError("background", "no background sets")
        return cls(means, variances, min_variance=min_variance)

    def _pixels(self, image, *, keep_uint8: bool = False) -> np.ndarray:
        """``image`` as (H, W, C) float32 (or uint8, see :func:`_as_image`) in the model's
        channels, checked against its size."""
        x = _as_image(image, self.channels, keep_uint8=keep_uint8)
        if x.shape[:2] != self.shape:
            raise InputError("image", f"size {x.shape[1]}x{x.shape[0]} differs from the background "
                                      f"model's {self.shape[1]}x{self.shape[0]}")
        return x

    def log_likelihood(self, image) -> tuple[np.ndarray, np.ndarray]:
        """Background log-likelihood per pixel and the most likely component.

        Parameters
        ----------
        image : (H, W) or (H, W, 3) array_like
            Image on the 0–255 scale.

        Returns
        -------
        loglik : (H, W) float32 ndarray
            ``log Σ_m (1/M) Π_c N(x_c; μ_mc, σ²_mc)``.
        best : (H, W) int ndarray
            Index of the component with the largest term.
        """
        x = self._pixels(image)
        terms = np.empty((self.n_components, *self.shape), dtype=np.float32)
        for m in range(self.n_components):
            d = x - self.means[m]
            terms[m] = self._const[m] - 0.5 * np.einsum("ijc,ijc->ij", d * d, self._inv_var[m])
        if self.n_components == 1:
            return terms[0], np.zeros(self.shape, dtype=np.intp)
        best = np.argmax(terms, axis=0)
        top = np.take_along_axis(terms, best[None], axis=0)[0]
        # log-sum-exp around the best component (stable for very negative log-likelihoods)
        loglik = top + log(exp((terms - top[None]).astype(np.float64)).sum(axis=0))
        return loglik.astype(np.float32), best

    def threshold(self, risk: float = _DEFAULT.risk) -> float:
        """Log-likelihood threshold ``−log(256^C · risk)`` below which a pixel is foreground."""
        return -(self.channels * math.log(256.0) + math.log(float(risk)))

    def foreground(self, image, *, risk: float = _DEFAULT.risk, shadows: bool = False,
                   shadow_brightness=_DEFAULT.shadow_brightness,
                   shadow_chromaticity: float = _DEFAULT.shadow_chromaticity,
                   shadow_gray: bool = _DEFAULT.shadow_gray, shadow_ncc: float = _DEFAULT.shadow_ncc,
                   shadow_window: int = _DEFAULT.shadow_window) -> np.ndarray:
        """Raw foreground mask (no clean-up) of one image.

        Parameters
        ----------
        image : (H, W) or (H, W, 3) array_like
            Image on the 0–255 scale.
        risk : float
            Foreground iff likelihood < 1 / (256^C · risk).
        shadows, shadow_brightness, shadow_chromaticity, shadow_gray, shadow_ncc, shadow_window
            Shadow suppression (:func:`suppress_shadows`; see :class:`SilhouetteConfig`).

        Returns
        -------
        (H, W) bool ndarray
        """
        # converted once, for the test and the shadows; the kernel reads uint8 as it is
        pixels = self._pixels(image, keep_uint8=self.n_components == 1)
        if self.n_components == 1:  # the common case, fused into one parallel pass
            from ._silhouette_kernels import gaussian_foreground

            mask = np.empty(self.shape, dtype=bool)
            gaussian_foreground(pixels, self.means[0], self._inv_var[0], self._const[0],
                                float(self.threshold(risk)), mask)
            best = None  # the one component
        else:
            loglik, best = self.log_likelihood(pixels)
            mask = loglik < self.threshold(risk)
        if shadows and (self.channels == 3 or shadow_gray):
            # only foreground pixels can turn out to be shadows: test those alone (a few percent),
            # found inside the foreground's bounding box rather than over the whole image
            x0, y0, w, h = cv2.boundingRect(mask.view(np.uint8))
            rows, cols = np.nonzero(mask[y0:y0 + h, x0:x0 + w])
            rows += y0
            cols += x0
            x = pixels[rows, cols].astype(np.float32, copy=False)
            mean = (self.means[0, rows, cols] if best is None
                    else self.means[best[rows, cols], rows, cols])
            shadow = _shadow_pixels(x, mean, shadow_brightness, shadow_chromaticity)
            if self.channels == 1 and shadow.any():
                ncc, texture = _local_ncc(pixels[:, :, 0],
                                          self.means[0][:, :, 0] if best is None
                                          else np.take_along_axis(
                                              self.means[:, :, :, 0], best[None], axis=0)[0],
                                          int(shadow_window))
                # texture kept (and present: a flat floor has no texture to keep)
                shadow &= (ncc[rows, cols] > shadow_ncc) & (texture[rows, cols] > _MIN_TEXTURE)
            mask[rows[shadow], cols[shadow]] = False
        return mask


#: Smallest local background variance (grey levels²) for the texture test of gray shadows.
_MIN_TEXTURE = 4.0


def _local_ncc(image: np.ndarray, background: np.ndarray, radius: int):
    """Normalised cross-correlation of two (H, W) images over (2r+1)² windows, and the
    background's local variance (both (H, W) float32)."""
    k = (2 * radius + 1, 2 * radius + 1)
    img = image.astype(np.float32)
    bg = background.astype(np.float32)
    mi = cv2.boxFilter(img, -1, k)
    mb = cv2.boxFilter(bg, -1, k)
    cov = cv2.boxFilter(img * bg, -1, k) - mi * mb
    vi = cv2.boxFilter(img * img, -1, k) - mi * mi
    vb = cv2.boxFilter(bg * bg, -1, k) - mb * mb
    ncc = cov / np.sqrt(np.maximum(vi * vb, 1e-6))
    return ncc, vb


def _shadow_pixels(x, bg, brightness, chromaticity) -> np.ndarray:
    """Shadow test on (K, C) pixel values ``x`` against background means ``bg`` (see below)."""
    dot = np.einsum("kc,kc->k", x, bg)
    norm2 = np.einsum("kc,kc->k", bg, bg)
    with np.errstate(divide="ignore", invalid="ignore"):
        alpha = np.where(norm2 > 0, dot / norm2, 0.0)
        resid = x - alpha[:, None] * bg
        cd = np.sqrt(np.einsum("kc,kc->k", resid, resid)) / (alpha * np.sqrt(norm2))
    shadow = (alpha >= brightness[0]) & (alpha <= brightness[1]) & (norm2 > 0)
    if bg.shape[1] > 1:
        shadow &= np.nan_to_num(cd, nan=np.inf) <= chromaticity
    return shadow


def suppress_shadows(image, background, *, brightness=_DEFAULT.shadow_brightness,
                     chromaticity: float = _DEFAULT.shadow_chromaticity) -> np.ndarray:
    """Pixels that look like a cast shadow on the background (Horprasert et al. 1999).

    Parameters
    ----------
    image : (H, W) or (H, W, C) array_like
        Current image (0–255).
    background : (H, W) or (H, W, C) array_like
        Background mean image (0–255), same channels.
    brightness : (float, float)
        Range of the brightness distortion α = ⟨I, E⟩ / ⟨E, E⟩ a shadow may have.
    chromaticity : float
        Largest normalised chromaticity distortion ``|I − αE| / |αE|`` of a shadow (ignored for
        one channel, where it is always 0).

    Returns
    -------
    (H, W) bool ndarray
        True where the pixel is a shadow (to be removed from the foreground).
    """
    bg = _as_image(background)
    x = _as_image(image, bg.shape[2])
    h, w, c = bg.shape
    return _shadow_pixels(x.reshape(-1, c), bg.reshape(-1, c), brightness,
                          chromaticity).reshape(h, w)


# ---------------------------------------------------------------------- MOG2
class Mog2Background:
    """OpenCV's ``BackgroundSubtractorMOG2`` with the same ``foreground`` interface.

    Parameters
    ----------
    history : int
        Frames that shape the model.
    var_threshold : float
        Squared Mahalanobis distance below which a pixel matches a background mode.
    shadows : bool
        Use OpenCV's shadow detector; shadow pixels count as background.
    learning_rate : float
        Rate used by :meth:`foreground` (-1 = automatic, 0 = frozen).
    """

    def __init__(self, *, history: int = _DEFAULT.mog2_history,
                 var_threshold: float = _DEFAULT.var_threshold, shadows: bool = _DEFAULT.shadows,
                 learning_rate: float = _DEFAULT.mog2_learning_rate):
        self.subtractor = cv2.createBackgroundSubtractorMOG2(int(history), float(var_threshold),
                                                             bool(shadows))
        self.learning_rate = float(learning_rate)
        self.shape: tuple[int, int] | None = None

    def _apply(self, image, rate: float) -> np.ndarray:
        img = np.ascontiguousarray(np.asarray(image).astype(np.uint8, copy=False))
        if img.ndim not in (2, 3):
            raise InputError("image", f"expected an (H, W) or (H, W, 3) image, got shape {img.shape}")
        if self.shape is None:
            self.shape = img.shape[:2]
        elif img.shape[:2] != self.shape:
            raise InputError("image", f"size {img.shape[1]}x{img.shape[0]} differs from the "
                                      f"model's {self.shape[1]}x{self.shape[0]}")
        return self.subtractor.apply(img, learningRate=rate)

    @classmethod
    def fit(cls, frames: Iterable, **options) -> Mog2Background:
        """A model trained on background frames (automatic learning rate while training)."""
        model = cls(**options)
        n = 0
        for frame in frames:
            model._apply(frame, -1.0)
            n += 1
        if n == 0:
            raise InputError("background frames", "no background frames")
        return model

    def foreground(self, image) -> np.ndarray:
        """Foreground mask of one image (the model also learns from it at ``learning_rate``).

        Returns
        -------
        (H, W) bool ndarray
            True where MOG2 says foreground (255); shadows (127) are background.
        """
        return self._apply(image, self.learning_rate) == 255


# ---------------------------------------------------------------------- clean-up
def _disk(radius: int) -> np.ndarray:
    return cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * radius + 1, 2 * radius + 1))


def clean_mask(mask, *, open_radius: int = _DEFAULT.open_radius,
               close_radius: int = _DEFAULT.close_radius, min_area: int = _DEFAULT.min_area,
               largest_only: bool = _DEFAULT.largest_only,
               fill_holes: bool = _DEFAULT.fill_holes) -> np.ndarray:
    """Morphological clean-up of a raw foreground mask.

    Steps, in order: opening (radius ``open_radius``), closing (``close_radius``), largest
    8-connected component only (``largest_only``), removal of 4-connected blobs smaller than
    ``min_area`` pixels, filling of enclosed holes (``fill_holes``).

    Parameters
    ----------
    mask : (H, W) array_like of bool
        Raw foreground.

    Returns
    -------
    (H, W) bool ndarray
    """
    m = np.asarray(mask)
    if m.ndim != 2:
        raise InputError("mask", f"expected an (H, W) mask, got shape {m.shape}")
    m = (m != 0).astype(np.uint8)
    if open_radius > 0:
        m = cv2.morphologyEx(m, cv2.MORPH_OPEN, _disk(int(open_radius)))
    if close_radius > 0:
        # Pad so that closing does not glue the silhouette to the image border.
        r = int(close_radius)
        padded = cv2.copyMakeBorder(m, r, r, r, r, cv2.BORDER_CONSTANT, value=0)
        m = cv2.morphologyEx(padded, cv2.MORPH_CLOSE, _disk(r))[r:-r, r:-r]
    x, y, w, h = cv2.boundingRect(m)  # of the non-zero pixels; (0, 0, 0, 0) when none
    if w == 0 or not (largest_only or min_area > 1 or fill_holes):
        return m.astype(bool)
    # Component labelling on the foreground's bounding box grown by one background pixel: every
    # component lies inside it, and the box's rim is background connected to the outside, so the
    # result is the same as on the whole image at a fraction of the cost.
    box = (slice(max(y - 1, 0), y + h + 1), slice(max(x - 1, 0), x + w + 1))
    sub = np.ascontiguousarray(m[box])
    if largest_only:
        _, labels, stats, _ = cv2.connectedComponentsWithStats(sub, connectivity=8)
        keep = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
        sub = (labels == keep).astype(np.uint8)
    if min_area > 1 and sub.any():
        _, labels, stats, _ = cv2.connectedComponentsWithStats(sub, connectivity=4)
        small = np.flatnonzero(stats[:, cv2.CC_STAT_AREA] < min_area)
        small = small[small > 0]
        if len(small):
            sub[np.isin(labels, small)] = 0
    if fill_holes and sub.any():
        # Background reachable from the border stays; everything else becomes foreground.
        _, labels, _, _ = cv2.connectedComponentsWithStats(1 - sub, connectivity=4)
        border = np.unique(np.concatenate([labels[0], labels[-1], labels[:, 0], labels[:, -1]]))
        hole = ~np.isin(labels, border) & (sub == 0)
        sub[hole] = 1
    m[box] = sub
    return m.astype(bool)


# ---------------------------------------------------------------------- stage helpers
def segment(image, background, config: SilhouetteConfig | None = None, *,
            camera: str | None = None) -> np.ndarray:
    """Clean silhouette of one image with one camera's background model.

    Parameters
    ----------
    image : (H, W) or (H, W, 3) uint8 ndarray
        The frame.
    background : GaussianBackground or Mog2Background
        That camera's model.
    config : SilhouetteConfig, optional
        Thresholds, shadow and clean-up settings (defaults when None).
    camera : str, optional
        Camera name, selecting the per-camera thresholds.

    Returns
    -------
    (H, W) bool ndarray
    """
    config = config or _DEFAULT
    if isinstance(background, GaussianBackground):
        raw = background.foreground(
            image, risk=config.risk_for(camera), shadows=config.shadows,
            shadow_brightness=config.shadow_brightness,
            shadow_chromaticity=config.shadow_chromaticity, shadow_gray=config.shadow_gray,
            shadow_ncc=config.shadow_ncc, shadow_window=config.shadow_window)
    else:
        raw = background.foreground(image)
    mask = clean_mask(raw, open_radius=config.open_radius, close_radius=config.close_radius,
                      min_area=config.min_area, largest_only=config.largest_only,
                      fill_holes=config.fill_holes)
    refine = getattr(background, "refine", None)
    if refine is not None:
        # a learnt plate decides its never-seen pixels from this frame (plate.py)
        mask = refine(image, mask, config)
    return mask


def build_backgrounds(config: SilhouetteConfig, cameras: Iterable[str],
                      background_frames: Mapping[str, Iterable] | None = None, *,
                      sets: bool = False) -> dict:
    """One background model per camera.

    Parameters
    ----------
    config : SilhouetteConfig
        ``method`` selects the model; thresholds are per camera.
    cameras : iterable of str
        Camera names.
    background_frames : mapping of str to iterable, optional
        Background images per camera (or, with ``sets=True``, an iterable of image sets per camera,
        one mixture component each). Required for ``"gaussian"``; optional training for ``"mog2"``.
    sets : bool
        Whether each camera's entry is a sequence of sets (one per background video).

    Returns
    -------
    dict of str to GaussianBackground or Mog2Background
    """
    out = {}
    background_frames = background_frames or {}
    for name in cameras:
        frames = background_frames.get(name)
        if config.method == "gaussian":
            if frames is None:
                raise InputError(f"background of {name}",
                                 "the Gaussian model needs background frames (or use mog2)")
            fit = GaussianBackground.fit_sets if sets else GaussianBackground.fit
            out[name] = fit(frames, min_variance=config.min_variance)
        else:
            options = dict(history=config.mog2_history, var_threshold=config.var_threshold_for(name),
                           shadows=config.shadows, learning_rate=config.mog2_learning_rate)
            if frames is None:
                out[name] = Mog2Background(**options)
            else:
                flat = (f for s in frames for f in s) if sets else frames
                out[name] = Mog2Background.fit(flat, **options)
    return out
