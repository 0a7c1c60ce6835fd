"""The 15 HumanEva landmarks and the 20 ``body_pose`` endpoints of the body model.

The skeleton's joints (:func:`~voxelmocap.body.kinematics.forward_kinematics`) are kept in
``LANDMARK_NAMES`` order, so the landmarks are the joints themselves. The endpoints follow the
ground-truth geometry of the body-file contract: ``torsoProximal`` = ``headProximal`` = thorax
(neck base), ``torsoDistal`` = pelvis, ``headDistal`` = head top, an elbow (knee) is both the
distal end of the upper arm (thigh) and the proximal end of the forearm (shin). Duplicated
endpoints are identical, so :func:`voxelmocap.joints.endpoints_to_landmarks` maps the endpoints
back to exactly the landmarks.

>>> ENDPOINT_JOINTS[ENDPOINT_NAMES.index("headDistal")] == LANDMARK_NAMES.index("head")
True
"""

from __future__ import annotations

import numpy as np

from ..joints import ENDPOINT_NAMES, LANDMARK_NAMES

__all__ = ["ENDPOINT_JOINTS", "joints_to_endpoints"]

_L = {name: i for i, name in enumerate(LANDMARK_NAMES)}
_ENDPOINT_TO_LANDMARK = {
    "torsoProximal": "thorax", "torsoDistal": "pelvis",
    "upperLArmProximal": "l_shoulder", "upperLArmDistal": "l_elbow",
    "lowerLArmProximal": "l_elbow", "lowerLArmDistal": "l_wrist",
    "upperRArmProximal": "r_shoulder", "upperRArmDistal": "r_elbow",
    "lowerRArmProximal": "r_elbow", "lowerRArmDistal": "r_wrist",
    "upperLLegProximal": "l_hip", "upperLLegDistal": "l_knee",
    "lowerLLegProximal": "l_knee", "lowerLLegDistal": "l_ankle",
    "upperRLegProximal": "r_hip", "upperRLegDistal": "r_knee",
    "lowerRLegProximal": "r_knee", "lowerRLegDistal": "r_ankle",
    "headProximal": "thorax", "headDistal": "head",
}
#: For each of the 20 endpoints (``ENDPOINT_NAMES`` order), the index of its landmark / joint.
ENDPOINT_JOINTS: tuple[int, ...] = tuple(_L[_ENDPOINT_TO_LANDMARK[n]] for n in ENDPOINT_NAMES)


def joints_to_endpoints(joints) -> np.ndarray:
    """The 20 endpoints ``(..., 20, 3)`` from joints ``(..., 15, 3)`` in ``LANDMARK_NAMES`` order."""
    joints = np.asarray(joints, dtype=float)
    return joints[..., list(ENDPOINT_JOINTS), :]
