"""The body model: a subject's dimensions, the 27-dimensional state, kinematics and cones.

>>> model = BodyModel()                    # the average adult (1780 mm)
>>> model.n_dims, len(model.parts)
(27, 10)
>>> x = model.default_state()              # standing upright at the origin, facing +Y
>>> model.landmarks(x[None]).shape
(1, 15, 3)
"""

from __future__ import annotations

import numpy as np

from .kinematics import Kinematics, forward_kinematics
from .landmarks import joints_to_endpoints
from .shapes import ANKLE_HEIGHT_SHARE, PART_NAMES, BodyDimensions, Part
from .state import N_DIMS, STATE_HIGH, STATE_LOW, STATE_NAMES, check_states

__all__ = ["BodyModel", "PartGeometry"]


class PartGeometry:
    """Per-particle cone geometry in the flat form the likelihood kernels consume.

    Attributes
    ----------
    base, axis, u1, u2 : (P, n_parts, 3) float64 ndarray
        As in :class:`~voxelmocap.body.kinematics.Kinematics`.
    shape : (n_parts, 7) float64 ndarray
        Per part ``1/H, 1/W, L, (R − 1)/L, H, W, R`` (mm⁻¹, mm⁻¹, mm, mm⁻¹, mm, mm, 1). Membership
        of a point ``p`` is decided with exactly these numbers by both likelihood implementations
        (see ``voxelmocap.score.likelihood``).
    """

    def __init__(self, kin: Kinematics, parts: tuple[Part, ...]):
        self.base = kin.base
        self.axis = kin.axis
        self.u1 = kin.u1
        self.u2 = kin.u2
        self.shape = np.array([[1.0 / p.H, 1.0 / p.W, p.L, (p.R - 1.0) / p.L, p.H, p.W, p.R]
                               for p in parts])

    @property
    def n_particles(self) -> int:
        """Number of particles P."""
        return self.base.shape[0]


class BodyModel:
    """Truncated-cone human body model with a 27-parameter state.

    Parameters
    ----------
    dimensions : BodyDimensions, optional
        The subject; default the average adult (:meth:`BodyDimensions.average`).
    low, high : (27,) array_like, optional
        Legal state ranges; default the published ranges of :mod:`voxelmocap.body.state`.

    Attributes
    ----------
    dimensions : BodyDimensions
    parts : tuple of Part
        The ten cones (name, H, W, L, R) in ``PART_NAMES`` order.
    state_names : tuple of str
        27 names.
    low, high : (27,) float ndarray
        Legal ranges (mm, rad).
    """

    def __init__(self, dimensions: BodyDimensions | None = None, *, low=None, high=None):
        self.dimensions = BodyDimensions.average() if dimensions is None else dimensions
        self.parts: tuple[Part, ...] = self.dimensions.parts()
        self.part_names: tuple[str, ...] = PART_NAMES
        self.state_names: tuple[str, ...] = STATE_NAMES
        self.low = np.array(STATE_LOW if low is None else low, dtype=float)
        self.high = np.array(STATE_HIGH if high is None else high, dtype=float)
        if self.low.shape != (N_DIMS,) or self.high.shape != (N_DIMS,) \
                or not np.all(self.low <= self.high):
            raise ValueError("low and high must be (27,) with low <= high")
        self.low.setflags(write=False)
        self.high.setflags(write=False)

    # ----------------------------------------------------------------------------- builders
    @classmethod
    def from_landmarks(cls, landmarks) -> BodyModel:
        """Model whose limb lengths are measured from ground-truth landmarks ``(F, 15, 3)``."""
        return cls(BodyDimensions.from_landmarks(landmarks))

    @classmethod
    def scaled(cls, height_mm: float) -> BodyModel:
        """The average adult scaled to a standing height (mm)."""
        return cls(BodyDimensions.average(height_mm))

    def __repr__(self) -> str:
        return f"BodyModel(height={self.dimensions.height:.0f} mm, {len(self.parts)} parts)"

    # ----------------------------------------------------------------------------- states
    @property
    def n_dims(self) -> int:
        """27."""
        return N_DIMS

    @property
    def n_parts(self) -> int:
        """Number of cones (10)."""
        return len(self.parts)

    def default_state(self) -> np.ndarray:
        """(27,) upright standing pose at the world origin, facing +Y, feet on the floor."""
        x = np.zeros(N_DIMS)
        d = self.dimensions
        x[2] = (max(d.hip_drop) + max(d.thigh) + max(d.shin)
                + d.height * ANKLE_HEIGHT_SHARE)  # ankles above the floor
        return np.clip(x, self.low, self.high)

    def check(self, states, *, legal: bool = True, clip: bool = False,
              source: str = "states") -> np.ndarray:
        """Validate states, see :func:`voxelmocap.body.state.check_states`."""
        return check_states(states, low=self.low, high=self.high, legal=legal, clip=clip,
                            source=source)

    def clip(self, states) -> np.ndarray:
        """States clipped into the legal ranges (NaN still rejected)."""
        return check_states(states, low=self.low, high=self.high, clip=True)

    # ----------------------------------------------------------------------------- geometry
    def forward(self, states) -> Kinematics:
        """Batched forward kinematics.

        Parameters
        ----------
        states : (P, 27) array_like
            Finite states (mm, rad); out-of-range angles are allowed here (the geometry is
            defined), the likelihood rejects them.

        Returns
        -------
        Kinematics
            ``base``, ``axis``, ``u1``, ``u2`` ``(P, 10, 3)`` for every part, ``joints``
            ``(P, 15, 3)``.
        """
        return forward_kinematics(self.check(states, legal=False), self.dimensions)

    def geometry(self, states, *, legal: bool = True, clip: bool = False) -> PartGeometry:
        """Validated cone geometry for the likelihood (see :class:`PartGeometry`)."""
        x = self.check(states, legal=legal, clip=clip)
        return PartGeometry(forward_kinematics(x, self.dimensions), self.parts)

    def landmarks(self, states) -> np.ndarray:
        """(P, 15, 3) landmarks (mm) in ``LANDMARK_NAMES`` order."""
        return self.forward(states).joints

    def endpoints(self, states) -> np.ndarray:
        """(P, 20, 3) ``body_pose`` endpoints (mm) in ``ENDPOINT_NAMES`` order."""
        return joints_to_endpoints(self.forward(states).joints)
