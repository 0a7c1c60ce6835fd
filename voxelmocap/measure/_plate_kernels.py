"""Numba kernels of a learnt background plate (:mod:`voxelmocap.measure.plate`).

* :func:`order_statistics` — :func:`~voxelmocap.measure.plate.masked_median`'s per-pixel
  order statistics. The plate of a recording without background video is the per-pixel median
  of 60 sampled frames (its noise the quartiles' spread), learnt once per pass and per camera:
  NumPy sorted each pixel's samples as uint16 blocks, a tenth of the Pose2Sim demo's CPU time.
  The samples are uint8, so a histogram per pixel and channel gives every order statistic in
  one scan, without sorting and without the blocks' buffers.
* :func:`plate_foreground` — :meth:`~voxelmocap.measure.plate.PlateBackground.foreground`
  without NumPy's whole-image temporaries (the distance, the shadow test's gathers).

Both do NumPy's float arithmetic operation for operation (the interpolation between the samples
around a quantile, the σ's channel mean, float32 sums over at most three channels in index
order, the casts), so the results are the same to the bit: ``tests/measure/test_plate_kernels.py``
holds them to the sorting and to ``PlateBackground._foreground_numpy``. Both are serial and free
of the GIL: the cameras of a frame, and the plates of a pass's cameras, run in the threads of
:mod:`.threads` (numba's own parallel launch may not run in two threads at once).
"""

from __future__ import annotations

import numpy as np
from numba import njit

#: The quantiles the plate needs: the median, then the quartiles of the σ.
_Q = (0.5, 0.25, 0.75)


@njit(cache=True, inline="always")
def _rank(n, q):
    """The sorted positions either side of quantile ``q`` of ``n`` samples and the weight of
    the upper one: NumPy's ``clip((n − 1)·q, 0)``, ``floor``, ``ceil``, ``pos − lo``."""
    pos = np.float64(n - 1) * q
    if pos < 0.0:
        pos = 0.0
    lo = np.floor(pos)
    hi = np.ceil(pos)
    return np.int64(lo), np.int64(hi), pos - lo


@njit(cache=True, nogil=True)
def order_statistics(frames, keep, use_keep, quartiles, med, count, sigma, r0, r1):
    """Median (and quartile σ) of each pixel's kept uint8 samples in rows ``r0:r1``.

    Serial and free of the GIL: the caller spreads blocks of rows over threads
    (:func:`voxelmocap.measure.threads.each`), which a camera's plate, itself learnt in a
    worker thread, may call too (numba's own parallel launch may not run in two threads).

    Parameters
    ----------
    frames : (F, H, W, C) uint8 ndarray
    keep : (F, H, W) bool ndarray
        Samples to use (read only with ``use_keep``).
    use_keep : bool
    quartiles : bool
        Also fill ``sigma``: √(mean over the channels of ((Q3 − Q1) / 1.349)²), 0 below 4 samples.
    med : (H, W, C) float32 ndarray
        Output: the linear-interpolated median (0 where no sample is kept).
    count : (H, W) int64 ndarray
        Output: samples kept per pixel.
    sigma : (H, W) float32 ndarray
        Output (with ``quartiles``).
    r0, r1 : int
        The rows to do.
    """
    f, _, w, n_c = frames.shape
    n_q = 3 if quartiles else 1
    n_w = 2 * n_q
    for i in range(r0, r1):
        # per channel: a histogram of the samples and one of their top four bits (16 levels),
        # so that finding a position scans at most 16 + 16 bins, not 256
        fine = np.zeros((n_c, 256), np.int64)
        coarse = np.zeros((n_c, 16), np.int64)
        want = np.empty(n_w, np.int64)          # sorted positions wanted
        weight = np.empty(n_q, np.float64)
        order = np.empty(n_w, np.int64)         # their slots, by increasing position
        got = np.empty(n_w, np.float64)
        value = np.empty((n_c, n_q), np.float64)
        for j in range(w):
            n = 0
            for k in range(f):
                if not use_keep or keep[k, i, j]:
                    n += 1
                    for c in range(n_c):
                        v = frames[k, i, j, c]
                        fine[c, v] += 1
                        coarse[c, v >> 4] += 1
            count[i, j] = n
            if n == 0:
                for c in range(n_c):
                    med[i, j, c] = np.float32(0.0)
                if quartiles:
                    sigma[i, j] = np.float32(0.0)
                continue
            for s in range(n_q):
                lo, hi, t = _rank(n, _Q[s])
                want[2 * s] = lo
                want[2 * s + 1] = hi
                weight[s] = t
            for s in range(n_w):                # insertion sort of (at most) six slots
                order[s] = s
            for s in range(1, n_w):
                x = order[s]
                m = s - 1
                while m >= 0 and want[order[m]] > want[x]:
                    order[m + 1] = order[m]
                    m -= 1
                order[m + 1] = x
            for c in range(n_c):
                s = 0
                seen = 0
                for b in range(16):
                    nb = coarse[c, b]
                    if nb == 0:
                        continue
                    if want[order[s]] >= seen + nb:   # no wanted position in this level
                        seen += nb
                        continue
                    for v in range(16 * b, 16 * b + 16):
                        seen += fine[c, v]
                        while s < n_w and want[order[s]] < seen:
                            got[order[s]] = np.float64(v)
                            s += 1
                    if s == n_w:
                        break
                for s in range(n_q):
                    t = weight[s]
                    value[c, s] = got[2 * s] * (1.0 - t) + got[2 * s + 1] * t
            for k in range(f):
                if not use_keep or keep[k, i, j]:
                    for c in range(n_c):
                        v = frames[k, i, j, c]
                        fine[c, v] = 0
                        coarse[c, v >> 4] = 0
            for c in range(n_c):
                med[i, j, c] = np.float32(value[c, 0])
            if quartiles:
                if n < 4:
                    sigma[i, j] = np.float32(0.0)
                else:
                    acc = 0.0
                    for c in range(n_c):
                        d = (value[c, 2] - value[c, 1]) / 1.349
                        acc += d * d
                    sigma[i, j] = np.float32(np.sqrt(acc / n_c))


