"""Numba kernels of the partial re-scoring behind :class:`voxelmocap.score.partial.PartialScorer`.

When only some parts move (a limb layer of the hierarchical search), the counts of the parts
that stay put change only through double occupancy (DO): their own voxels, Out, Occ and surface
do not depend on the other parts. So the static parts' runs are found once, per column of their
box (:func:`static_runs`); every particle then runs the column rasteriser of
:mod:`._raster_kernels` over the moving parts only (:func:`partial_counts`), takes their Out, Occ,
surface counts from it as usual, and settles DO column by column, from the runs that overlap each
moving run (:func:`_moving_do`):

* a moving part's voxel is doubly occupied when any other part, static or moving, contains it;
* a static part gains DO at a voxel it alone covered among the static parts, once some moving
  part covers it (counted once per voxel, for the lowest-numbered moving part containing it).

Interval arithmetic per column costs a few operations per run; the voxel walk it replaced cost a
few per voxel and per other moving part, which made the legs' four cones dearer to score this
way than all ten in full.

The static parts' DO among themselves comes from the full kernel run on the static subset. The
sum equals the full kernel's integer counts exactly (``tests/score/test_partial_likelihood.py``).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from ._raster_kernels import _boxes, _insert_by_start, _run_of, _runs, _score, _union_columns


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
def static_runs(base, axis, u1, u2, shape, ox, oy, oz, vs, box, table):
    """Each static part's run in each column of the box: ``table (ni, nj, n_static, 2)``
    (``klo, khi``; ``klo > khi`` where the part misses the column, as the caller fills it)
    for the parts of particle 0; ``box`` from :func:`static_box`."""
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
                table[i - box[0], j - box[1], q, 0] = runs[idx, 0]
                table[i - box[0], j - box[1], q, 1] = runs[idx, 1]


@njit(cache=True, inline="always")
def _covered(lo, hi, ilo, ihi, n, slo, shi):
    """Integers of ``[lo, hi]`` inside the union of the intervals ``ilo[:n], ihi[:n]``
    (``slo``, ``shi``: scratch of length ≥ n)."""
    m = 0
    for t in range(n):  # clipped to [lo, hi], sorted by start (a handful of intervals)
        a = max(ilo[t], lo)
        b = min(ihi[t], hi)
        if a <= b:
            _insert_by_start(slo, shi, m, a, b)
            m += 1
    if m == 0:
        return 0
    total = 0
    cur_lo = slo[0]
    cur_hi = shi[0]
    for t in range(1, m):
        if slo[t] <= cur_hi:
            cur_hi = max(cur_hi, shi[t])
        else:
            total += cur_hi - cur_lo + 1
            cur_lo = slo[t]
            cur_hi = shi[t]
    return total + cur_hi - cur_lo + 1


@njit(cache=True)
def _moving_do(bb, runs, box, table, static_ids, counts, static_do, olo, ohi, kind, plo, phi,
               slo, shi):
    """DO of the moving parts (``counts[:, 2]``) and the static parts' DO gains
    (``static_do``, indexed like the full body's parts through ``static_ids``), column by
    column: in each column of a moving part's run, the other parts' runs that overlap it.

    * the moving part's DO: its layers covered by any other part's run;
    * a static part's gain, charged to the lowest-numbered moving part covering the layer: the
      layers of its run inside this moving run that no other static part and no lower-numbered
      moving part covers (there the static parts alone did not double-occupy it).

    ``olo, ohi, kind, plo, phi, slo, shi``: scratch of length ≥ the number of parts.
    """
    n_moving = bb.shape[0]
    n_static = table.shape[2]
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
                # the other parts' runs in this column that overlap [klo, khi]; kind ≥ 0 is a
                # static part's index, −1 − q2 the moving part q2
                n = 0
                b = j - box[1]
                if in_a and 0 <= b < box[4]:
                    for s in range(n_static):
                        lo2 = table[a, b, s, 0]
                        hi2 = table[a, b, s, 1]
                        if lo2 <= hi2 and lo2 <= khi and hi2 >= klo:
                            olo[n] = lo2
                            ohi[n] = hi2
                            kind[n] = s
                            n += 1
                for q2 in range(n_moving):
                    if q2 != q:
                        lo2, hi2 = _run_of(q2, i, j, bb, runs)
                        if lo2 <= hi2 and lo2 <= khi and hi2 >= klo:
                            olo[n] = lo2
                            ohi[n] = hi2
                            kind[n] = -1 - q2
                            n += 1
                if n == 0:
                    continue
                do += _covered(klo, khi, olo, ohi, n, slo, shi)
                for t in range(n):
                    s = kind[t]
                    if s < 0:
                        continue
                    ilo = max(olo[t], klo)
                    ihi = min(ohi[t], khi)
                    m = 0
                    for u in range(n):
                        if u != t and (kind[u] >= 0 or -1 - kind[u] < q):
                            plo[m] = olo[u]
                            phi[m] = ohi[u]
                            m += 1
                    static_do[static_ids[s]] += ihi - ilo + 1 - _covered(ilo, ihi, plo, phi, m,
                                                                         slo, shi)
        counts[q, 2] = do


@njit(cache=True)
def _partial_chunk(c, n_chunks, base, axis, u1, u2, shape, ox, oy, oz, vs, prefix, lattice, qmax,
                   box, table, static_ids, counts, static_do):
    """Particles ``c, c + n_chunks, …`` of :func:`partial_counts`."""
    n_particles = base.shape[0]
    n_parts = shape.shape[0]
    bb = np.empty((n_parts, 7), np.int64)
    runs = np.empty((512, 2), np.int64)
    cover = np.empty((512, n_parts, 3), np.int64)
    cover_n = np.empty(512, np.int64)
    multi = np.empty(512, np.int64)
    terms = np.empty((7, 256))
    n_all = n_parts + table.shape[2]
    olo = np.empty(n_all, np.int64)
    ohi = np.empty(n_all, np.int64)
    kind = np.empty(n_all, np.int64)
    plo = np.empty(n_all, np.int64)
    phi = np.empty(n_all, np.int64)
    slo = np.empty(n_all, np.int64)
    shi = np.empty(n_all, np.int64)
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
        _score(lattice, prefix, qmax, bb, runs, cover, cover_n, multi, counts[p])
        _moving_do(bb, runs, box, table, static_ids, counts[p], static_do[p], olo, ohi, kind,
                   plo, phi, slo, shi)


@njit(cache=True, parallel=True)
def partial_counts(base, axis, u1, u2, shape, ox, oy, oz, vs, prefix, lattice, qmax, box, table,
                   static_ids, n_chunks, counts, static_do):
    """Counts of the moving parts ``counts (P, n_moving, 6)`` and the static parts' DO gains
    ``static_do (P, n_parts)`` for every particle (geometry arrays hold the moving parts only)."""
    n_chunks = max(1, min(base.shape[0], n_chunks))
    for c in prange(n_chunks):
        _partial_chunk(c, n_chunks, base, axis, u1, u2, shape, ox, oy, oz, vs, prefix, lattice,
                       qmax, box, table, static_ids, counts, static_do)


@njit(cache=True)
def partial_counts_serial(base, axis, u1, u2, shape, ox, oy, oz, vs, prefix, lattice, qmax, box,
                          table, static_ids, n_chunks, counts, static_do):
    """:func:`partial_counts` on one thread, the same chunks in turn: for a few particles
    (:func:`voxelmocap.thread_waits.serial`)."""
    n_chunks = max(1, min(base.shape[0], n_chunks))
    for c in range(n_chunks):
        _partial_chunk(c, n_chunks, base, axis, u1, u2, shape, ox, oy, oz, vs, prefix, lattice,
                       qmax, box, table, static_ids, counts, static_do)
