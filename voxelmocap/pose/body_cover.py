"""The person's cover from a tracked body: where a previous run saw the person, per camera.

A plate learnt from the sequence needs to know, in each sampled frame, which pixels the person
covers (:func:`voxelmocap.measure.background.plates_from_covers`).
:func:`~voxelmocap.measure.background.learn_plates`
finds them by carving against a first plate; a body tracked by a previous run
(``track --plate-from RUN``) gives them directly: its cones drawn in each camera
(:func:`voxelmocap.score.cues.contours.body_mask`), grown by a margin. Pure: the run is read by
:func:`voxelmocap.run.pipeline.tracked_body`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["TrackedBody", "plate_covers_of", "support_column"]


@dataclass(frozen=True)
class TrackedBody:
    """A previous run's body over the frames it tracked: a plate's cover (``--plate-from``).

    Attributes
    ----------
    model : BodyModel
        The body the run tracked with.
    frames : (F,) int ndarray
        Frame numbers, increasing (the frames where the run saw the person).
    states : (F, 27) float ndarray
        The tracked state of each.
    source : str
        Where it was read (for messages).
    """

    model: object
    frames: np.ndarray
    states: np.ndarray
    source: str

    def state_at(self, frame: int) -> np.ndarray | None:
        """The ``(27,)`` state tracked at ``frame``, or None where the run has none."""
        k = int(np.searchsorted(self.frames, frame))
        return self.states[k] if k < len(self.frames) and self.frames[k] == frame else None


def plate_covers_of(rig, model, states, margin: float, *, support: float = 0.0,
                    max_side: int = 480) -> dict[str, np.ndarray]:
    """Each camera's image of the body in each state, grown by ``margin``: a plate's cover.

    Drawn at most ``max_side`` pixels on a side (the resolution :func:`learn_plates` finds its
    covers at; :func:`~voxelmocap.measure.background.plates_from_covers` resizes them).

    With ``support`` the cover also holds the image of the vertical cylinder of that radius
    under the pelvis, from its height down to the floor (:func:`support_column`): wherever the
    tracked legs went, a standing person's legs are in it. A leg the previous pass lost would
    otherwise be left uncovered where it stood, and a leg that stands in one place for most of
    the sequence is what the median of its uncovered frames then learns as background.

    Parameters
    ----------
    rig : sequence of Camera
    model : BodyModel
    states : (F, 27) array_like
    margin : float
        Millimetres at the body's depth (the tracked cones are not the person's exact outline).
    support : float
        Radius (mm) of the column under the pelvis also covered (0: none).
    max_side : int

    Returns
    -------
    dict of str to (F, h, w) bool ndarray
    """
    import cv2

    from ..measure.plate import camera_at_most
    from ..score.cues.contours import body_mask

    states = np.asarray(states, float)
    geos = [model.geometry(states[f:f + 1], legal=False) for f in range(len(states))]
    out = {}
    for cam in rig:
        small = camera_at_most(cam, max_side)
        masks = []
        for geo in geos:
            m = body_mask(geo, small)
            depth = small.world_to_camera(geo.base[0].mean(axis=0)[None])[0, 2]
            if m.any() and margin > 0 and depth > 0:
                # grown by the margin's image at the body's depth (a distance transform: its
                # cost does not grow with the radius, which is large for a body near the lens)
                r = max(small.fc) * margin / depth
                far = cv2.distanceTransform((~m).astype(np.uint8), cv2.DIST_L2, 5)
                m = far <= r
            masks.append(m)
        out[cam.name] = np.stack(masks)
        if support > 0:
            for f, state in enumerate(states):
                out[cam.name][f] |= support_column(small, state[:3], support)
    return out


def support_column(camera, pelvis, radius: float, *, sides: int = 48) -> np.ndarray:
    """(H, W) bool image of the vertical cylinder of ``radius`` (mm) from ``pelvis`` to the floor.

    The image of a convex solid is convex: the convex hull of its two end circles' images
    (``sides``-gons, which the circles' images hardly exceed). Empty when any of it is behind the
    camera (a hull of such points would be meaningless) or the pelvis is below the floor.
    """
    import cv2

    w, h = camera.size
    out = np.zeros((h, w), np.uint8)
    x, y, z = (float(v) for v in pelvis)
    if z <= 0:
        return out.view(bool)
    ang = np.arange(sides) * (2 * np.pi / sides)
    ring = np.stack([x + radius * np.cos(ang), y + radius * np.sin(ang)], axis=1)
    ends = np.concatenate([np.c_[ring, np.full(sides, z)], np.c_[ring, np.zeros(sides)]])
    if (camera.world_to_camera(ends)[:, 2] <= 0).any():
        return out.view(bool)
    uv = camera.project(ends)
    # far off-image points only clip: keep the hull's coordinates within int32's comfortable range
    uv = np.clip(np.round(uv), -4 * (w + h), 4 * (w + h)).astype(np.int32)
    cv2.fillConvexPoly(out, cv2.convexHull(uv), 1)
    return out.view(bool)
