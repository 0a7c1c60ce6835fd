"""Numba kernels of shape-from-silhouette carving (used through :mod:`voxelmocap.carving`).

Every function here is a pure function of arrays. ``tables`` is the ``(n_voxels, N_C)`` int32 table
of flat pixel indices into ``masks``: entry ``(v, c)`` is where voxel ``v``'s centre falls in camera
``c``'s mask (offset of that camera's mask in the concatenated buffer plus ``row * W + column``), or
``-1`` when camera ``c`` does not see the voxel. ``masks`` is the flat ``uint8`` concatenation of the
``N_C`` silhouettes (0 = background). Cameras are contiguous per voxel so that a voxel's lookups
share cache lines and the loop can stop at the first camera that rules the voxel out.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

__all__ = ["carve_all_views", "carve_min_views", "count_views"]


@njit(cache=True, parallel=True)
def carve_all_views(tables, masks, out):  # pragma: no cover - compiled
    """Occupied iff every camera that sees the voxel has it inside its silhouette (and >= 1 sees it).

    Parameters
    ----------
    tables : (n_voxels, N_C) int32 ndarray
        Flat pixel index per voxel and camera, -1 where the camera does not see the voxel.
    masks : (P,) uint8 ndarray
        Concatenated silhouettes, non-zero = foreground.
    out : (n_voxels,) bool ndarray
        Written with the occupancy.
    """
    n_vox, n_cam = tables.shape
    for v in prange(n_vox):
        seen = 0
        keep = True
        for c in range(n_cam):
            p = tables[v, c]
            if p >= 0:
                if masks[p] == 0:
                    keep = False
                    break  # one empty view carves the voxel away
                seen += 1
        out[v] = keep and seen > 0


@njit(cache=True, parallel=True)
def carve_min_views(tables, masks, min_views, out):  # pragma: no cover - compiled
    """Occupied iff at least ``min_views`` cameras see the voxel inside their silhouette.

    Parameters
    ----------
    tables : (n_voxels, N_C) int32 ndarray
        As in :func:`carve_all_views`.
    masks : (P,) uint8 ndarray
        Concatenated silhouettes.
    min_views : int
        Number of supporting cameras needed, ``1 <= min_views <= N_C``.
    out : (n_voxels,) bool ndarray
        Written with the occupancy.
    """
    n_vox, n_cam = tables.shape
    for v in prange(n_vox):
        hits = 0
        for c in range(n_cam):
            if hits + (n_cam - c) < min_views:
                break  # the remaining cameras can no longer reach min_views
            p = tables[v, c]
            if p >= 0 and masks[p] != 0:
                hits += 1
                if hits >= min_views:
                    break
        out[v] = hits >= min_views


@njit(cache=True, parallel=True)
def count_views(tables, masks, seen_out, inside_out):  # pragma: no cover - compiled
    """Per voxel: how many cameras see it and how many have it inside their silhouette.

    Parameters
    ----------
    tables : (n_voxels, N_C) int32 ndarray
        As in :func:`carve_all_views`.
    masks : (P,) uint8 ndarray
        Concatenated silhouettes.
    seen_out, inside_out : (n_voxels,) uint8 ndarray
        Written with the two counts.
    """
    n_vox, n_cam = tables.shape
    for v in prange(n_vox):
        seen = 0
        inside = 0
        for c in range(n_cam):
            p = tables[v, c]
            if p >= 0:
                seen += 1
                if masks[p] != 0:
                    inside += 1
        seen_out[v] = seen
        inside_out[v] = inside


def _warm_up() -> None:  # pragma: no cover - used by benchmarks to exclude compile time
    tables = np.zeros((2, 1), dtype=np.int32)
    masks = np.ones(1, dtype=np.uint8)
    out = np.zeros(2, dtype=np.bool_)
    carve_all_views(tables, masks, out)
    carve_min_views(tables, masks, 1, out)
    counts = np.zeros(2, dtype=np.uint8)
    count_views(tables, masks, counts, counts.copy())
