"""Numba kernels of the partial re-scoring behind :class:`voxelmocap.likelihood.PartialScorer`.

When only some parts move (a limb layer of the hierarchical search), the counts of the parts
that stay put change only through double occupancy (DO): their own voxels, Out, Occ and surface
do not depend on the other parts. So the static parts are rasterised once, into a box of the
unbounded lattice holding, per voxel, how many static parts contain it and — where exactly one
does — which one (:func:`static_cover`); every particle then runs the column rasteriser of
:mod:`._raster_kernels` over the moving parts only (:func:`partial_counts`), takes their Out, Occ,
surface counts from it as usual, and walks their voxels once for DO:

* a moving part's voxel is doubly occupied when the static parts and the moving parts containing
  it number two or more;
* a static part gains DO at a voxel it alone covered among the static parts, once some moving
  part covers it (counted once per voxel, for the lowest-numbered moving part containing it).

The static parts' DO among themselves comes from the full kernel run on the static subset. The
sum equals the full kernel's integer counts exactly (``tests/test_partial_likelihood.py``).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from ._raster_kernels import _boxes, _run_of, _runs, _score, _union_columns


@njit(cache=True)
def static_box(base, axis, u1, u2, shape, ox, oy, oz, vs, box):
    """Union lattice box ``box = (i0, j0, k0, ni, nj, nk)`` of the parts of particle 0."""
    n_parts = shape.shape[0]
    bb = np.empty((n_parts, 7), np.int64)
    _boxes(0, base, axis, u1, u2, shape, ox, oy, oz, vs, bb)
    i0, i1, j0, j1, k0, k1 = bb[0, 0], bb[0, 1], bb[0, 2], bb[0, 3], bb[0, 4], bb[0, 5]
    for q in range(1, n_parts):
        i0 = min(i0, bb[q, 0])
        i1 = max(i1, bb[q, 1])
        j0 = min(j0, bb[q, 2])
        j1 = max(j1, bb[q, 3])
        k0 = min(k0, bb[q, 4])
        k1 = max(k1, bb[q, 5])
    box[0], box[1], box[2] = i0, j0, k0
    box[3], box[4], box[5] = max(i1 - i0 + 1, 0), max(j1 - j0 + 1, 0), max(k1 - k0 + 1, 0)


@njit(cache=True)
def static_cover(base, axis, u1, u2, shape, ox, oy, oz, vs, box, count, owner):
    """Fill ``count`` (parts containing each voxel of the box, saturating at 2) and ``owner``
    (the part index where ``count == 1``) for the parts of particle 0; ``box`` from
    :func:`static_box`, arrays of shape ``box[3:6]``, zero-filled by the caller."""
    n_parts = shape.shape[0]
    bb = np.empty((n_parts, 7), np.int64)
    total = _boxes(0, base, axis, u1, u2, shape, ox, oy, oz, vs, bb)
    runs = np.empty((max(total, 1), 2), np.int64)
    _runs(0, base, axis, u1, u2, shape, ox, oy, oz, vs, bb, runs, np.empty((7, 256)))
    for q in range(n_parts):
        nj = bb[q, 3] - bb[q, 2] + 1
        for i in range(bb[q, 0], bb[q, 1] + 1):
            for j in range(bb[q, 2], bb[q, 3] + 1):
                idx = bb[q, 6] + (i - bb[q, 0]) * nj + (j - bb[q, 2])
                for k in range(runs[idx, 0], runs[idx, 1] + 1):
                    a, b, c = i - box[0], j - box[1], k - box[2]
                    if count[a, b, c] == 0:
                        owner[a, b, c] = q
                    if count[a, b, c] < 2:
                        count[a, b, c] += 1


@njit(cache=True)
def _moving_do(bb, runs, box, count, owner, static_ids, counts, static_do):
    """DO of the moving parts (``counts[:, 2]``) and the static parts' DO gains
    (``static_do``, indexed like the full body's parts through ``static_ids``)."""
    n_moving = bb.shape[0]
    for q in range(n_moving):
        do = 0
        i0, i1, j0, j1 = bb[q, 0], bb[q, 1], bb[q, 2], bb[q, 3]
        nj = j1 - j0 + 1
        for i in range(i0, i1 + 1):
            a = i - box[0]
            in_a = 0 <= a < box[3]
            for j in range(j0, j1 + 1):
                idx = bb[q, 6] + (i - i0) * nj + (j - j0)
                klo = runs[idx, 0]
                khi = runs[idx, 1]
                if klo > khi:
                    continue
                b = j - box[1]
                in_ab = in_a and 0 <= b < box[4]
                for k in range(klo, khi + 1):
                    c = k - box[2]
                    sc = 0
                    if in_ab and 0 <= c < box[5]:
                        sc = count[a, b, c]
                    mc = 1
                    first = True
                    for q2 in range(n_moving):
                        if q2 == q:
                            continue
                        lo2, hi2 = _run_of(q2, i, j, bb, runs)
                        if lo2 <= k <= hi2:
                            mc += 1
                            if q2 < q:
                                first = False
                    if sc + mc >= 2:
                        do += 1
                    if sc == 1 and first:
                        static_do[static_ids[owner[a, b, c]]] += 1
        counts[q, 2] = do


@njit(cache=True, parallel=True)
def partial_counts(base, axis, u1, u2, shape, ox, oy, oz, vs, prefix, qmax, box, count, owner,
                   static_ids, n_chunks, counts, static_do):
    """Counts of the moving parts ``counts (P, n_moving, 6)`` and the static parts' DO gains
    ``static_do (P, n_parts)`` for every particle (geometry arrays hold the moving parts only)."""
    n_particles = base.shape[0]
    n_parts = shape.shape[0]
    nx, ny, nz = prefix.shape[0], prefix.shape[1], prefix.shape[2] - 1
    n_chunks = max(1, min(n_particles, n_chunks))
    for c in prange(n_chunks):
        bb = np.empty((n_parts, 7), np.int64)
        runs = np.empty((512, 2), np.int64)
        cover = np.empty((512, n_parts, 3), np.int64)
        cover_n = np.empty(512, np.int64)
        multi = np.empty(512, np.int64)
        terms = np.empty((7, 256))
        for p in range(c, n_particles, n_chunks):
            total = _boxes(p, base, axis, u1, u2, shape, ox, oy, oz, vs, bb)
            if total > runs.shape[0]:
                runs = np.empty((2 * total, 2), np.int64)
            ncol = _union_columns(bb)
            if ncol > cover_n.shape[0]:
                cover = np.empty((2 * ncol, n_parts, 3), np.int64)
                cover_n = np.empty(2 * ncol, np.int64)
                multi = np.empty(2 * ncol, np.int64)
            terms = _runs(p, base, axis, u1, u2, shape, ox, oy, oz, vs, bb, runs, terms)
            _score(nx, ny, nz, prefix, qmax, bb, runs, cover, cover_n, multi, counts[p])
            _moving_do(bb, runs, box, count, owner, static_ids, counts[p], static_do[p])
