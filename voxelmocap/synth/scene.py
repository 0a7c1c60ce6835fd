"""The static scene around the subject: a textured room with furniture, one light, and the camera noise.

The room is a box (floor at Z = 0, walls and ceiling around every camera of the rig) with
procedural textures evaluated at the ray hit points: floor tiles with grout, per-tile shade, fine
grain and a rug; painted walls with a skirting board, a horizontal band and posters; a few boxes
(cabinets, crates, a table-like block) placed outside the capture area, which may occlude the
subject in some views and cast static shadows on the floor. Everything is lit by one directional
light plus ambient, the same light that shades the subject and casts its soft floor shadow.

:class:`Scene` renders, per camera, the background radiance ``(H, W, 3)``, its depth along each
ray (for occlusion), the floor points and a floor mask (for the subject's shadow).
:func:`sensor` turns radiance into 8-bit frames with per-frame gain flicker, a slight optical blur
and Gaussian sensor noise, grey for BW cameras.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

__all__ = ["LIGHT", "Scene", "sensor"]

#: Unit vector towards the (directional) light, from above and one side.
LIGHT = np.array([0.35, -0.25, 1.0]) / np.linalg.norm([0.35, -0.25, 1.0])
AMBIENT = 0.42


def _max3(a):
    # column-wise: much faster than a.max(axis=1) on (N, 3) arrays
    return np.maximum(np.maximum(a[:, 0], a[:, 1]), a[:, 2])


def _min3(a):
    return np.minimum(np.minimum(a[:, 0], a[:, 1]), a[:, 2])


def _hash(ix, iy, seed):
    """Deterministic pseudo-random values in [0, 1) for integer lattice points (any shape)."""
    h = (np.asarray(ix, dtype=np.int64) * 73856093) ^ (np.asarray(iy, dtype=np.int64) * 19349663) \
        ^ (seed * 83492791)
    h = (h ^ (h >> 13)) * 1274126177
    h = h ^ (h >> 16)
    return (h & 0xFFFFFF).astype(np.float64) / float(0x1000000)


def _value_noise(x, y, cell, seed):
    """Smooth value noise in [0, 1) on a lattice of ``cell`` mm (bilinear, smoothstep-weighted)."""
    gx, gy = x / cell, y / cell
    ix, iy = np.floor(gx), np.floor(gy)
    fx, fy = gx - ix, gy - iy
    fx, fy = fx * fx * (3 - 2 * fx), fy * fy * (3 - 2 * fy)
    ix, iy = ix.astype(np.int64), iy.astype(np.int64)
    v00, v10 = _hash(ix, iy, seed), _hash(ix + 1, iy, seed)
    v01, v11 = _hash(ix, iy + 1, seed), _hash(ix + 1, iy + 1, seed)
    return (v00 * (1 - fx) + v10 * fx) * (1 - fy) + (v01 * (1 - fx) + v11 * fx) * fy


def _blocks_view(centre, size, cameras, keep_clear) -> bool:
    """True when a footprint (grown by 300 mm) enters any camera's floor wedge onto the capture box."""
    box = np.array([[sx * keep_clear[0], sy * keep_clear[1]] for sx in (-1, 1) for sy in (-1, 1)])
    half = np.asarray(size) / 2 + 300.0
    probe = np.array([[centre[0] + a * half[0], centre[1] + b * half[1]]
                      for a in (-1, 0, 1) for b in (-1, 0, 1)], dtype=np.float32)
    for cam in cameras:
        hull = cv2.convexHull(np.vstack([box, cam[None, :2]]).astype(np.float32))
        if any(cv2.pointPolygonTest(hull, (float(x), float(y)), False) >= 0 for x, y in probe):
            return True
    return False


@dataclass
class Box:
    """An axis-aligned box (mm) with a BGR colour."""

    lo: np.ndarray
    hi: np.ndarray
    colour: np.ndarray


