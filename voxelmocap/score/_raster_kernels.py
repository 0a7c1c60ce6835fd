"""Numba kernels of the per-column interval rasteriser behind :mod:`voxelmocap.score.likelihood`.

Every truncated cone is convex, so its voxels in a lattice column ``(i, j)`` form one run
``k ∈ [klo, khi]`` (DESIGN.md §4). :func:`_column_interval` finds the run from the roots of a
quadratic in z, then decides the voxel nearest to each end with :func:`_inside` — the very
membership test, in the very floating-point operation order, that the per-voxel reference uses —
so the runs are exactly the reference's voxel sets. With per-column prefix sums along z of the
scene mask, of ``V^R`` and of the quantised ``Ṽ^S``, a part's voxel count, Out, Occ and Surf
sums cost O(1) per column; DO counts, in each column where runs meet, the run's layers covered
twice or more; a part's surface voxels are the run ends plus the stretches not covered by all
four neighbour columns' runs.

All lattice indices are *unbounded* (columns and layers outside the grid exist, they are simply
outside the analysed scene). Geometry arrays are float64, ``(P, n_parts, 3)``; ``shape`` is
``(n_parts, 7)`` = ``1/H, 1/W, L, (R − 1)/L, H, W, R``. Counts are int64 ``(P, n_parts, 6)`` =
``|Y|, Out, DO, Occ, |Y^S|, Σ_{Y^S}(Q − Ṽq)``.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import njit, prange

# Widening of the cone inequality in the closed form (dimensionless): a line that only grazes a
# cone still gets a (tiny) run, whose end voxels _inside then decides.
_EPS_Q = 1e-9
# Conditioning thresholds of the closed form. Below _NZ_MIN the axis is treated as horizontal
# (t is decided from tp with tolerance _TP_TOL mm, far above |dz·nz| < 5000 mm · 1e-9). A root is
# trusted when q crosses 0 with slope 2·sqrt(disc) > 2·_SLOPE_MIN / voxel, i.e. when _EPS_Q and
# rounding (≲ 1e-15) move it by far less than a tenth of a voxel. |q| ≤ _Q_MIN counts as zero.
_NZ_MIN = 1e-9
# Voxel centres closer than _DELTA voxel to a closed-form end are decided by _inside.
_DELTA = 0.05
_TP_TOL = 1e-5
_SLOPE_MIN = 1e-7
_Q_MIN = 1e-7
_EPS_IDX = 1e-6
N_COUNTS = 6


@njit(cache=True, inline="always")
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
def _inside_outlined(tp, ap, bp, dz, nz, u1z, u2z, inv_h, inv_w, length, k_r):
    """:func:`_inside` as a real call, for the rare scans (keeps the inlined code small)."""
    return _inside(tp, ap, bp, dz, nz, u1z, u2z, inv_h, inv_w, length, k_r)


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


@njit(cache=True, inline="always")
def _column_interval(tp, ap, bp, nz, u1z, u2z, inv_h, inv_w, length, k_r, bz, oz, vs,
                     kmin, kmax, qa, qb, qc, disc, sq):
    """Exact run ``(klo, khi)`` of one cone in one column; ``klo > khi`` when empty.

    The closed form locates each end of the run. When it is well conditioned (the end comes from
    a slab plane, or from a root crossed at a clear slope) it is good to far better than
    ``_DELTA`` voxel, so the voxel nearest to each end is inside exactly when the end lies beyond
    its centre; only centres within ``_DELTA`` voxel of an end are tested with :func:`_inside`.
    Otherwise (grazing lines, horizontal axes with the column near an end plane, nearly constant
    cases) the column is scanned with :func:`_inside` from both ends.
    """
    # Closed form: the cone inequality is q(dz) = qa dz² + 2 qb dz + qc ≤ 0 on the slab
    # 0 ≤ t ≤ L; dz is measured from the base centre's z. qb, qc (widened by _EPS_Q), the
    # discriminant and its square root (of max(disc, 0)) come from _row_terms.
    lo = (kmin + 0.5) * vs + oz - bz - vs
    hi = (kmax + 0.5) * vs + oz - bz + vs
    lo_ok = False  # does the end come from a well-conditioned constraint?
    hi_ok = False
    walk = False
    if abs(nz) >= _NZ_MIN:
        inv_nz = 1.0 / nz  # loop-invariant: hoisted out of the column loops once inlined
        za = -tp * inv_nz
        zb = (length - tp) * inv_nz
        lo_ok = min(za, zb) > lo
        hi_ok = max(za, zb) < hi
        lo = max(lo, min(za, zb))
        hi = min(hi, max(za, zb))
    else:
        # t = tp + dz·nz hardly varies along the column (and rounds to tp in _inside when
        # |dz·nz| is below tp's last bit): decide from tp, or walk when tp is near 0 or L
        if tp < -_TP_TOL or tp > length + _TP_TOL:
            return 1, 0
        if tp < _TP_TOL or tp > length - _TP_TOL:
            walk = True
    if lo > hi:
        return 1, 0
    slope_min = _SLOPE_MIN / vs
    inv_qa = 1.0 / qa if qa != 0.0 else 0.0  # loop-invariant (qa depends on the part only)
    if qa > 0.0:
        if disc < 0.0:
            return 1, 0
        root_ok = sq > slope_min
        qq = -(qb + math.copysign(sq, qb))
        if qq == 0.0:
            r1 = r2 = -qb * inv_qa
        else:
            r1 = min(qq * inv_qa, qc / qq)
            r2 = max(qq * inv_qa, qc / qq)
        # selects rather than branches: which constraint binds varies from column to column
        lo_ok = root_ok if r1 > lo else lo_ok
        hi_ok = root_ok if r2 < hi else hi_ok
        lo = max(lo, r1)
        hi = min(hi, r2)
    elif qa < 0.0:
        if disc >= 0.0:
            root_ok = sq > slope_min
            qq = -(qb + math.copysign(sq, qb))
            if qq == 0.0:
                rs = rb = -qb * inv_qa
            else:
                rs = min(qq * inv_qa, qc / qq)
                rb = max(qq * inv_qa, qc / qq)
            piece_a = min(hi, rs) >= lo
            piece_b = max(lo, rb) <= hi
            if piece_a and not piece_b:
                if rb < hi + vs:  # the other piece is not clearly out
                    walk = True
                if rs < hi:
                    hi = rs
                    hi_ok = root_ok
            elif piece_b and not piece_a:
                if rs > lo - vs:
                    walk = True
                if rb > lo:
                    lo = rb
                    lo_ok = root_ok
            elif not piece_a and not piece_b:
                if rs > lo - vs or rb < hi + vs:
                    walk = True
                else:
                    return 1, 0
            else:
                walk = True
        elif -disc < -qa * _Q_MIN:  # q < 0 everywhere, but its maximum is close to 0
            walk = True
    else:
        if abs(qb) * vs > _Q_MIN:
            r = -qc / (2.0 * qb)
            if qb > 0.0 and r < hi:
                hi = r
                hi_ok = True
            elif qb < 0.0 and r > lo:
                lo = r
                lo_ok = True
        elif abs(qc) > _Q_MIN:
            if qc > 0.0:
                return 1, 0
        else:
            walk = True
    if lo > hi and not walk:
        return 1, 0
    inv_vs = 1.0 / vs
    kf_lo = (lo + bz - oz) * inv_vs - 0.5
    kf_hi = (hi + bz - oz) * inv_vs - 0.5
    if lo_ok and hi_ok and not walk:
        # the nearest voxel to each end: the closed form decides it when the end is more than
        # _DELTA voxel from its centre (the closed form is good to ~_DELTA / 10), _inside otherwise
        klo = max(int(math.floor(kf_lo + 0.5)), kmin)
        khi = min(int(math.floor(kf_hi + 0.5)), kmax)
        if klo > khi:
            return 1, 0
        d_lo = klo - kf_lo
        d_hi = kf_hi - khi
        # branch-free in the common case: the rare near-centre ends take the predictable branch
        in_lo = d_lo >= 0.0
        if abs(d_lo) <= _DELTA:
            in_lo = _inside(tp, ap, bp, oz + (klo + 0.5) * vs - bz, nz, u1z, u2z, inv_h, inv_w,
                            length, k_r)
        in_hi = d_hi >= 0.0
        if abs(d_hi) <= _DELTA:
            in_hi = _inside(tp, ap, bp, oz + (khi + 0.5) * vs - bz, nz, u1z, u2z, inv_h, inv_w,
                            length, k_r)
        if khi == klo:
            return (klo, klo) if in_lo and in_hi else (1, 0)
        return (klo if in_lo else klo + 1), (khi if in_hi else khi - 1)
    # uncertain closed form: scan the box column with the exact test from both ends
    if walk:
        klo = kmin
        khi = kmax
    else:
        klo = max(int(math.ceil(max(kf_lo, kmin - 1.0))) - 1, kmin)
        khi = min(int(math.floor(min(kf_hi, kmax + 1.0))) + 1, kmax)
    while klo <= khi and not _inside_outlined(tp, ap, bp, oz + (klo + 0.5) * vs - bz, nz, u1z,
                                              u2z, inv_h, inv_w, length, k_r):
        klo += 1
    while khi >= klo and not _inside_outlined(tp, ap, bp, oz + (khi + 0.5) * vs - bz, nz, u1z,
                                              u2z, inv_h, inv_w, length, k_r):
        khi -= 1
    if klo > khi:
        return 1, 0
    while klo > kmin and _inside_outlined(tp, ap, bp, oz + (klo - 0.5) * vs - bz, nz, u1z, u2z,
                                          inv_h, inv_w, length, k_r):
        klo -= 1
    while khi < kmax and _inside_outlined(tp, ap, bp, oz + (khi + 1.5) * vs - bz, nz, u1z, u2z,
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
def _runs(p, base, axis, u1, u2, shape, ox, oy, oz, vs, bb, runs, terms):
    """Runs of every part of particle ``p`` in every column of its box, into ``runs (·, 2)``;
    ``terms (7, ·)`` is row scratch (returned, reallocated if too short)."""
    for q in range(shape.shape[0]):
        inv_h, inv_w, length, k_r = shape[q, 0], shape[q, 1], shape[q, 2], shape[q, 3]
        bx, by, bz = base[p, q, 0], base[p, q, 1], base[p, q, 2]
        nx_, ny_, nz_ = axis[p, q, 0], axis[p, q, 1], axis[p, q, 2]
        ax, ay, az = u1[p, q, 0], u1[p, q, 1], u1[p, q, 2]
        cx, cy, cz = u2[p, q, 0], u2[p, q, 1], u2[p, q, 2]
        i0, i1, j0, j1, k0, k1, off = bb[q, 0], bb[q, 1], bb[q, 2], bb[q, 3], bb[q, 4], \
            bb[q, 5], bb[q, 6]
        nj = j1 - j0 + 1
        a1 = az * inv_h
        b1 = cz * inv_w
        s1 = k_r * nz_
        qa = a1 * a1 + b1 * b1 - s1 * s1
        if terms.shape[1] < nj:
            terms = np.empty((7, 2 * nj))
        for i in range(i0, i1 + 1):
            dx = ox + (i + 0.5) * vs - bx
            _row_terms(dx, oy, vs, by, j0, nj, nx_, ny_, ax, ay, cx, cy, inv_h, inv_w, k_r,
                       a1, b1, s1, qa, terms)
            row = off + (i - i0) * nj
            for jj in range(nj):
                klo, khi = _column_interval(terms[0, jj], terms[1, jj], terms[2, jj], nz_, az,
                                            cz, inv_h, inv_w, length, k_r, bz, oz, vs, k0, k1,
                                            qa, terms[3, jj], terms[4, jj], terms[5, jj],
                                            terms[6, jj])
                runs[row + jj, 0] = klo
                runs[row + jj, 1] = khi
    return terms


@njit(cache=True, inline="always")
def _row_terms(dx, oy, vs, by, j0, nj, nx_, ny_, ax, ay, cx, cy, inv_h, inv_w, k_r, a1, b1, s1,
               qa, terms):
    """Branch-free per-column terms of one row (a loop the compiler can vectorise):
    ``tp, ap, bp`` (the exact partial sums _inside uses), ``qb``, ``qc``, ``disc``, ``sqrt``."""
    for jj in range(nj):
        dy = oy + (j0 + jj + 0.5) * vs - by
        tp = dx * nx_ + dy * ny_
        ap = dx * ax + dy * ay
        bp = dx * cx + dy * cy
        a0 = ap * inv_h
        b0 = bp * inv_w
        s0 = 1.0 + k_r * tp
        qb = a0 * a1 + b0 * b1 - s0 * s1
        qc = a0 * a0 + b0 * b0 - s0 * s0 - _EPS_Q
        disc = qb * qb - qa * qc
        terms[0, jj] = tp
        terms[1, jj] = ap
        terms[2, jj] = bp
        terms[3, jj] = qb
        terms[4, jj] = qc
        terms[5, jj] = disc
        terms[6, jj] = math.sqrt(max(disc, 0.0))


@njit(cache=True)
def _union_columns(bb):
    """Number of columns of the union box (in x-y) of all parts' boxes."""
    return ((bb[:, 1].max() - bb[:, 0].min() + 1) * (bb[:, 3].max() - bb[:, 2].min() + 1))


