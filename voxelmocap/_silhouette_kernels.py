"""Numba kernel of :meth:`voxelmocap.silhouette.GaussianBackground.foreground` (one component).

NumPy evaluates the per-pixel Gaussian log-likelihood through whole-image temporaries (the
difference, its square, the weighted channel sum, the constant) on one core; at 7 cameras this
was half of the measurement stage. The kernel does the same float32 arithmetic in the same order
per pixel, rows spread over the cores, and writes the mask directly
(``tests/test_silhouette.py`` compares it with the NumPy expression).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange


@njit(cache=True, parallel=True)
def gaussian_foreground(x, mean, inv_var, const, threshold, mask):
    """``mask = const − ½ Σ_c (x − mean)² · inv_var < threshold`` per pixel.

    Parameters
    ----------
    x : (H, W, C) float32 or uint8 ndarray
        Image (uint8 is read as it is: no float copy of the whole image).
    mean, inv_var : (H, W, C) float32 ndarray
        Background means and inverse variances.
    const : (H, W) float32 ndarray
        The Gaussian's log normalisation per pixel.
    threshold : float
        Log-likelihood below which a pixel is foreground (compared in float64).
    mask : (H, W) bool ndarray
        Output.
    """
    h, w, n_c = x.shape
    half = np.float32(0.5)
    for i in prange(h):
        for j in range(w):
            acc = np.float32(0.0)
            for c in range(n_c):
                d = np.float32(x[i, j, c]) - mean[i, j, c]
                acc += d * d * inv_var[i, j, c]
            mask[i, j] = np.float64(const[i, j] - half * acc) < threshold