@dataclass
class Scene:
    """A room around the rig.

    Parameters
    ----------
    room_lo, room_hi : (3,) array_like
        Opposite corners of the room box (mm); the floor is at Z = 0.
    boxes : list of Box
        Static objects.
    seed : int
        Texture seed.
    """

    room_lo: np.ndarray
    room_hi: np.ndarray
    boxes: list[Box] = field(default_factory=list)
    seed: int = 0

    @classmethod
    def around(cls, centres, *, seed: int = 0, keep_clear=(2000.0, 1500.0)) -> Scene:
        """A room enclosing the camera centres ``(N, 3)`` with 5 objects outside the capture area.

        Objects are kept out of ``|x| < keep_clear[0]``, ``|y| < keep_clear[1]`` (mm) and away from
        the cameras, so the subject never intersects them.
        """
        centres = np.asarray(centres, dtype=float).reshape(-1, 3)
        rng = np.random.default_rng(seed)
        lo = np.minimum(centres.min(axis=0) - 1500.0, [-5000.0, -5000.0, 0.0])
        hi = np.maximum(centres.max(axis=0) + 1500.0, [5000.0, 5000.0, 3000.0])
        lo[2] = 0.0
        hi[2] = max(hi[2], 3200.0)
        boxes = []
        palette = [(0.20, 0.30, 0.45), (0.55, 0.50, 0.40), (0.15, 0.35, 0.25), (0.60, 0.62, 0.65),
                   (0.25, 0.22, 0.50), (0.40, 0.45, 0.20)]
        tries = 0
        while len(boxes) < 5 and tries < 500:
            tries += 1
            ang = rng.uniform(0, 2 * np.pi)
            rad = rng.uniform(2600, 4300)
            c = np.array([rad * np.cos(ang), rad * np.sin(ang)])
            size = rng.uniform([400, 400, 500], [1100, 900, 1900])
            if np.any(np.abs(c) + size[:2] / 2 > np.array([hi[0], hi[1]]) - 200):
                continue
            if abs(c[0]) < keep_clear[0] + size[0] / 2 and abs(c[1]) < keep_clear[1] + size[1] / 2:
                continue
            if np.min(np.linalg.norm(centres[:, :2] - c, axis=1)) < 1200:
                continue
            if _blocks_view(c, size[:2], centres, keep_clear):
                continue
            if any(np.linalg.norm(c - 0.5 * (b.lo[:2] + b.hi[:2])) < 1200 for b in boxes):
                continue
            blo = np.array([c[0] - size[0] / 2, c[1] - size[1] / 2, 0.0])
            bhi = np.array([c[0] + size[0] / 2, c[1] + size[1] / 2, size[2]])
            boxes.append(Box(blo, bhi, np.array(palette[len(boxes) % len(palette)])))
        return cls(lo, hi, boxes, seed)

    # ------------------------------------------------------------------ ray casting
    def render(self, origin, rays):
        """Background of one camera.

        Parameters
        ----------
        origin : (3,) array_like
            Camera centre (mm), inside the room.
        rays : (H, W, 3) array_like
            Unit ray directions.

        Returns
        -------
        radiance : (H, W, 3) float32
            BGR radiance in [0, 1].
        depth : (H, W) float32
            Distance to the background along each ray (mm).
        floor_points : (H, W, 3) float32
            Hit points (mm); meaningful where ``is_floor``.
        is_floor : (H, W) bool
            Pixels seeing the floor.
        """
        o = np.asarray(origin, dtype=float)
        H, W = rays.shape[:2]
        d = np.asarray(rays, dtype=float).reshape(-1, 3)
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / d
            # Exit of the room box (the camera is inside): nearest wall/floor/ceiling plane.
            tw = np.where(d > 0, (self.room_hi - o) * inv, (self.room_lo - o) * inv)
        tw = np.where(np.isfinite(tw) & (tw > 0), tw, np.inf)
        axis = np.argmin(tw, axis=1)
        t = tw[np.arange(len(d)), axis]
        normal = np.zeros_like(d)
        normal[np.arange(len(d)), axis] = -np.sign(d[np.arange(len(d)), axis])
        obj = np.full(len(d), -1)
        for k, b in enumerate(self.boxes):
            # Only rays passing within the box's bounding sphere can hit it (cheap pre-test).
            centre, radius = 0.5 * (b.lo + b.hi), 0.5 * np.linalg.norm(b.hi - b.lo)
            v = centre - o
            along = d @ v
            near = np.flatnonzero((v @ v - along * along <= radius * radius) & (along > -radius))
            if near.size == 0:
                continue
            dn, invn = d[near], inv[near]
            with np.errstate(divide="ignore", invalid="ignore"):
                t1 = (b.lo - o) * invn
                t2 = (b.hi - o) * invn
            tmin3 = np.where(np.isnan(t1), -np.inf, np.minimum(t1, t2))
            tmax3 = np.where(np.isnan(t1), np.inf, np.maximum(t1, t2))
            tn = _max3(tmin3)
            tf = _min3(tmax3)
            hit = (tn <= tf) & (tn > 0) & (tn < t[near])
            if np.any(hit):
                idx = near[hit]
                ax = np.argmax(tmin3[hit], axis=1)
                t[idx] = tn[hit]
                n = np.zeros((len(idx), 3))
                n[np.arange(len(idx)), ax] = -np.sign(dn[hit][np.arange(len(idx)), ax])
                normal[idx] = n
                obj[idx] = k
        p = o + t[:, None] * d
        colour = self._albedo(p, normal, obj, axis)
        lam = np.clip(normal @ LIGHT, 0.0, 1.0)
        light = AMBIENT + (1 - AMBIENT) * lam
        is_floor = (obj < 0) & (axis == 2) & (d[:, 2] < 0)
        # static shadows of the objects on the floor
        if self.boxes and np.any(is_floor):
            fp = p[is_floor]
            shadowed = np.zeros(len(fp), dtype=bool)
            for b in self.boxes:
                with np.errstate(divide="ignore", invalid="ignore"):
                    t1 = (b.lo - fp) / LIGHT
                    t2 = (b.hi - fp) / LIGHT
                tn = _max3(np.minimum(t1, t2))
                tf = _min3(np.maximum(t1, t2))
                shadowed |= (tn <= tf) & (tf > 0)
            lf = light[is_floor]
            lf[shadowed] = AMBIENT
            light[is_floor] = lf
        radiance = (colour * light[:, None]).astype(np.float32).reshape(H, W, 3)
        return (radiance, t.astype(np.float32).reshape(H, W),
                p.astype(np.float32).reshape(H, W, 3), is_floor.reshape(H, W))

    def _albedo(self, p, normal, obj, axis):
        """BGR reflectance at hit points (procedural textures)."""
        n = len(p)
        col = np.empty((n, 3))
        x, y, z = p[:, 0], p[:, 1], p[:, 2]
        s = self.seed
        # floor: 600 mm tiles, grout, per-tile shade, grain, and a rug
        fl = (obj < 0) & (axis == 2) & (normal[:, 2] > 0)
        if np.any(fl):
            fx, fy = x[fl], y[fl]
            tile = _hash(np.floor(fx / 600), np.floor(fy / 600), s + 1)
            gx, gy = np.mod(fx, 600), np.mod(fy, 600)
            grout = (np.minimum(gx, 600 - gx) < 8) | (np.minimum(gy, 600 - gy) < 8)
            grain = _value_noise(fx, fy, 40.0, s + 2)
            base = np.array([0.55, 0.60, 0.64]) * (0.85 + 0.2 * tile)[:, None]
            base *= (0.9 + 0.2 * grain)[:, None]
            base[grout] = [0.35, 0.36, 0.38]
            rug = (np.abs(fx + 2600) < 700) & (np.abs(fy - 1800) < 1000)
            stripes = (np.floor((fx + 2600) / 120) % 2).astype(float)
            base[rug] = (np.array([0.15, 0.18, 0.45]) * (0.8 + 0.3 * stripes[rug])[:, None])
            col[fl] = base
        # ceiling
        ce = (obj < 0) & (axis == 2) & (normal[:, 2] < 0)
        col[ce] = [0.80, 0.80, 0.78]
        # walls: paint per wall, skirting, band, posters
        wl = (obj < 0) & (axis < 2)
        if np.any(wl):
            wx, wy, wz = x[wl], y[wl], z[wl]
            along = np.where(axis[wl] == 0, wy, wx)
            wall_id = axis[wl] * 2 + (normal[wl][np.arange(wl.sum()), axis[wl]] > 0)
            paints = np.array([[0.62, 0.72, 0.78], [0.70, 0.66, 0.55], [0.55, 0.68, 0.60],
                               [0.75, 0.74, 0.70]])
            base = paints[wall_id] * (0.92 + 0.12 * _value_noise(along, wz, 300.0, s + 3))[:, None]
            band = np.abs(wz - 1000) < 60
            base[band] *= 0.7
            base[wz < 120] = [0.20, 0.20, 0.22]
            cell = np.floor(along / 1500)
            has = _hash(cell, wall_id, s + 4) < 0.55
            cx = (cell + 0.5) * 1500
            poster = has & (np.abs(along - cx) < 420) & (np.abs(wz - 1700) < 330)
            pc = np.stack([_hash(cell, wall_id, s + k) for k in (5, 6, 7)], 1)
            inner = (np.floor((wz - 1370) / 110) % 2 == 0)[:, None]
            base = np.where(poster[:, None], np.where(inner, pc, 0.5 * pc + 0.4), base)
            col[wl] = base
        for k, b in enumerate(self.boxes):
            m = obj == k
            if np.any(m):
                tex = _value_noise(x[m] + y[m], z[m], 80.0, s + 10 + k)
                col[m] = b.colour * (0.85 + 0.3 * tex)[:, None]
        return col


