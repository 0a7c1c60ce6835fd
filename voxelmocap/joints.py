"""HumanEva joint vocabularies: the 20 ``body_pose`` endpoints and the 15 evaluation landmarks.

The 20 endpoints are the toolkit's ``body_pose`` fields in XML order (``HUMANEVA.md`` §4.5). The 15
landmarks ("virtual joints") are in the order of the toolkit's ``error()`` (``HUMANEVA.md`` §5.1,
``DESIGN.md`` §2); four of them (thorax, elbows, knees) merge two endpoints.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "ENDPOINT_NAMES",
    "LANDMARK_ENDPOINTS",
    "LANDMARK_NAMES",
    "LANDMARK_PARENTS",
    "endpoints_to_landmarks",
]

ENDPOINT_NAMES: tuple[str, ...] = (
    "torsoProximal", "torsoDistal",
    "upperLArmProximal", "upperLArmDistal", "lowerLArmProximal", "lowerLArmDistal",
    "upperRArmProximal", "upperRArmDistal", "lowerRArmProximal", "lowerRArmDistal",
    "upperLLegProximal", "upperLLegDistal", "lowerLLegProximal", "lowerLLegDistal",
    "upperRLegProximal", "upperRLegDistal", "lowerRLegProximal", "lowerRLegDistal",
    "headProximal", "headDistal",
)

LANDMARK_NAMES: tuple[str, ...] = (
    "thorax", "pelvis",
    "l_shoulder", "l_elbow", "l_wrist",
    "r_shoulder", "r_elbow", "r_wrist",
    "l_hip", "l_knee", "l_ankle",
    "r_hip", "r_knee", "r_ankle",
    "head",
)

_E = {name: i for i, name in enumerate(ENDPOINT_NAMES)}

#: For each landmark, the endpoint indices it is made of (one, or two for merged joints).
LANDMARK_ENDPOINTS: tuple[tuple[int, ...], ...] = (
    (_E["torsoProximal"], _E["headProximal"]),
    (_E["torsoDistal"],),
    (_E["upperLArmProximal"],),
    (_E["upperLArmDistal"], _E["lowerLArmProximal"]),
    (_E["lowerLArmDistal"],),
    (_E["upperRArmProximal"],),
    (_E["upperRArmDistal"], _E["lowerRArmProximal"]),
    (_E["lowerRArmDistal"],),
    (_E["upperLLegProximal"],),
    (_E["upperLLegDistal"], _E["lowerLLegProximal"]),
    (_E["lowerLLegDistal"],),
    (_E["upperRLegProximal"],),
    (_E["upperRLegDistal"], _E["lowerRLegProximal"]),
    (_E["lowerRLegDistal"],),
    (_E["headDistal"],),
)

#: Parent of each landmark in a stick figure (-1 for the root, the pelvis), for drawing and BVH.
LANDMARK_PARENTS: tuple[int, ...] = (1, -1, 0, 2, 3, 0, 5, 6, 1, 8, 9, 1, 11, 12, 0)


def endpoints_to_landmarks(endpoints, enabled=None):
    """The 15 landmarks from the 20 endpoints; merged joints are the mean of their two endpoints.

    Parameters
    ----------
    endpoints : (..., 20, D) array_like
        Endpoint positions (D = 3 in mm, or 2 in pixels), in :data:`ENDPOINT_NAMES` order.
    enabled : (..., 20) array_like of bool, optional
        Endpoint flags. A merged landmark with one disabled endpoint takes the other one; a
        landmark whose endpoints are all disabled is NaN.

    Returns
    -------
    (..., 15, D) ndarray
        Landmarks in :data:`LANDMARK_NAMES` order.
    """
    endpoints = np.asarray(endpoints, dtype=float)
    if endpoints.shape[-2] != 20:
        raise ValueError(f"expected 20 endpoints on axis -2, got shape {endpoints.shape}")
    if enabled is None:
        enabled = np.ones(endpoints.shape[:-1], dtype=bool)
    enabled = np.broadcast_to(np.asarray(enabled, dtype=bool), endpoints.shape[:-1])
    out = np.empty(endpoints.shape[:-2] + (15, endpoints.shape[-1]))
    for j, idx in enumerate(LANDMARK_ENDPOINTS):
        pts = endpoints[..., idx, :]
        w = enabled[..., idx].astype(float)[..., None]
        total = w.sum(axis=-2)
        with np.errstate(invalid="ignore", divide="ignore"):
            out[..., j, :] = np.where(total > 0, (pts * w).sum(axis=-2) / np.maximum(total, 1),
                                      np.nan)
    return out
