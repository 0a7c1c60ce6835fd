"""Rendering the subject into every camera of a rig: per-pixel ray casting over the subject's box.

For each camera the renderer keeps a table of unit ray directions for all pixels (distortion and
skew inverted once, so the images follow each camera's full model) and the static background
(radiance, depth, floor points). Per frame it projects the body's bounding spheres and their
floor shadows to find a region of interest, darkens the floor there with the soft shadow and
ray-casts the body's capsules and ellipsoids (:mod:`._render_kernels`), nearest hit wins, with
the background depth as the far limit (static objects occlude the subject correctly).

>>> r = Renderer(rig)                                            # doctest: +SKIP
>>> radiance, mask = r.render("C1", body_primitives(points, shape))  # doctest: +SKIP
"""

from __future__ import annotations

from collections import OrderedDict

import numpy as np

from . import _render_kernels as K
from .body_shape import Primitives
from .scene import AMBIENT, LIGHT, Scene

__all__ = ["Renderer", "pixel_rays"]

SHADOW_STRENGTH = 0.5

# Per-camera ray tables and backgrounds cost ~1 s per camera to build; repeated renders of the same
# rig and room (tests, batches of sequences) reuse them. Keyed by every number that shapes them.
_VIEW_CACHE: OrderedDict = OrderedDict()
_VIEW_CACHE_SIZE = 16


def _view_key(camera, scene: Scene) -> bytes:
    parts = [camera.fc, camera.cc, np.array([camera.alpha_c]), camera.kc, camera.R, camera.T,
             np.array(camera.size, dtype=float), scene.room_lo, scene.room_hi,
             np.array([scene.seed], dtype=float)]
    parts += [np.concatenate([b.lo, b.hi, b.colour]) for b in scene.boxes]
    return b"".join(np.asarray(p, dtype=np.float64).tobytes() for p in parts)


def pixel_rays(camera) -> np.ndarray:
    """Unit world ray directions ``(H, W, 3)`` float32 of every pixel centre of ``camera``."""
    W, H = camera.size
    u, v = np.meshgrid(np.arange(W, dtype=float), np.arange(H, dtype=float))
    _, d = camera.rays(np.stack([u.ravel(), v.ravel()], axis=1))
    return d.reshape(H, W, 3).astype(np.float32)


def _on_floor(points):
    """Points (N, 3) pushed along −LIGHT onto the floor Z = 0; also the distance travelled."""
    s = np.maximum(points[:, 2], 0.0) / LIGHT[2]
    return points[:, :2] - s[:, None] * LIGHT[None, :2], s


def _shadow_discs(caps, centres, semi_max, semi_mean):
    """Floor discs (cx, cy, R) beyond which a capsule / ellipsoid casts no shadow (with penumbra).

    The penumbra half-width of the kernel is 12 mm + 0.1 × the distance along the light ray.
    """
    a, sa = _on_floor(caps[:, 0:3])
    b, sb = _on_floor(caps[:, 3:6])
    grow = 1.0 / LIGHT[2]
    # The light-ray tube of radius r + k meets the floor in a disc stretched by 1 / L_z.
    cap_r = 0.5 * np.linalg.norm(a - b, axis=1) + grow * (
        caps[:, 6] + 12.0 + 0.1 * (np.maximum(sa, sb) + caps[:, 6] * grow)) + 1.0
    cap = np.column_stack([0.5 * (a + b), cap_r])
    c, sc = _on_floor(centres)
    # The kernel's ellipsoid penumbra is k in units of the mean semi-axis: scale it to the longest.
    k = 12.0 + 0.1 * (sc + semi_max * grow)
    ell_r = grow * (semi_max + k * semi_max / semi_mean) + 1.0
    ell = np.column_stack([c, ell_r])
    return np.ascontiguousarray(cap), np.ascontiguousarray(ell)


class _View:
    def __init__(self, camera, scene: Scene):
        self.camera = camera
        self.origin = np.asarray(camera.center, dtype=np.float64)
        self.rays = pixel_rays(camera)
        (self.background, self.bg_depth, self.floor_points,
         self.is_floor) = scene.render(self.origin, self.rays)


