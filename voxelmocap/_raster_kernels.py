"""Numba kernels of the per-column interval rasteriser behind :mod:`voxelmocap.likelihood`.

Every truncated cone is convex, so its voxels in a lattice column ``(i, j)`` form one run
``k ∈ [klo, khi]`` (DESIGN.md §4). :func:`_column_interval` finds the run from the roots of a
quadratic in z, then settles both ends with :func:`_inside` — the very membership test, in the very
floating-point operation order, that the per-voxel reference uses — so the runs are exactly the
reference's voxel sets. With per-column prefix sums along z of the scene mask, of ``V^R`` and of
the quantised ``Ṽ^S``, a part's voxel count, Out, Occ and Surf sums cost O(1) per column; DO is
the overlap of the run with the union of the other parts' runs in that column, and a part's
surface voxels are the run ends plus the stretches not covered by all four neighbour columns' runs.

All lattice indices are *unbounded* (columns and layers outside the grid exist, they are simply
outside the analysed scene). Geometry arrays are float64, ``(P, n_parts, 3)``; ``shape`` is
``(n_parts, 7)`` = ``1/H, 1/W, L, (R − 1)/L, H, W, R``. Counts are int64 ``(P, n_parts, 6)`` =
``|Y|, Out, DO, Occ, |Y^S|, Σ_{Y^S}(Q − Ṽq)``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

# Widening of the approximate run (dimensionless in the cone inequality, mm along the axis): it
# only makes the closed-form run a little too long; the exact ends come from _inside.
_EPS_Q = 1e-9
_EPS_T = 1e-6
_EPS_IDX = 1e-6
N_COUNTS = 6


@njit(cache=True)
def _inside(tp, ap, bp, dz, nz, u1z, u2z, inv_h, inv_w, length, k_r):
    """Membership of one voxel centre; ``tp, ap, bp`` are the column's x-y partial sums.

    The expression order matches ``likelihood._inside_reference`` term by term:
    ``t = dx·nx + dy·ny + dz·nz`` evaluates as ``(dx·nx + dy·ny) + dz·nz``.
    """
    t = tp + dz * nz
    if t < 0.0 or t > length:
        return False
    a = ap + dz * u1z
    b = bp + dz * u2z
    s = 1.0 + k_r * t
    ah = a * inv_h
    bw = b * inv_w
    return ah * ah + bw * bw <= s * s


@njit(cache=True)
def _part_bbox(base, axis, u1, u2, shp, ox, oy, oz, vs, bb):
    """Lattice index box ``bb = (i0, i1, j0, j1, k0, k1)`` (inclusive) of one cone."""
    h, w, r, length = shp[4], shp[5], shp[6], shp[2]
    origin = (ox, oy, oz)
    for e in range(3):
        ext0 = math.sqrt((h * u1[e]) ** 2 + (w * u2[e]) ** 2)
        ext1 = r * ext0
        far = base[e] + length * axis[e]
        lo = min(base[e] - ext0, far - ext1)
        hi = max(base[e] + ext0, far + ext1)
        bb[2 * e] = int(math.ceil((lo - origin[e]) / vs - 0.5 - _EPS_IDX))
        bb[2 * e + 1] = int(math.floor((hi - origin[e]) / vs - 0.5 + _EPS_IDX))


@njit(cache=True)
def _column_interval(tp, ap, bp, nz, u1z, u2z, inv_h, inv_w, length, k_r, bz, oz, vs,
                     kmin, kmax):
    """Exact run ``(klo, khi)`` of one cone in one column; ``klo > khi`` when empty."""
    # Closed form: the cone inequality is q(dz) = qa dz² + 2 qb dz + qc ≤ 0 on the slab
    # 0 ≤ t ≤ L; dz is measured from the base centre's z.
    a0 = ap * inv_h
    a1 = u1z * inv_h
    b0 = bp * inv_w
    b1 = u2z * inv_w
    s0 = 1.0 + k_r * tp
    s1 = k_r * nz
    qa = a1 * a1 + b1 * b1 - s1 * s1
    qb = a0 * a1 + b0 * b1 - s0 * s1
    qc = a0 * a0 + b0 * b0 - s0 * s0 - _EPS_Q
    lo = (kmin + 0.5) * vs + oz - bz - vs
    hi = (kmax + 0.5) * vs + oz - bz + vs
    if nz != 0.0:
        za = (-_EPS_T - tp) / nz
        zb = (length + _EPS_T - tp) / nz
        lo = max(lo, min(za, zb))
        hi = min(hi, max(za, zb))
    elif tp < -_EPS_T or tp > length + _EPS_T:
        return 1, 0
    if lo > hi:
        return 1, 0
    disc = qb * qb - qa * qc
    if qa > 0.0:
        if disc < 0.0:
            return 1, 0
        qq = -(qb + math.copysign(math.sqrt(disc), qb))
        if qq == 0.0:
            r1 = r2 = -qb / qa
        else:
            r1 = qq / qa
            r2 = qc / qq
        lo = max(lo, min(r1, r2))
        hi = min(hi, max(r1, r2))
    elif qa < 0.0:
        if disc >= 0.0:
            qq = -(qb + math.copysign(math.sqrt(disc), qb))
            if qq == 0.0:
                rs = rb = -qb / qa
            else:
                rs = min(qq / qa, qc / qq)
                rb = max(qq / qa, qc / qq)
            piece_a = min(hi, rs) >= lo
            piece_b = max(lo, rb) <= hi
            if piece_a and not piece_b:
                hi = min(hi, rs)
            elif piece_b and not piece_a:
                lo = max(lo, rb)
            elif not piece_a and not piece_b:
                return 1, 0
            # both pieces: keep the hull; the exact ends are found below
    else:
        if qb > 0.0:
            hi = min(hi, -qc / (2.0 * qb))
        elif qb < 0.0:
            lo = max(lo, -qc / (2.0 * qb))
        elif qc > 0.0:
            return 1, 0
    if lo > hi:
        return 1, 0
    # to lattice layers, clamped to the cone's box
    klo = int(math.ceil(max(min((lo + bz - oz) / vs - 0.5, kmax + 1.0), kmin - 1.0)))
    khi = int(math.floor(max(min((hi + bz - oz) / vs - 0.5, kmax + 1.0), kmin - 1.0)))
    klo = max(klo, kmin)
    khi = min(khi, kmax)
    # settle the ends with the exact membership test
    while klo <= khi and not _inside(tp, ap, bp, oz + (klo + 0.5) * vs - bz, nz, u1z, u2z,
                                     inv_h, inv_w, length, k_r):
        klo += 1
    while khi >= klo and not _inside(tp, ap, bp, oz + (khi + 0.5) * vs - bz, nz, u1z, u2z,
                                     inv_h, inv_w, length, k_r):
        khi -= 1
    if klo > khi:
        return 1, 0
    while klo > kmin and _inside(tp, ap, bp, oz + (klo - 0.5) * vs - bz, nz, u1z, u2z,
                                 inv_h, inv_w, length, k_r):
        klo -= 1
    while khi < kmax and _inside(tp, ap, bp, oz + (khi + 1.5) * vs - bz, nz, u1z, u2z,
                                 inv_h, inv_w, length, k_r):
        khi += 1
    return klo, khi


@njit(cache=True)
def _boxes(p, base, axis, u1, u2, shape, ox, oy, oz, vs, bb):
    """Boxes of all parts of particle ``p`` into ``bb (n_parts, 7)``; column offsets in
    ``bb[:, 6]``; returns the total number of columns."""
    total = 0
    for q in range(shape.shape[0]):
        _part_bbox(base[p, q], axis[p, q], u1[p, q], u2[p, q], shape[q], ox, oy, oz, vs, bb[q])
        bb[q, 6] = total
        ni = bb[q, 1] - bb[q, 0] + 1
        nj = bb[q, 3] - bb[q, 2] + 1
        if ni > 0 and nj > 0:
            total += ni * nj
    return total


@njit(cache=True)
def _runs(p, base, axis, u1, u2, shape, ox, oy, oz, vs, bb, runs):
    """Runs of every part of particle ``p`` in every column of its box, into ``runs (·, 2)``."""
    for q in range(shape.shape[0]):
        inv_h, inv_w, length, k_r = shape[q, 0], shape[q, 1], shape[q, 2], shape[q, 3]
        bx, by, bz = base[p, q, 0], base[p, q, 1], base[p, q, 2]
        nx_, ny_, nz_ = axis[p, q, 0], axis[p, q, 1], axis[p, q, 2]
        ax, ay, az = u1[p, q, 0], u1[p, q, 1], u1[p, q, 2]
        cx, cy, cz = u2[p, q, 0], u2[p, q, 1], u2[p, q, 2]
        i0, i1, j0, j1, k0, k1, off = bb[q, 0], bb[q, 1], bb[q, 2], bb[q, 3], bb[q, 4], \
            bb[q, 5], bb[q, 6]
        nj = j1 - j0 + 1
        for i in range(i0, i1 + 1):
            dx = ox + (i + 0.5) * vs - bx
            for j in range(j0, j1 + 1):
                dy = oy + (j + 0.5) * vs - by
                tp = dx * nx_ + dy * ny_
                ap = dx * ax + dy * ay
                bp = dx * cx + dy * cy
                klo, khi = _column_interval(tp, ap, bp, nz_, az, cz, inv_h, inv_w, length, k_r,
                                            bz, oz, vs, k0, k1)
                idx = off + (i - i0) * nj + (j - j0)
                runs[idx, 0] = klo
                runs[idx, 1] = khi


@njit(cache=True)
def _run_of(q, i, j, bb, runs):
    if i < bb[q, 0] or i > bb[q, 1] or j < bb[q, 2] or j > bb[q, 3]:
        return 1, 0
    idx = bb[q, 6] + (i - bb[q, 0]) * (bb[q, 3] - bb[q, 2] + 1) + (j - bb[q, 2])
    return runs[idx, 0], runs[idx, 1]


@njit(cache=True)
def _score(nx, ny, nz, prefix, qmax, bb, runs, near, tmp_lo, tmp_hi, counts):
    """Integer counts of every part of one particle into ``counts (n_parts, 6)``."""
    n_parts = bb.shape[0]
    for q in range(n_parts):
        n = 0
        out = 0
        do = 0
        occ = 0
        nsurf = 0
        surf = 0
        i0, i1, j0, j1 = bb[q, 0], bb[q, 1], bb[q, 2], bb[q, 3]
        nj = j1 - j0 + 1
        off = bb[q, 6]
        # only parts whose boxes meet this part's box can share voxels with it
        n_near = 0
        for r in range(n_parts):
            if r != q and bb[r, 0] <= i1 and bb[r, 1] >= i0 and bb[r, 2] <= j1 \
                    and bb[r, 3] >= j0 and bb[r, 4] <= bb[q, 5] and bb[r, 5] >= bb[q, 4]:
                near[n_near] = r
                n_near += 1
        for i in range(i0, i1 + 1):
            for j in range(j0, j1 + 1):
                idx = off + (i - i0) * nj + (j - j0)
                klo = runs[idx, 0]
                khi = runs[idx, 1]
                if klo > khi:
                    continue
                length = khi - klo + 1
                n += length
                # interior: k±1 in the run and the four neighbour columns contain k
                ilo = klo + 1
                ihi = khi - 1
                # neighbours inside the box have runs; outside it the part is empty
                if i > i0 and i < i1 and j > j0 and j < j1:
                    ilo = max(ilo, max(max(runs[idx - nj, 0], runs[idx + nj, 0]),
                                       max(runs[idx - 1, 0], runs[idx + 1, 0])))
                    ihi = min(ihi, min(min(runs[idx - nj, 1], runs[idx + nj, 1]),
                                       min(runs[idx - 1, 1], runs[idx + 1, 1])))
                else:
                    ihi = ilo - 1
                n_int = ihi - ilo + 1 if ihi >= ilo else 0
                nsurf += length - n_int
                sv_all = 0
                sv_int = 0
                scene_in = 0
                if 0 <= i < nx and 0 <= j < ny:
                    a = max(klo, 0)
                    b = min(khi, nz - 1)
                    if a <= b:
                        scene_in = prefix[i, j, b + 1, 0] - prefix[i, j, a, 0]
                        occ += prefix[i, j, b + 1, 1] - prefix[i, j, a, 1]
                        sv_all = prefix[i, j, b + 1, 2] - prefix[i, j, a, 2]
                    if n_int > 0:
                        a = max(ilo, 0)
                        b = min(ihi, nz - 1)
                        if a <= b:
                            sv_int = prefix[i, j, b + 1, 2] - prefix[i, j, a, 2]
                out += length - scene_in
                surf += (length - n_int) * qmax - (sv_all - sv_int)
                # double occupancy: union of the other parts' runs clipped to this run
                m = 0
                for rr in range(n_near):
                    r = near[rr]
                    lo_r, hi_r = _run_of(r, i, j, bb, runs)
                    lo_r = max(lo_r, klo)
                    hi_r = min(hi_r, khi)
                    if lo_r > hi_r:
                        continue
                    pos = m  # insertion sort by start
                    while pos > 0 and tmp_lo[pos - 1] > lo_r:
                        tmp_lo[pos] = tmp_lo[pos - 1]
                        tmp_hi[pos] = tmp_hi[pos - 1]
                        pos -= 1
                    tmp_lo[pos] = lo_r
                    tmp_hi[pos] = hi_r
                    m += 1
                if m > 0:
                    cur_lo = tmp_lo[0]
                    cur_hi = tmp_hi[0]
                    for s in range(1, m):
                        if tmp_lo[s] > cur_hi + 1:
                            do += cur_hi - cur_lo + 1
                            cur_lo = tmp_lo[s]
                            cur_hi = tmp_hi[s]
                        elif tmp_hi[s] > cur_hi:
                            cur_hi = tmp_hi[s]
                    do += cur_hi - cur_lo + 1
        counts[q, 0] = n
        counts[q, 1] = out
        counts[q, 2] = do
        counts[q, 3] = occ
        counts[q, 4] = nsurf
        counts[q, 5] = surf


@njit(cache=True, parallel=True)
def part_counts(base, axis, u1, u2, shape, ox, oy, oz, vs, prefix, qmax, n_chunks, counts):
    """Fill ``counts (P, n_parts, 6)`` for every particle, in parallel over chunks of particles.

    ``prefix (nx, ny, nz + 1, 3)`` int32 holds the prefix sums along z of the scene mask, of
    ``V^R`` and of the quantised ``Ṽ^S`` (``qmax`` = the quantised value of 1). Particles are
    dealt round-robin to ``n_chunks`` chunks, each with its own scratch buffers.
    """
    n_particles = base.shape[0]
    n_parts = shape.shape[0]
    nx, ny, nz = prefix.shape[0], prefix.shape[1], prefix.shape[2] - 1
    n_chunks = max(1, min(n_particles, n_chunks))
    for c in prange(n_chunks):
        bb = np.empty((n_parts, 7), np.int64)
        runs = np.empty((4096, 2), np.int64)
        tmp_lo = np.empty(n_parts, np.int64)
        tmp_hi = np.empty(n_parts, np.int64)
        near = np.empty(n_parts, np.int64)
        for p in range(c, n_particles, n_chunks):
            total = _boxes(p, base, axis, u1, u2, shape, ox, oy, oz, vs, bb)
            if total > runs.shape[0]:
                runs = np.empty((2 * total, 2), np.int64)
            _runs(p, base, axis, u1, u2, shape, ox, oy, oz, vs, bb, runs)
            _score(nx, ny, nz, prefix, qmax, bb, runs, near, tmp_lo, tmp_hi, counts[p])


@njit(cache=True)
def rasterise_counts(base, axis, u1, u2, shape, ox, oy, oz, vs, volume):
    """Add 1 per containing part to every voxel of ``volume (nx, ny, nz)`` (uint8), particle 0."""
    n_parts = shape.shape[0]
    nx, ny, nz = volume.shape
    bb = np.empty((n_parts, 7), np.int64)
    total = _boxes(0, base, axis, u1, u2, shape, ox, oy, oz, vs, bb)
    runs = np.empty((max(total, 1), 2), np.int64)
    _runs(0, base, axis, u1, u2, shape, ox, oy, oz, vs, bb, runs)
    for q in range(n_parts):
        nj = bb[q, 3] - bb[q, 2] + 1
        for i in range(max(bb[q, 0], 0), min(bb[q, 1], nx - 1) + 1):
            for j in range(max(bb[q, 2], 0), min(bb[q, 3], ny - 1) + 1):
                idx = bb[q, 6] + (i - bb[q, 0]) * nj + (j - bb[q, 2])
                for k in range(max(runs[idx, 0], 0), min(runs[idx, 1], nz - 1) + 1):
                    volume[i, j, k] += 1