@njit(cache=True, inline="always")
def _run_of(q, i, j, bb, runs):
    if i < bb[q, 0] or i > bb[q, 1] or j < bb[q, 2] or j > bb[q, 3]:
        return 1, 0
    idx = bb[q, 6] + (i - bb[q, 0]) * (bb[q, 3] - bb[q, 2] + 1) + (j - bb[q, 2])
    return runs[idx, 0], runs[idx, 1]


@njit(cache=True)
def _score(lattice, prefix, qmax, bb, runs, cover, cover_n, multi, counts):
    """Counts of every part of one particle into ``counts (n_parts, 6)``, except DO; fills
    ``cover``/``cover_n`` (see :func:`_double_occupancy`) and returns how many columns of
    ``multi`` have two runs or more.

    ``lattice = (nx, ny, nz, i0, j0)``: the grid's shape and the first column of ``prefix``,
    which holds the columns ``[i0, i0 + ni) × [j0, j0 + nj)``; in every other column of the
    grid nothing is occupied, the smoothed surface is 0 and the whole column is in the scene.
    """
    nx, ny, nz, pi0, pj0 = lattice[0], lattice[1], lattice[2], lattice[3], lattice[4]
    pni, pnj = prefix.shape[0], prefix.shape[1]
    n_parts = bb.shape[0]
    ui0 = bb[0, 0]
    uj0 = bb[0, 2]
    uj1 = bb[0, 3]
    for q in range(1, n_parts):
        ui0 = min(ui0, bb[q, 0])
        uj0 = min(uj0, bb[q, 2])
        uj1 = max(uj1, bb[q, 3])
    nuj = uj1 - uj0 + 1
    cover_n[:_union_columns(bb)] = 0
    n_multi = 0
    for q in range(n_parts):
        n = 0
        out = 0
        occ = 0
        nsurf = 0
        surf = 0
        i0, i1, j0, j1 = bb[q, 0], bb[q, 1], bb[q, 2], bb[q, 3]
        nj = j1 - j0 + 1
        off = bb[q, 6]
        for i in range(i0, i1 + 1):
            row = off + (i - i0) * nj - j0
            crow = (i - ui0) * nuj - uj0
            inside_i = 0 <= i < nx
            for j in range(j0, j1 + 1):
                idx = row + j
                klo = runs[idx, 0]
                khi = runs[idx, 1]
                if klo > khi:
                    continue
                # register the run for the double-occupancy pass
                c = crow + j
                m = cover_n[c]
                cover[c, m, 0] = q
                cover[c, m, 1] = klo
                cover[c, m, 2] = khi
                cover_n[c] = m + 1
                if m == 1:
                    multi[n_multi] = c
                    n_multi += 1
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
                if inside_i and 0 <= j < ny:
                    a = max(klo, 0)
                    b = min(khi, nz - 1)
                    pi = i - pi0
                    pj = j - pj0
                    if 0 <= pi < pni and 0 <= pj < pnj:
                        if a <= b:
                            scene_in = prefix[pi, pj, b + 1, 0] - prefix[pi, pj, a, 0]
                            occ += prefix[pi, pj, b + 1, 1] - prefix[pi, pj, a, 1]
                            sv_all = prefix[pi, pj, b + 1, 2] - prefix[pi, pj, a, 2]
                        if n_int > 0:
                            a = max(ilo, 0)
                            b = min(ihi, nz - 1)
                            if a <= b:
                                sv_int = prefix[pi, pj, b + 1, 2] - prefix[pi, pj, a, 2]
                    elif a <= b:
                        scene_in = b - a + 1  # an empty column wholly in the scene
                out += length - scene_in
                surf += (length - n_int) * qmax - (sv_all - sv_int)
        counts[q, 0] = n
        counts[q, 1] = out
        counts[q, 2] = 0
        counts[q, 3] = occ
        counts[q, 4] = nsurf
        counts[q, 5] = surf
    return n_multi


