"""Numba kernels of shape-from-silhouette carving (used through :mod:`voxelmocap.measure.carving`).

Every function here is a pure function of arrays. ``tables`` is the ``(N_C, n_voxels)`` int32 table
of flat pixel indices into ``masks``: entry ``(c, v)`` is where voxel ``v``'s centre falls in camera
``c``'s mask (offset of that camera's mask in the concatenated buffer plus ``row * W + column``), or
``-1`` when camera ``c`` does not see the voxel. ``masks`` is the flat ``uint8`` concatenation of the
``N_C`` silhouettes (0 = background).

Why camera-major: a frame is limited by memory traffic, not arithmetic. Most voxels are ruled out
by the first camera, so only the first camera's row is streamed in full; later rows are read only
around the voxels still alive, which are clustered (the silhouette's cone), so few cache lines of
them are touched. A voxel-major layout would stream all ``4 · N_C`` bytes of every voxel.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

__all__ = ["brick_bounds", "carve_all_views", "carve_bricks", "carve_min_views", "count_views",
           "project_table"]


@njit(cache=True, parallel=True)
def carve_all_views(tables, masks, out):  # pragma: no cover - compiled
    """Occupied iff every camera that sees the voxel has it inside its silhouette (and >= 1 sees it).

    Parameters
    ----------
    tables : (N_C, n_voxels) int32 ndarray
        Flat pixel index per camera and voxel, -1 where the camera does not see the voxel.
    masks : (P,) uint8 ndarray
        Concatenated silhouettes, non-zero = foreground.
    out : (n_voxels,) bool ndarray
        Written with the occupancy.
    """
    n_cam, n_vox = tables.shape
    for v in prange(n_vox):
        seen = 0
        keep = True
        for c in range(n_cam):
            p = tables[c, v]
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
    tables : (N_C, n_voxels) int32 ndarray
        As in :func:`carve_all_views`.
    masks : (P,) uint8 ndarray
        Concatenated silhouettes.
    min_views : int
        Number of supporting cameras needed, ``1 <= min_views <= N_C``.
    out : (n_voxels,) bool ndarray
        Written with the occupancy.
    """
    n_cam, n_vox = tables.shape
    for v in prange(n_vox):
        hits = 0
        for c in range(n_cam):
            if hits + (n_cam - c) < min_views:
                break  # the remaining cameras can no longer reach min_views
            p = tables[c, v]
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
    tables : (N_C, n_voxels) int32 ndarray
        As in :func:`carve_all_views`.
    masks : (P,) uint8 ndarray
        Concatenated silhouettes.
    seen_out, inside_out : (n_voxels,) uint8 ndarray
        Written with the two counts.
    """
    n_cam, n_vox = tables.shape
    for v in prange(n_vox):
        seen = 0
        inside = 0
        for c in range(n_cam):
            p = tables[c, v]
            if p >= 0:
                seen += 1
                if masks[p] != 0:
                    inside += 1
        seen_out[v] = seen
        inside_out[v] = inside


def _warm_up() -> None:  # pragma: no cover - used by benchmarks to exclude compile time
    tables = np.zeros((1, 2), dtype=np.int32)
    masks = np.ones(1, dtype=np.uint8)
    out = np.zeros(2, dtype=np.bool_)
    carve_all_views(tables, masks, out)
    carve_min_views(tables, masks, 1, out)
    counts = np.zeros(2, dtype=np.uint8)
    count_views(tables, masks, counts, counts.copy())


# ---------------------------------------------------------------------- bricks
# The grid is split into bricks of b×b×b voxels. For every brick and camera, the pixel rectangle
# holding the projections of the brick's voxels that the camera sees is stored once. Per frame, a
# rectangle with no silhouette pixel (one look-up in the mask's integral image) proves that the
# camera carves every voxel of the brick it sees, so whole bricks of empty room are skipped without
# touching their voxels' table entries.


@njit(cache=True, parallel=True)
def brick_bounds(table, offset, width, nx, ny, nz, b, rect, full):  # pragma: no cover - compiled
    """Pixel rectangle of each brick's voxels in one camera.

    Parameters
    ----------
    table : (n_voxels,) int32 ndarray
        This camera's row of the tables.
    offset, width : int
        Offset of the camera's mask in the concatenated buffer, and the image width W.
    nx, ny, nz, b : int
        Grid shape and brick edge (voxels).
    rect : (n_bricks, 4) int32 ndarray
        Written with ``u0, u1, v0, v1`` (inclusive); ``u0 = -1`` when no voxel is seen.
    full : (n_bricks,) bool ndarray
        Written with whether every voxel of the brick is seen.
    """
    bx = (nx + b - 1) // b
    by = (ny + b - 1) // b
    bz = (nz + b - 1) // b
    for brick in prange(bx * by * bz):
        i0 = (brick // (by * bz)) * b
        j0 = ((brick // bz) % by) * b
        k0 = (brick % bz) * b
        u0 = 1 << 30
        v0 = 1 << 30
        u1 = -1
        v1 = -1
        all_seen = True
        for i in range(i0, min(i0 + b, nx)):
            for j in range(j0, min(j0 + b, ny)):
                base = (i * ny + j) * nz
                for k in range(k0, min(k0 + b, nz)):
                    p = table[base + k]
                    if p < 0:
                        all_seen = False
                        continue
                    r = p - offset
                    v = r // width
                    u = r - v * width
                    u0 = min(u0, u)
                    u1 = max(u1, u)
                    v0 = min(v0, v)
                    v1 = max(v1, v)
        if u1 < 0:
            rect[brick, 0] = -1
            rect[brick, 1] = -1
            rect[brick, 2] = -1
            rect[brick, 3] = -1
        else:
            rect[brick, 0] = u0
            rect[brick, 1] = u1
            rect[brick, 2] = v0
            rect[brick, 3] = v1
        full[brick] = all_seen


# Serial on purpose: with brick rejection a 3.8 M-voxel frame is ~1 ms of work on one core, less
# than what a parallel region costs to start and join whenever the cores are shared (a prange
# region then waits for the other thread to be scheduled: 8-16 ms measured at load 4-8 on 2 cores).
@njit(cache=True)
def carve_bricks(tables, masks, integrals, int_offsets, int_widths, rects, full, nx, ny, nz, b,
                 min_views, out):  # pragma: no cover - compiled
    """Carving with brick rejection; same result as :func:`carve_all_views` / :func:`carve_min_views`.

    Parameters
    ----------
    tables : (N_C, n_voxels) int32 ndarray
        Voxel → pixel tables.
    masks : (P,) uint8 ndarray
        Concatenated silhouettes.
    integrals : (Q,) int32 ndarray
        Concatenated integral images, ``(H + 1, W + 1)`` per camera (``cv2.integral``).
    int_offsets, int_widths : (N_C,) int64 ndarray
        Where each camera's integral image starts in ``integrals``, and its row length ``W + 1``.
    rects : (N_C, n_bricks, 4) int32 ndarray
        From :func:`brick_bounds`.
    full : (N_C, n_bricks) bool ndarray
        From :func:`brick_bounds`.
    nx, ny, nz, b : int
        Grid shape and brick edge.
    min_views : int
        0 for the default rule (every camera that sees the voxel), else the number of silhouettes
        a voxel must be inside.
    out : (n_voxels,) bool ndarray
        Zero on entry; written with the occupancy.
    """
    n_cam = tables.shape[0]
    bx = (nx + b - 1) // b
    by = (ny + b - 1) // b
    bz = (nz + b - 1) // b
    for brick in range(bx * by * bz):
        # how many cameras may still hold the brick's voxels inside their silhouette
        possible = 0
        empty = False
        for c in range(n_cam):
            if min_views > 0 and (possible >= min_views or possible + n_cam - c < min_views):
                break  # already enough cameras, or no longer reachable
            u0 = rects[c, brick, 0]
            if u0 < 0:
                continue
            u1 = rects[c, brick, 1] + 1
            v0 = rects[c, brick, 2]
            v1 = rects[c, brick, 3] + 1
            o = int_offsets[c]
            w = int_widths[c]
            s = (integrals[o + v1 * w + u1] - integrals[o + v0 * w + u1]
                 - integrals[o + v1 * w + u0] + integrals[o + v0 * w + u0])
            if s > 0:
                possible += 1
            elif min_views == 0 and full[c, brick]:
                empty = True  # this camera sees every voxel of the brick on background
                break
        if empty or possible == 0 or (min_views > 0 and possible < min_views):
            continue
        i0 = (brick // (by * bz)) * b
        j0 = ((brick // bz) % by) * b
        k0 = (brick % bz) * b
        for i in range(i0, min(i0 + b, nx)):
            for j in range(j0, min(j0 + b, ny)):
                base = (i * ny + j) * nz
                for k in range(k0, min(k0 + b, nz)):
                    v = base + k
                    if min_views == 0:
                        seen = 0
                        keep = True
                        for c in range(n_cam):
                            p = tables[c, v]
                            if p >= 0:
                                if masks[p] == 0:
                                    keep = False
                                    break
                                seen += 1
                        out[v] = keep and seen > 0
                    else:
                        hits = 0
                        for c in range(n_cam):
                            if hits + (n_cam - c) < min_views:
                                break
                            p = tables[c, v]
                            if p >= 0 and masks[p] != 0:
                                hits += 1
                                if hits >= min_views:
                                    break
                        out[v] = hits >= min_views


# ---------------------------------------------------------------------- tables
@njit(cache=True, parallel=True)
def project_table(R, T, fc, cc, alpha, kc, r_max, origin, size, nx, ny, nz, width, height,
                  offset, out):  # pragma: no cover - compiled
    """One camera's row of the voxel → pixel table (Bouguet model, as ``Camera.project``).

    Parameters
    ----------
    R : (3, 3) float64 ndarray
        World → camera rotation.
    T : (3,) float64 ndarray
        World → camera translation (mm).
    fc, cc : (2,) float64 ndarray
        Focal lengths and principal point (pixels).
    alpha : float
        Skew.
    kc : (5,) float64 ndarray
        Distortion ``k1, k2, p1, p2, k3``.
    r_max : float
        Largest trusted undistorted normalised radius (field of view).
    origin : (3,) float64 ndarray
        Grid corner (mm).
    size : float
        Voxel edge (mm).
    nx, ny, nz : int
        Grid shape.
    width, height : int
        Image size.
    offset : int
        Offset of this camera's mask in the concatenated buffer.
    out : (nx * ny * nz,) int32 ndarray
        Written with ``offset + row * width + column``, or -1 where the camera does not see the
        voxel centre (behind, outside the field of view, or rounding outside the image).
    """
    k1, k2, p1, p2, k3 = kc[0], kc[1], kc[2], kc[3], kc[4]
    r2max = r_max * r_max
    for i in prange(nx):
        x = origin[0] + (i + 0.5) * size
        for j in range(ny):
            y = origin[1] + (j + 0.5) * size
            base = (i * ny + j) * nz
            for k in range(nz):
                w = origin[2] + (k + 0.5) * size
                xc = R[0, 0] * x + R[0, 1] * y + R[0, 2] * w + T[0]
                yc = R[1, 0] * x + R[1, 1] * y + R[1, 2] * w + T[1]
                zc = R[2, 0] * x + R[2, 1] * y + R[2, 2] * w + T[2]
                idx = -1
                if zc > 0:
                    a = xc / zc
                    b = yc / zc
                    r2 = a * a + b * b
                    if r2 <= r2max:
                        radial = 1.0 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2
                        xd = a * radial + 2.0 * p1 * a * b + p2 * (r2 + 2.0 * a * a)
                        yd = b * radial + p1 * (r2 + 2.0 * b * b) + 2.0 * p2 * a * b
                        u = np.rint(fc[0] * (xd + alpha * yd) + cc[0])
                        v = np.rint(fc[1] * yd + cc[1])
                        if u >= 0 and u < width and v >= 0 and v < height:
                            idx = offset + int(v) * width + int(u)
                out[base + k] = idx