class Renderer:
    """Renders body primitives into the cameras of a rig over a static scene.

    Parameters
    ----------
    rig : voxelmocap.camera.Rig
        The cameras.
    scene : Scene, optional
        The room; by default :meth:`Scene.around` the camera centres with ``scene_seed``.
    scene_seed : int
        Seed of the room's layout and textures (independent of the noise seed, so every
        sequence of one rig shares the same background).
    """

    def __init__(self, rig, *, scene: Scene | None = None, scene_seed: int = 0):
        self.rig = rig
        self.scene = scene or Scene.around([c.center for c in rig], seed=scene_seed)
        self._views = {}
        for cam in rig:
            key = _view_key(cam, self.scene)
            view = _VIEW_CACHE.get(key)
            if view is None:
                view = _View(cam, self.scene)
                _VIEW_CACHE[key] = view
                while len(_VIEW_CACHE) > _VIEW_CACHE_SIZE:
                    _VIEW_CACHE.popitem(last=False)
            _VIEW_CACHE.move_to_end(key)
            self._views[cam.name] = view

    def background(self, camera: str) -> np.ndarray:
        """The empty scene's radiance ``(H, W, 3)`` float32 for a camera (a copy)."""
        return self._views[camera].background.copy()

    def roi(self, camera: str, prims: Primitives, *, body: bool = True, shadow: bool = True
            ) -> np.ndarray:
        """``(u0, u1, v0, v1)`` int64 pixel box holding the body and/or its floor shadow."""
        view = self._views[camera]
        cam = view.camera
        pts = prims.bounding_points()
        rad = prims.radii()
        allp, allr = [], []
        if body:
            allp.append(pts)
            allr.append(rad)
        if shadow:
            # The points pushed along −LIGHT onto Z = 0, widened for the penumbra.
            flat = pts - (np.maximum(pts[:, 2], 0.0) / LIGHT[2])[:, None] * LIGHT[None, :]
            flat[:, 2] = 0.0
            allp.append(flat)
            allr.append(1.3 * rad + 40.0 + 0.1 * pts[:, 2] / LIGHT[2])
        allp, allr = np.concatenate(allp), np.concatenate(allr)
        uv, z = cam.project(allp, return_depth=True)
        ok = z > 1.0
        W, H = cam.size
        if not np.any(ok):
            return np.array([0, 0, 0, 0], dtype=np.int64)
        pr = 1.25 * allr[ok] * max(cam.fc) / z[ok] + 3.0
        u0 = int(np.floor(np.min(uv[ok, 0] - pr)))
        u1 = int(np.ceil(np.max(uv[ok, 0] + pr))) + 1
        v0 = int(np.floor(np.min(uv[ok, 1] - pr)))
        v1 = int(np.ceil(np.max(uv[ok, 1] + pr))) + 1
        return np.array([max(u0, 0), min(u1, W), max(v0, 0), min(v1, H)], dtype=np.int64)

    def primitive_boxes(self, camera: str, prims: Primitives) -> tuple[np.ndarray, np.ndarray]:
        """Per-primitive pixel boxes ``(N, 4)`` int64 (``u0, u1, v0, v1``) from bounding spheres.

        A capsule's box holds both end spheres, an ellipsoid's its circumscribed sphere; the
        projected radius is widened by 25 % and 2 px so that lens distortion cannot push the
        primitive outside it.
        """
        cam = self._views[camera].camera
        caps, ells = prims.capsules, prims.ellipsoids
        semi_max = 1.0 / np.linalg.svd(ells[:, 3:12].reshape(-1, 3, 3), compute_uv=False)[:, -1]
        centres = np.concatenate([caps[:, 0:3], caps[:, 3:6], ells[:, :3]])
        radii = np.concatenate([caps[:, 6], caps[:, 6], semi_max])
        uv, z = cam.project(centres, return_depth=True)
        behind = z <= radii + 1.0  # a sphere reaching behind the camera: no useful box
        pr = np.where(behind, 0.0, 1.25 * radii * max(cam.fc) / np.maximum(z - radii, 1.0) + 2.0)
        lo = np.floor(uv - pr[:, None])
        hi = np.ceil(uv + pr[:, None]) + 1
        big = 1 << 30
        lo[behind], hi[behind] = -big, big
        lo = np.clip(lo, -big, big).astype(np.int64)
        hi = np.clip(hi, -big, big).astype(np.int64)
        nc = len(caps)
        cap_box = np.column_stack([np.minimum(lo[:nc, 0], lo[nc:2 * nc, 0]),
                                   np.maximum(hi[:nc, 0], hi[nc:2 * nc, 0]),
                                   np.minimum(lo[:nc, 1], lo[nc:2 * nc, 1]),
                                   np.maximum(hi[:nc, 1], hi[nc:2 * nc, 1])])
        ell_box = np.column_stack([lo[2 * nc:, 0], hi[2 * nc:, 0], lo[2 * nc:, 1],
                                   hi[2 * nc:, 1]])
        return np.ascontiguousarray(cap_box), np.ascontiguousarray(ell_box)

    def render(self, camera: str, prims: Primitives, *, shadow: bool = True
               ) -> tuple[np.ndarray, np.ndarray]:
        """Render one camera.

        Parameters
        ----------
        camera : str
            Camera name.
        prims : Primitives
            The body in this frame.
        shadow : bool
            Draw the body's soft floor shadow.

        Returns
        -------
        radiance : (H, W, 3) float32
            BGR radiance in [0, 1] (background, shadow and body).
        mask : (H, W) bool
            Pixels where the body is visible (noise-free person mask).
        """
        view = self._views[camera]
        img = view.background.copy()
        H, W = img.shape[:2]
        mask = np.zeros((H, W), dtype=bool)
        depth = np.zeros((H, W), dtype=np.float32)
        roi = self.roi(camera, prims, shadow=False)
        caps = np.ascontiguousarray(prims.capsules, dtype=np.float64)
        ells = np.ascontiguousarray(prims.ellipsoids, dtype=np.float64)
        light = LIGHT.astype(np.float64)
        if shadow:
            A = ells[:, 3:12].reshape(-1, 3, 3)
            semi = 1.0 / np.linalg.svd(A, compute_uv=False)
            ell_r = semi.mean(axis=1)
            cap_cull, ell_cull = _shadow_discs(caps, ells[:, :3], semi.max(axis=1), ell_r)
            K.floor_shadow(view.floor_points, view.is_floor, self.roi(camera, prims, body=False),
                           caps, ells, ell_r, cap_cull, ell_cull, light, SHADOW_STRENGTH, img)
        cap_boxes, ell_boxes = self.primitive_boxes(camera, prims)
        K.cast_body(view.rays, view.origin, roi, caps,
                    np.ascontiguousarray(prims.capsule_colours, dtype=np.float64), cap_boxes,
                    ells, np.ascontiguousarray(prims.ellipsoid_colours, dtype=np.float64),
                    ell_boxes, view.bg_depth, light, AMBIENT, img, mask, depth)
        return img, mask
