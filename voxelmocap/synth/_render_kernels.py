"""Numba kernels of the synthetic renderer: ray casting of capsules/ellipsoids and floor shadows.

Pure functions on arrays (no Python objects, no randomness). Rays come from a per-camera table of
unit directions (the lens distortion is inverted once per camera, so projection is exact through
the full camera model); each pixel of a region of interest keeps the nearest hit among all
primitives and the static background (whose depth is given), so occlusion between body parts
and by static objects is exact.

The kernels are serial on purpose: one image's work is 1–3 ms, and on a shared 2-core machine
``parallel=True`` made a whole sequence 3–4 times slower (wall and CPU) because the worker threads
wait for each other on every call (measured with ``scripts/bench_synth.py``-style runs:
40 frames × 7 cameras, 4.4 s with one thread against 18 s with two).
"""

from __future__ import annotations

import math

import numba
import numpy as np

__all__ = ["cast_body", "expose", "floor_shadow", "ray_capsule", "ray_ellipsoid"]


@numba.njit(cache=True, inline="always")
def ray_capsule(ox, oy, oz, dx, dy, dz, cap):
    """Distance along a unit ray to a capsule ``cap = (ax, ay, az, bx, by, bz, r)``; −1 if missed."""
    ax, ay, az, bx, by, bz, r = cap[0], cap[1], cap[2], cap[3], cap[4], cap[5], cap[6]
    bax, bay, baz = bx - ax, by - ay, bz - az
    oax, oay, oaz = ox - ax, oy - ay, oz - az
    baba = bax * bax + bay * bay + baz * baz
    bard = bax * dx + bay * dy + baz * dz
    baoa = bax * oax + bay * oay + baz * oaz
    rdoa = dx * oax + dy * oay + dz * oaz
    oaoa = oax * oax + oay * oay + oaz * oaz
    a = baba - bard * bard
    b = baba * rdoa - baoa * bard
    c = baba * oaoa - baoa * baoa - r * r * baba
    h = b * b - a * c
    if a > 1e-9 * baba and h >= 0.0:
        t = (-b - math.sqrt(h)) / a
        y = baoa + t * bard
        if 0.0 < y < baba:
            return t
    # The spherical caps (also the whole capsule when the ray runs along its axis).
    best = -1.0
    for k in range(2):
        cx, cy, cz = (ax, ay, az) if k == 0 else (bx, by, bz)
        px, py, pz = ox - cx, oy - cy, oz - cz
        bb = dx * px + dy * py + dz * pz
        cc = px * px + py * py + pz * pz - r * r
        hh = bb * bb - cc
        if hh >= 0.0:
            t = -bb - math.sqrt(hh)
            if t > 0.0 and (best < 0.0 or t < best):
                best = t
    return best


@numba.njit(cache=True, inline="always")
def ray_ellipsoid(ox, oy, oz, dx, dy, dz, ell):
    """Distance along a ray to an ellipsoid ``ell = (c(3), A(9) row-major)``; −1 if missed."""
    px, py, pz = ox - ell[0], oy - ell[1], oz - ell[2]
    qx = ell[3] * px + ell[4] * py + ell[5] * pz
    qy = ell[6] * px + ell[7] * py + ell[8] * pz
    qz = ell[9] * px + ell[10] * py + ell[11] * pz
    ex = ell[3] * dx + ell[4] * dy + ell[5] * dz
    ey = ell[6] * dx + ell[7] * dy + ell[8] * dz
    ez = ell[9] * dx + ell[10] * dy + ell[11] * dz
    a = ex * ex + ey * ey + ez * ez
    b = qx * ex + qy * ey + qz * ez
    c = qx * qx + qy * qy + qz * qz - 1.0
    h = b * b - a * c
    if h < 0.0:
        return -1.0
    t = (-b - math.sqrt(h)) / a
    return t if t > 0.0 else -1.0