@njit(cache=True, inline="always")
def _insert_by_start(lo, hi, m, a, b):
    """Insert the interval ``[a, b]`` into ``lo[:m], hi[:m]``, kept sorted by start (insertion
    sort: a column holds a handful of runs). Stable: equal starts keep their order."""
    pos = m
    while pos > 0 and lo[pos - 1] > a:
        lo[pos] = lo[pos - 1]
        hi[pos] = hi[pos - 1]
        pos -= 1
    lo[pos] = a
    hi[pos] = b


@njit(cache=True)
def _double_occupancy(cover, cover_n, multi, n_multi, tmp_lo, tmp_hi, run_lo, run_hi, counts):
    """DO counts (``counts[:, 2]``).

    ``cover (·, n_parts, 3)`` holds, per column of the union box of the parts' boxes, the parts
    with a run there (part, klo, khi; ``cover_n`` how many); ``multi[:n_multi]`` lists the
    columns with two runs or more. In each of them: the layers covered twice or more (S2), and
    for each part the length of its run inside S2.
    """
    for mm in range(n_multi):
        c = multi[mm]
        m = cover_n[c]
        # the column's runs sorted by start
        for a in range(m):
            _insert_by_start(run_lo, run_hi, a, cover[c, a, 1], cover[c, a, 2])
        # S2 = layers inside two runs or more = ∪_b [lo_b, min(hi_b, reach before b)],
        # produced in increasing order and merged on the fly
        n2 = 0
        reach = run_hi[0]
        for b in range(1, m):
            lo_s = run_lo[b]
            hi_s = min(run_hi[b], reach)
            if lo_s <= hi_s:
                if n2 > 0 and lo_s <= tmp_hi[n2 - 1] + 1:
                    tmp_hi[n2 - 1] = max(tmp_hi[n2 - 1], hi_s)
                else:
                    tmp_lo[n2] = lo_s
                    tmp_hi[n2] = hi_s
                    n2 += 1
            reach = max(reach, run_hi[b])
        if n2 == 0:
            continue
        # DO of a part: its run's layers in S2 (eq 4: voxels whose count exceeds 1)
        for a in range(m):
            q = cover[c, a, 0]
            klo = cover[c, a, 1]
            khi = cover[c, a, 2]
            do = 0
            for t in range(n2):
                lo_s = max(tmp_lo[t], klo)
                hi_s = min(tmp_hi[t], khi)
                if lo_s <= hi_s:
                    do += hi_s - lo_s + 1
            counts[q, 2] += do


