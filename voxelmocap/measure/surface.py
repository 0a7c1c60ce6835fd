"""Surface voxels of an occupancy grid and their Gaussian-smoothed proximity map.

``V^S`` (:func:`surface_voxels`) holds the occupied voxels that have at least one empty
6-neighbour; voxels on the grid boundary count as having an empty neighbour outside the grid.
``Ṽ^S`` (:func:`smooth_surface`) is ``V^S`` smoothed by a Gaussian of ``sigma`` voxels and re-mapped to
[0, 1] so that it is exactly 1 on surface voxels and decays with distance from the observed surface
(paper 002 §2.2, "Surface based likelihood").

The re-mapping divides the smoothed volume by the response of an infinite flat surface at its own
voxels (the centre weight ``g0`` of the normalised 1-D Gaussian kernel), so a flat surface's profile
becomes ``exp(-d² / 2σ²)`` at distance ``d`` voxels; values above 1 (creases, thick walls) are clipped
and every surface voxel is set to 1.

Both functions work on the bounding box of the voxels that matter (grown by the filter's reach)
and paste the result into an empty volume: outside that box the answer is known to be 0, so the
result is identical to filtering the whole grid, at a fraction of the cost for a person in a room.

>>> occ = np.zeros((5, 5, 5), bool); occ[1:4, 1:4, 1:4] = True
>>> int(surface_voxels(occ).sum())  # the 3×3×3 cube minus its centre voxel
26
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from ..portable import exp

__all__ = ["smooth_surface", "smooth_surface_box", "smoothing_box", "surface_voxels"]


def surface_voxels(occupancy) -> np.ndarray:
    """Occupied voxels with at least one empty 6-neighbour (outside the grid counts as empty).

    Parameters
    ----------
    occupancy : (nx, ny, nz) array_like of bool
        ``V^R``.

    Returns
    -------
    (nx, ny, nz) bool ndarray
        ``V^S``.
    """
    occ = np.asarray(occupancy, dtype=bool)
    if occ.ndim != 3:
        raise ValueError(f"occupancy must be a 3-D volume, got shape {occ.shape}")
    out = np.zeros(occ.shape, dtype=bool)
    box = _bounding_box(occ, 1)
    if box is None:
        return out
    sub = occ[box]
    structure = ndimage.generate_binary_structure(3, 1)
    interior = ndimage.binary_erosion(sub, structure=structure, border_value=0)
    out[box] = sub & ~interior
    return out


def _bounding_box(volume: np.ndarray, pad: int) -> tuple[slice, ...] | None:
    """Slices of the bounding box of the non-zero voxels of a 3-D volume grown by ``pad``
    (clipped), or None."""
    # One reduction over the whole grid (across the x slabs: element-wise, the fast direction),
    # then x from the box's columns alone: a person fills a small part of the grid.
    plane = volume.any(axis=0)
    ys = np.flatnonzero(plane.any(axis=1))
    if len(ys) == 0:
        return None
    zs = np.flatnonzero(plane.any(axis=0))
    xs = np.flatnonzero(volume[:, ys[0]:ys[-1] + 1, zs[0]:zs[-1] + 1].any(axis=(1, 2)))
    return tuple(slice(max(int(hit[0]) - pad, 0), min(int(hit[-1]) + pad + 1, n))
                 for hit, n in zip((xs, ys, zs), volume.shape, strict=True))


def smoothing_box(surface, sigma: float, *, truncate: float = 4.0) -> tuple[slice, ...] | None:
    """Slices of the box outside which :func:`smooth_surface` is 0, or None when it is 0 everywhere.

    The bounding box of the surface voxels grown by the Gaussian's reach (``truncate · sigma``
    voxels, rounded as :func:`scipy.ndimage.gaussian_filter` does), clipped to the grid.
    ``sigma = 0`` gives the box of the voxels themselves.
    """
    surf = np.asarray(surface, dtype=bool)
    return _bounding_box(surf, int(truncate * float(sigma) + 0.5))


def _centre_weight(sigma: float, truncate: float) -> float:
    radius = int(truncate * sigma + 0.5)
    x = np.arange(-radius, radius + 1, dtype=float)
    kernel = exp(-0.5 * (x / sigma) ** 2)
    return float(1.0 / kernel.sum())


def smooth_surface(surface, sigma: float = 1.0, *, truncate: float = 4.0) -> np.ndarray:
    """Gaussian-smoothed surface map ``Ṽ^S`` in [0, 1], 1 on every surface voxel.

    Parameters
    ----------
    surface : (nx, ny, nz) array_like of bool
        ``V^S`` from :func:`surface_voxels`.
    sigma : float
        Standard deviation of the Gaussian, in voxels (> 0).
    truncate : float
        Kernel radius in standard deviations (as :func:`scipy.ndimage.gaussian_filter`).

    Returns
    -------
    (nx, ny, nz) float32 ndarray
        ``Ṽ^S``.
    """
    surf = np.asarray(surface, dtype=bool)
    out = np.zeros(surf.shape, dtype=np.float32)
    box, values = smooth_surface_box(surf, sigma, truncate=truncate)
    if box is not None:
        out[box] = values
    return out


def smooth_surface_box(surface, sigma: float = 1.0, *, truncate: float = 4.0):
    """:func:`smooth_surface` over :func:`smoothing_box` only (it is 0 everywhere else).

    Returns
    -------
    box : tuple of 3 slices, or None
        None when there is no surface voxel.
    values : (bx, by, bz) float32 ndarray, or None
        ``Ṽ^S`` inside the box.
    """
    surf = np.asarray(surface, dtype=bool)
    if not sigma > 0:
        raise ValueError(f"sigma must be positive, got {sigma!r}")
    box = smoothing_box(surf, sigma, truncate=truncate)
    if box is None:
        return None, None
    sub = surf[box]
    # mode="constant" treats the outside as empty, like the rest of the grid beyond the box
    smoothed = ndimage.gaussian_filter(sub.astype(np.float32), sigma=sigma, mode="constant",
                                       truncate=truncate)
    smoothed /= _centre_weight(float(sigma), truncate)
    np.clip(smoothed, 0.0, 1.0, out=smoothed)
    smoothed[sub] = 1.0
    return box, smoothed