#: Standard normal draws behind the sensor noise (see :func:`._render_kernels.expose`).
NOISE_TABLE = np.random.default_rng(20261122).standard_normal(1 << 13).astype(np.float32)


def sensor(radiance, *, gray: bool, gain: float, noise_sigma: float, rng, exposure: float = 255.0,
           blur: float = 0.6) -> np.ndarray:
    """Radiance ``(H, W, 3)`` in [0, 1] → an 8-bit camera frame.

    Parameters
    ----------
    radiance : (H, W, 3) float32
        BGR radiance.
    gray : bool
        Grey camera: luminance, returned as 3 equal channels (what OpenCV decodes from the AVI).
    gain : float
        This frame's gain (flicker), multiplies the exposure.
    noise_sigma : float
        Standard deviation of the Gaussian sensor noise (grey levels), independent per pixel
        and channel.
    rng : numpy.random.Generator
        Draws this frame's noise seed.
    exposure : float
        Grey level of radiance 1.
    blur : float
        Gaussian optical blur sigma (pixels); 0 disables it.

    Returns
    -------
    (H, W, 3) uint8
    """
    from ._render_kernels import expose

    img = np.asarray(radiance, dtype=np.float32)
    if gray:
        img = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
    if blur > 0:
        img = cv2.GaussianBlur(img, (0, 0), blur)
    if img.ndim == 2:
        img = img[:, :, None]
    out = np.empty(img.shape[:2] + (3,), dtype=np.uint8)
    seed = np.uint64(rng.integers(0, 2**63))
    expose(np.ascontiguousarray(img), np.float32(exposure * gain), np.float32(noise_sigma),
           NOISE_TABLE, seed, out)
    return out