@numba.njit(cache=True)
def cast_body(rays, origin, roi, capsules, cap_colours, cap_boxes, ellipsoids, ell_colours,
              ell_boxes, bg_depth, light, ambient, image, mask, depth):
    """Ray-cast the body into ``image`` over a region of interest.

    Parameters
    ----------
    rays : (H, W, 3) float32
        Unit world directions of every pixel.
    origin : (3,) float64
        Camera centre (mm).
    roi : (4,) int64
        ``u0, u1, v0, v1`` pixel bounds (half-open).
    capsules, cap_colours, ellipsoids, ell_colours : float64 arrays
        See :class:`voxelmocap.synth.body_shape.Primitives`.
    cap_boxes, ell_boxes : (Nc, 4), (Ne, 4) int64
        ``u0, u1, v0, v1`` pixel box outside which a primitive cannot appear (skipped there).
    bg_depth : (H, W) float32
        Distance (mm) to the static background along each ray; the body must be nearer.
    light : (3,) float64
        Unit vector towards the light.
    ambient : float
        Ambient share of the illumination (0..1).
    image : (H, W, 3) float32
        Background radiance, overwritten where the body is hit (in/out).
    mask : (H, W) bool
        Set True where the body is visible (out).
    depth : (H, W) float32
        Distance to the body where visible (out).
    """
    u0, u1, v0, v1 = roi[0], roi[1], roi[2], roi[3]
    ox, oy, oz = origin[0], origin[1], origin[2]
    nc = capsules.shape[0]
    ne = ellipsoids.shape[0]
    for v in range(v0, v1):
        for u in range(u0, u1):
            dx, dy, dz = rays[v, u, 0], rays[v, u, 1], rays[v, u, 2]
            best = bg_depth[v, u]
            kind = -1
            idx = -1
            for i in range(nc):
                if u < cap_boxes[i, 0] or u >= cap_boxes[i, 1] or v < cap_boxes[i, 2] \
                        or v >= cap_boxes[i, 3]:
                    continue
                t = ray_capsule(ox, oy, oz, dx, dy, dz, capsules[i])
                if 0.0 < t < best:
                    best, kind, idx = t, 0, i
            for i in range(ne):
                if u < ell_boxes[i, 0] or u >= ell_boxes[i, 1] or v < ell_boxes[i, 2] \
                        or v >= ell_boxes[i, 3]:
                    continue
                t = ray_ellipsoid(ox, oy, oz, dx, dy, dz, ellipsoids[i])
                if 0.0 < t < best:
                    best, kind, idx = t, 1, i
            if kind < 0:
                continue
            px, py, pz = ox + best * dx, oy + best * dy, oz + best * dz
            if kind == 0:
                cap = capsules[idx]
                bax, bay, baz = cap[3] - cap[0], cap[4] - cap[1], cap[5] - cap[2]
                s = ((px - cap[0]) * bax + (py - cap[1]) * bay + (pz - cap[2]) * baz) / max(
                    bax * bax + bay * bay + baz * baz, 1e-12)
                s = min(max(s, 0.0), 1.0)
                nx = px - (cap[0] + s * bax)
                ny = py - (cap[1] + s * bay)
                nz = pz - (cap[2] + s * baz)
                col = cap_colours[idx]
            else:
                e = ellipsoids[idx]
                qx = e[3] * (px - e[0]) + e[4] * (py - e[1]) + e[5] * (pz - e[2])
                qy = e[6] * (px - e[0]) + e[7] * (py - e[1]) + e[8] * (pz - e[2])
                qz = e[9] * (px - e[0]) + e[10] * (py - e[1]) + e[11] * (pz - e[2])
                # gradient of |A(p - c)|² ∝ Aᵀ A (p − c)
                nx = e[3] * qx + e[6] * qy + e[9] * qz
                ny = e[4] * qx + e[7] * qy + e[10] * qz
                nz = e[5] * qx + e[8] * qy + e[11] * qz
                col = ell_colours[idx]
            nn = math.sqrt(nx * nx + ny * ny + nz * nz) + 1e-12
            lam = (nx * light[0] + ny * light[1] + nz * light[2]) / nn
            # Lambert with one light plus ambient; a faint wrap term keeps the shadow side round.
            shade = ambient + (1.0 - ambient) * max(lam, 0.0) + 0.08 * (1.0 + lam) * 0.5
            for ch in range(3):
                image[v, u, ch] = col[ch] * shade
            mask[v, u] = True
            depth[v, u] = best