def default_chunks() -> int:
    """Number of particle chunks for :func:`part_counts`: one per numba thread."""
    return numba.get_num_threads()


@njit(cache=True, parallel=True)
def part_counts(base, axis, u1, u2, shape, ox, oy, oz, vs, prefix, lattice, qmax, n_chunks,
                counts):
    """Fill ``counts (P, n_parts, 6)`` for every particle, in parallel over chunks of particles.

    ``prefix (ni, nj, nz + 1, 3)`` int32 holds the prefix sums along z of the scene mask, of
    ``V^R`` and of the quantised ``Ṽ^S`` (``qmax`` = the quantised value of 1) over the columns
    that need them, ``lattice`` where they are (see :func:`_score`). Particles are dealt
    round-robin to ``n_chunks`` chunks, each with its own scratch buffers.
    """
    n_particles = base.shape[0]
    n_parts = shape.shape[0]
    n_chunks = max(1, min(n_particles, n_chunks))
    for c in prange(n_chunks):
        bb = np.empty((n_parts, 7), np.int64)
        # scratch sized for a typical particle at 20 mm voxels; grown on demand
        runs = np.empty((2048, 2), np.int64)
        tmp_lo = np.empty(n_parts, np.int64)
        tmp_hi = np.empty(n_parts, np.int64)
        run_lo = np.empty(n_parts, np.int64)
        run_hi = np.empty(n_parts, np.int64)
        cover = np.empty((2048, n_parts, 3), np.int64)
        cover_n = np.empty(2048, np.int64)
        multi = np.empty(2048, np.int64)
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
            n_multi = _score(lattice, prefix, qmax, bb, runs, cover, cover_n, multi,
                             counts[p])
            _double_occupancy(cover, cover_n, multi, n_multi, tmp_lo, tmp_hi, run_lo, run_hi,
                              counts[p])


@njit(cache=True)
def rasterise_counts(base, axis, u1, u2, shape, ox, oy, oz, vs, volume):
    """Add 1 per containing part to every voxel of ``volume (nx, ny, nz)`` (uint8), particle 0."""
    n_parts = shape.shape[0]
    nx, ny, nz = volume.shape
    bb = np.empty((n_parts, 7), np.int64)
    total = _boxes(0, base, axis, u1, u2, shape, ox, oy, oz, vs, bb)
    runs = np.empty((max(total, 1), 2), np.int64)
    _runs(0, base, axis, u1, u2, shape, ox, oy, oz, vs, bb, runs, np.empty((7, 256)))
    for q in range(n_parts):
        nj = bb[q, 3] - bb[q, 2] + 1
        for i in range(max(bb[q, 0], 0), min(bb[q, 1], nx - 1) + 1):
            for j in range(max(bb[q, 2], 0), min(bb[q, 3], ny - 1) + 1):
                idx = bb[q, 6] + (i - bb[q, 0]) * nj + (j - bb[q, 2])
                for k in range(max(runs[idx, 0], 0), min(runs[idx, 1], nz - 1) + 1):
                    volume[i, j, k] += 1
