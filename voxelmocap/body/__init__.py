"""The articulated truncated-cone body model (paper 002 §2.2; cones of paper 000 §3.1.1).

- :mod:`~voxelmocap.body.state`: the 27-dimensional state, its names and published legal ranges;
- :mod:`~voxelmocap.body.shapes`: subject dimensions (body file, landmarks, average adult) and the
  ten truncated elliptic cones (H, W, L, R);
- :mod:`~voxelmocap.body.kinematics`: batched forward kinematics;
- :mod:`~voxelmocap.body.landmarks`: the 15 HumanEva landmarks and 20 ``body_pose`` endpoints;
- :mod:`~voxelmocap.body.fit`: inverse kinematics from landmarks;
- :mod:`~voxelmocap.body.model`: :class:`BodyModel`, tying them together.

>>> model = BodyModel()
>>> model.landmarks(model.default_state()[None]).shape
(1, 15, 3)
"""

from .fit import analytic_state, fit_to_landmarks, retarget
from .kinematics import Kinematics, forward_kinematics
from .landmarks import ENDPOINT_JOINTS, joints_to_endpoints
from .model import BodyModel, PartGeometry
from .shapes import PART_NAMES, BodyDimensions, Part, frustum_volume
from .state import (
    N_DIMS,
    STATE_HIGH,
    STATE_INDEX,
    STATE_LOW,
    STATE_NAMES,
    check_states,
    wrap_heading,
)

__all__ = [
    "ENDPOINT_JOINTS",
    "N_DIMS",
    "PART_NAMES",
    "STATE_HIGH",
    "STATE_INDEX",
    "STATE_LOW",
    "STATE_NAMES",
    "BodyDimensions",
    "BodyModel",
    "Kinematics",
    "Part",
    "PartGeometry",
    "analytic_state",
    "check_states",
    "fit_to_landmarks",
    "forward_kinematics",
    "frustum_volume",
    "joints_to_endpoints",
    "retarget",
    "wrap_heading",
]