@numba.njit(cache=True)
def floor_shadow(floor_points, is_floor, roi, capsules, ellipsoids, ell_radius, cap_cull,
                 ell_cull, light, strength, image):
    """Darken floor pixels shadowed by the body, with a penumbra growing with distance.

    Parameters
    ----------
    floor_points : (H, W, 3) float32
        World point (mm) seen by each pixel where the background is floor.
    is_floor : (H, W) bool
        Pixels whose background is the floor.
    roi : (4,) int64
        ``u0, u1, v0, v1`` bounds.
    capsules, ellipsoids : float64 arrays
        Body primitives.
    ell_radius : (Ne,) float64
        Mean semi-axis of each ellipsoid (mm), to express its distance in mm.
    cap_cull, ell_cull : (Nc, 3), (Ne, 3) float64
        ``cx, cy, R``: a floor disc outside which a primitive casts no shadow (skipped there).
    light : (3,) float64
        Unit vector towards the light.
    strength : float
        Darkening of a fully shadowed pixel (0..1).
    image : (H, W, 3) float32
        Background radiance, darkened in place.
    """
    u0, u1, v0, v1 = roi[0], roi[1], roi[2], roi[3]
    lx, ly, lz = light[0], light[1], light[2]
    for v in range(v0, v1):
        for u in range(u0, u1):
            if not is_floor[v, u]:
                continue
            x, y, z = floor_points[v, u, 0], floor_points[v, u, 1], floor_points[v, u, 2]
            occl = 0.0
            for i in range(capsules.shape[0]):
                gx, gy = x - cap_cull[i, 0], y - cap_cull[i, 1]
                if gx * gx + gy * gy > cap_cull[i, 2] * cap_cull[i, 2]:
                    continue
                c = capsules[i]
                # closest approach between the light ray x + s·L (s ≥ 0) and segment AB
                ax, ay, az = c[0] - x, c[1] - y, c[2] - z
                bx, by, bz = c[3] - c[0], c[4] - c[1], c[5] - c[2]
                bb = bx * bx + by * by + bz * bz
                lb = lx * bx + ly * by + lz * bz
                la = lx * ax + ly * ay + lz * az
                ba = bx * ax + by * ay + bz * az
                den = bb - lb * lb
                w = 0.0 if den < 1e-9 else min(max((lb * la - ba) / den, 0.0), 1.0)
                s = max(la + w * lb, 0.0)
                w = min(max((s * lb - ba) / max(bb, 1e-9), 0.0), 1.0)
                qx = ax + w * bx - s * lx
                qy = ay + w * by - s * ly
                qz = az + w * bz - s * lz
                d = math.sqrt(qx * qx + qy * qy + qz * qz)
                k = 12.0 + 0.10 * s
                o = (c[6] + k - d) / (2.0 * k)
                occl = max(occl, min(max(o, 0.0), 1.0))
            for i in range(ellipsoids.shape[0]):
                gx, gy = x - ell_cull[i, 0], y - ell_cull[i, 1]
                if gx * gx + gy * gy > ell_cull[i, 2] * ell_cull[i, 2]:
                    continue
                e = ellipsoids[i]
                px, py, pz = x - e[0], y - e[1], z - e[2]
                qx = e[3] * px + e[4] * py + e[5] * pz
                qy = e[6] * px + e[7] * py + e[8] * pz
                qz = e[9] * px + e[10] * py + e[11] * pz
                ex = e[3] * lx + e[4] * ly + e[5] * lz
                ey = e[6] * lx + e[7] * ly + e[8] * lz
                ez = e[9] * lx + e[10] * ly + e[11] * lz
                ee = ex * ex + ey * ey + ez * ez
                s = max(-(qx * ex + qy * ey + qz * ez) / ee, 0.0)
                dx, dy, dz = qx + s * ex, qy + s * ey, qz + s * ez
                d = (math.sqrt(dx * dx + dy * dy + dz * dz) - 1.0) * ell_radius[i]
                k = 12.0 + 0.10 * s  # s is in mm: L is a unit vector in the world
                o = (k - d) / (2.0 * k)
                occl = max(occl, min(max(o, 0.0), 1.0))
            f = 1.0 - strength * occl
            for ch in range(3):
                image[v, u, ch] *= f


@numba.njit(cache=True, inline="always")
def _mix64(z):
    """SplitMix64 finaliser: a well-mixed 64-bit hash of a counter."""
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return z ^ (z >> np.uint64(31))


@numba.njit(cache=True)
def expose(radiance, scale, sigma, table, seed, out):
    """Sensor response: ``out = clip(radiance · scale + sigma · n + 0.5)`` as uint8.

    Parameters
    ----------
    radiance : (H, W, C) float32
        C = 3 (colour) or 1 (grey, written to all three output channels).
    scale : float
        Grey level of radiance 1 times this frame's gain.
    sigma : float
        Noise standard deviation (grey levels).
    table : (M,) float32
        Standard normal draws, M a power of two (small enough to stay in cache). Each pixel and
        channel takes the entry indexed by the top bits of a xorshift64 stream (one per image row,
        seeded by a hash of ``seed`` and the row): independent noise from the table's empirical
        normal distribution, deterministic for a seed, no shared RNG state between threads.
    seed : uint64
        This image's noise seed.
    out : (H, W, 3) uint8
        Output image.
    """
    H, W, C = radiance.shape
    shift = np.uint64(64 - int(np.log2(table.shape[0])))
    golden = np.uint64(0x9E3779B97F4A7C15)
    for v in range(H):
        # one xorshift64 stream per row, seeded by a hash of (seed, row): reproducible
        state = _mix64(seed + np.uint64(v + 1) * golden) | np.uint64(1)
        for u in range(W):
            for ch in range(C):
                state ^= state << np.uint64(13)
                state ^= state >> np.uint64(7)
                state ^= state << np.uint64(17)
                n = table[state >> shift]
                x = radiance[v, u, ch] * scale + sigma * n + 0.5
                x = min(max(x, 0.0), 255.0)
                if C == 1:
                    out[v, u, 0] = out[v, u, 1] = out[v, u, 2] = np.uint8(x)
                else:
                    out[v, u, ch] = np.uint8(x)