#: float32's largest finite value: what ``np.nan_to_num`` makes of +inf
_F32_MAX = np.float32(np.finfo(np.float32).max)


@njit(cache=True, nogil=True, error_model="numpy")
def plate_foreground(image, plate, inv_var, known, gain, threshold, shadows, low, high,
                     chromaticity, mask):
    """:meth:`~voxelmocap.measure.plate.PlateBackground.foreground` of one image, per pixel.

    NumPy's float32 expressions (the distance ``Σ_c (I_c − g P_c)² / σ²``, Horprasert's
    brightness ``α`` and chromaticity distortion) in the same order for at most three channels
    (NumPy's einsum pairs the sums of four or more), without the whole-image temporaries.
    Division by zero gives NumPy's inf or NaN (``error_model="numpy"``): a black pixel has
    ``α = 0``.

    Parameters
    ----------
    image : (H, W, C) uint8 ndarray, C <= 3
    plate : (H, W, C) float32 ndarray
    inv_var : (H, W) float32 ndarray
        1 / σ² per pixel.
    known : (H, W) bool ndarray
        The plate saw the background there (never-seen pixels are foreground).
    gain, threshold : float32
        The frame's exposure gain against the plate; the χ² quantile.
    shadows : bool
        Remove cast shadows from the foreground (known pixels only).
    low, high, chromaticity : float32
        A shadow's brightness range and largest chromaticity distortion (the latter tested
        only with more than one channel).
    mask : (H, W) bool ndarray
        Output.
    """
    h, w, n_c = image.shape
    for i in range(h):
        for j in range(w):
            acc = np.float32(0.0)
            for c in range(n_c):
                d = np.float32(image[i, j, c]) - gain * plate[i, j, c]
                acc += d * d
            fg = acc * inv_var[i, j] > threshold
            if fg and shadows and known[i, j]:
                dot = np.float32(0.0)
                norm2 = np.float32(0.0)
                for c in range(n_c):
                    bg = gain * plate[i, j, c]
                    dot += np.float32(image[i, j, c]) * bg
                    norm2 += bg * bg
                if norm2 > 0:
                    alpha = dot / norm2
                    if low <= alpha <= high:
                        shadow = True
                        if n_c > 1:
                            r2 = np.float32(0.0)
                            for c in range(n_c):
                                r = np.float32(image[i, j, c]) - alpha * (gain * plate[i, j, c])
                                r2 += r * r
                            cd = np.sqrt(r2) / (alpha * np.sqrt(norm2))
                            # the reference's nan_to_num(cd, nan=inf): NaN (α = 0 and no
                            # residual) → inf, +inf (α = 0) → float32's largest value
                            if cd != cd:
                                cd = np.float32(np.inf)
                            elif cd == np.inf:
                                cd = _F32_MAX
                            shadow = cd <= chromaticity
                        if shadow:
                            fg = False
            mask[i, j] = fg or not known[i, j]
