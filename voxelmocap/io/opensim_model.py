"""The OpenSim model of the tracked skeleton: bodies, joints, coordinates and the 15 markers.

voxelmocap's tracker moves a 27-parameter skeleton (:mod:`voxelmocap.body`); this module writes
the same skeleton as an OpenSim model, so that OpenSim's inverse kinematics can reproduce every
tracked pose and report it in OpenSim's joint-angle conventions. The model is written here through
the OpenSim API (no third-party model file is copied). Its segments take the tracked body's
dimensions (:class:`~voxelmocap.body.shapes.BodyDimensions`): the generic skeleton (the average
adult of :meth:`BodyDimensions.average`) scaled segment by segment to the subject, every length
set exactly, which OpenSim's per-body scale factors could not do for the shoulder and hip drops
(often 0) or for a left side that differs from the right.

Axes (OpenSim's): X forward, Y up, Z to the subject's right, metres; the ground is the
calibration's world frame turned by Pose2Sim's ``zup2yup`` (X ← world Y, Y ← world Z, Z ← world X).

========== ========== ================= ===============================================================
body       parent     joint             coordinates (body-fixed sequence, in this order)
========== ========== ================= ===============================================================
pelvis     ground     ``ground_pelvis`` pelvis_rotation (Y, heading), pelvis_tilt (Z, + backwards),
                                        pelvis_list (X, + right side down), pelvis_tx, _ty, _tz
torso      pelvis     ``back``          lumbar_extension (Z), lumbar_bending (X, + to the right),
                                        lumbar_rotation (Y, + turning left)
head       torso      ``neck``          neck_extension (Z), neck_bending (X, + to the right)
humerus_*  torso      ``shoulder_*``    arm_flex_* (Z), arm_add_* (X), arm_rot_* (Y, + internal)
ulna_*     humerus_*  ``elbow_*``       elbow_flex_* (Z)
femur_*    pelvis     ``hip_*``         hip_flexion_* (Z), hip_adduction_* (X), hip_rotation_* (Y, +
                                        internal)
tibia_*    femur_*    ``knee_*``        knee_angle_* (−Z: + flexion, the shank backwards)
========== ========== ================= ===============================================================

The left side's adduction and rotation axes are −X and −Y, so that a positive angle means the
same movement on both sides (OpenSim's gait models do the same). Heading comes first in the
pelvis, so that tilt and list stay the subject's own whichever way it walks.

Joint positions follow the tracker's kinematics (``voxelmocap.body.kinematics``): the pelvis
origin is the ``pelvis`` landmark; the lumbar joint sits there too (the tracker's torso turns about
the pelvis); ``thorax`` is ``torso`` above it, the neck joint there; a shoulder is ``shoulder_drop``
below the thorax and ``shoulder_offset`` to the side, a hip ``hip_drop`` below the pelvis and
``hip_offset`` to the side; limbs hang along −Y. Each of the 15 HumanEva landmarks is a marker
at its joint (``head`` = the head top), so a pose of the tracker is a pose of this model, exactly.

Mass properties (not used by inverse kinematics, but a model needs them): each body carries the
mass and inertia of its cone in the tracker's model (:meth:`BodyDimensions.parts`) at
:data:`DENSITY`; the pelvis, which the tracker's model has no cone for (the torso cone starts
there), is massless.

>>> from voxelmocap.body.shapes import BodyDimensions
>>> geometry = skeleton(BodyDimensions.average())
>>> geometry.markers["r_knee"]
('femur_r', (0.0, -0.44, 0.0))
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..body.shapes import BodyDimensions, Part

__all__ = ["COORDINATES", "DENSITY", "JOINTS", "Skeleton", "build_model", "skeleton"]

#: kg/m³: the mean density of the human body (about 1.05 g/cm³, e.g. Winter, *Biomechanics and
#: Motor Control of Human Movement*, 4th ed., Table 4.1 averages 1.04–1.16 per segment).
DENSITY = 1050.0

_X, _Y, _Z = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)


def _neg(axis):
    return tuple(-a for a in axis)


#: (joint, parent body, child body, [(coordinate, axis in the parent's frame)] in order; the
#: pelvis' three translations follow its rotations).
JOINTS: tuple = (
    ("ground_pelvis", "ground", "pelvis",
     [("pelvis_rotation", _Y), ("pelvis_tilt", _Z), ("pelvis_list", _X)]),
    ("back", "pelvis", "torso",
     [("lumbar_extension", _Z), ("lumbar_bending", _X), ("lumbar_rotation", _Y)]),
    ("neck", "torso", "head", [("neck_extension", _Z), ("neck_bending", _X)]),
    *(j for side, s in (("r", 1.0), ("l", -1.0)) for j in (
        (f"shoulder_{side}", "torso", f"humerus_{side}",
         [(f"arm_flex_{side}", _Z), (f"arm_add_{side}", (s, 0.0, 0.0)),
          (f"arm_rot_{side}", (0.0, s, 0.0))]),
        (f"elbow_{side}", f"humerus_{side}", f"ulna_{side}", [(f"elbow_flex_{side}", _Z)]),
    )),
    *(j for side, s in (("r", 1.0), ("l", -1.0)) for j in (
        (f"hip_{side}", "pelvis", f"femur_{side}",
         [(f"hip_flexion_{side}", _Z), (f"hip_adduction_{side}", (s, 0.0, 0.0)),
          (f"hip_rotation_{side}", (0.0, s, 0.0))]),
        (f"knee_{side}", f"femur_{side}", f"tibia_{side}", [(f"knee_angle_{side}", _neg(_Z))]),
    )),
)
_TRANSLATIONS = ("pelvis_tx", "pelvis_ty", "pelvis_tz")
#: Every coordinate of the model, in the order of the ``.mot`` columns.
COORDINATES: tuple[str, ...] = (
    *(c for c, _ in JOINTS[0][3]), *_TRANSLATIONS,
    *(c for joint in JOINTS[1:] for c, _ in joint[3]))

# Ranges (degrees) written into the model for a viewer's sliders: the tracker's legal ranges
# (voxelmocap.body.state), in these coordinates' signs. Inverse kinematics does not clamp them.
_RANGES_DEG = {
    "pelvis_rotation": (-720.0, 720.0), "pelvis_tilt": (-90.0, 90.0), "pelvis_list": (-90.0, 90.0),
    "lumbar_extension": (-80.0, 25.0), "lumbar_bending": (-35.0, 35.0),
    "lumbar_rotation": (-45.0, 45.0), "neck_extension": (-45.0, 45.0),
    "neck_bending": (-45.0, 45.0), "arm_flex": (-60.0, 180.0), "arm_add": (-180.0, 45.0),
    "arm_rot": (-90.0, 70.0), "elbow_flex": (0.0, 150.0), "hip_flexion": (-30.0, 120.0),
    "hip_adduction": (-45.0, 30.0), "hip_rotation": (-45.0, 45.0), "knee_angle": (0.0, 135.0),
}


@dataclass(frozen=True)
class Skeleton:
    """Where the joints and markers of the model are (metres, OpenSim axes).

    Attributes
    ----------
    joint_in_parent : dict
        Joint name → its position in the parent body's frame.
    markers : dict
        Landmark name → (body, position in that body's frame).
    parts : dict
        Body name → the tracker's cone it carries (:class:`~voxelmocap.body.shapes.Part`, mm),
        and the direction of the cone's axis in the body (+1 up, −1 down).
    """

    joint_in_parent: dict
    markers: dict
    parts: dict


def skeleton(dims: BodyDimensions) -> Skeleton:
    """The joint and marker positions of a body (see the module docstring).

    Parameters
    ----------
    dims : BodyDimensions
        Lengths in mm.

    Returns
    -------
    Skeleton
    """
    m = 1e-3
    joints = {"ground_pelvis": (0.0, 0.0, 0.0), "back": (0.0, 0.0, 0.0),
              "neck": (0.0, dims.torso * m, 0.0)}
    markers = {"pelvis": ("pelvis", (0.0, 0.0, 0.0)),
               "thorax": ("torso", (0.0, dims.torso * m, 0.0)),
               "head": ("head", (0.0, dims.head * m, 0.0))}
    for side, s, i in (("r", 1.0, 1), ("l", -1.0, 0)):
        shoulder = (0.0, (dims.torso - dims.shoulder_drop[i]) * m, s * dims.shoulder_offset[i] * m)
        hip = (0.0, -dims.hip_drop[i] * m, s * dims.hip_offset[i] * m)
        joints[f"shoulder_{side}"] = shoulder
        joints[f"elbow_{side}"] = (0.0, -dims.upper_arm[i] * m, 0.0)
        joints[f"hip_{side}"] = hip
        joints[f"knee_{side}"] = (0.0, -dims.thigh[i] * m, 0.0)
        markers[f"{side}_shoulder"] = ("torso", shoulder)
        markers[f"{side}_elbow"] = (f"humerus_{side}", joints[f"elbow_{side}"])
        markers[f"{side}_wrist"] = (f"ulna_{side}", (0.0, -dims.forearm[i] * m, 0.0))
        markers[f"{side}_hip"] = ("pelvis", hip)
        markers[f"{side}_knee"] = (f"femur_{side}", joints[f"knee_{side}"])
        markers[f"{side}_ankle"] = (f"tibia_{side}", (0.0, -dims.shin[i] * m, 0.0))
    cones = {p.name: p for p in dims.parts()}
    parts = {"torso": (cones["torso"], 1.0), "head": (cones["head"], 1.0)}
    for side, vm in (("r", "r"), ("l", "l")):
        parts[f"humerus_{side}"] = (cones[f"{vm}_upper_arm"], -1.0)
        parts[f"ulna_{side}"] = (cones[f"{vm}_forearm"], -1.0)
        parts[f"femur_{side}"] = (cones[f"{vm}_thigh"], -1.0)
        parts[f"tibia_{side}"] = (cones[f"{vm}_shin"], -1.0)
    return Skeleton(joints, markers, parts)


def cone_mass_properties(part: Part, direction: float, density: float = DENSITY,
                         slices: int = 400):
    """Mass, centre of mass and central inertia of a truncated elliptic cone (SI units).

    The cone starts at the body origin and runs along ``direction`` · Y; its half-axis ``H`` lies
    along Z (the tracker's lateral axis ``u1``) and ``W`` along X (front-back, ``u2``). Summed
    over thin elliptic slices (midpoint rule): a slice of half-axes a (Z), b (X) and mass dm has
    central moments dm·(a² + b²)/4 about Y, dm·a²/4 about X and dm·b²/4 about Z.

    Returns
    -------
    mass : float
        kg.
    com : (3,) ndarray
        m, in the body frame.
    inertia : (3,) ndarray
        Ixx, Iyy, Izz (kg m²) about the centre of mass.
    """
    length = part.L * 1e-3
    t = (np.arange(slices) + 0.5) / slices * length
    scale = 1.0 + (part.R - 1.0) * t / length
    a, b = part.H * 1e-3 * scale, part.W * 1e-3 * scale
    dm = density * math.pi * a * b * (length / slices)
    mass = float(dm.sum())
    tc = float((dm * t).sum() / mass)
    along = (dm * (t - tc) ** 2).sum()
    inertia = np.array([(dm * a**2 / 4).sum() + along, (dm * (a**2 + b**2) / 4).sum(),
                        (dm * b**2 / 4).sum() + along])
    return mass, np.array([0.0, direction * tc, 0.0]), inertia


def build_model(dims: BodyDimensions, name: str = "voxelmocap_skeleton"):
    """The OpenSim model of a body (see the module docstring).

    Parameters
    ----------
    dims : BodyDimensions
    name : str
        The model's name.

    Returns
    -------
    opensim.Model
        Not yet initialised (call ``initSystem``).
    """
    import opensim as osim

    geometry = skeleton(dims)
    model = osim.Model()
    model.setName(name)
    model.set_length_units("meters")
    model.set_force_units("N")
    model.setGravity(osim.Vec3(0.0, -9.80665, 0.0))
    bodies = {"ground": model.getGround()}
    for joint_name, parent, child, coords in JOINTS:
        if child in geometry.parts:
            mass, com, inertia = cone_mass_properties(*geometry.parts[child])
        else:
            mass, com, inertia = 0.0, np.zeros(3), np.zeros(3)
        body = osim.Body(child, mass, osim.Vec3(*com), osim.Inertia(*inertia))
        model.addBody(body)
        bodies[child] = body
        transform = osim.SpatialTransform()
        for k, (coordinate, axis) in enumerate(coords):
            _axis(osim, transform.updTransformAxis(k), coordinate, axis, osim.LinearFunction())
        used = [tuple(abs(a) for a in axis) for _, axis in coords]
        spare = [axis for axis in (_X, _Y, _Z) if axis not in used]
        for k in range(len(coords), 3):  # unused rotations: the axes the others leave free
            _axis(osim, transform.updTransformAxis(k), None, spare[k - len(coords)],
                  osim.Constant(0.0))
        for k, axis in enumerate((_X, _Y, _Z)):
            coordinate = _TRANSLATIONS[k] if joint_name == "ground_pelvis" else None
            function = osim.LinearFunction() if coordinate else osim.Constant(0.0)
            _axis(osim, transform.updTransformAxis(3 + k), coordinate, axis, function)
        joint = osim.CustomJoint(joint_name, bodies[parent],
                                 osim.Vec3(*geometry.joint_in_parent[joint_name]), osim.Vec3(0.0),
                                 body, osim.Vec3(0.0), osim.Vec3(0.0), transform)
        model.addJoint(joint)
        for k in range(joint.numCoordinates()):
            coordinate = joint.upd_coordinates(k)
            base = coordinate.getName().rsplit("_", 1)[0]
            key = coordinate.getName() if coordinate.getName() in _RANGES_DEG else base
            if key in _RANGES_DEG:
                low, high = _RANGES_DEG[key]
                coordinate.setRangeMin(math.radians(low))
                coordinate.setRangeMax(math.radians(high))
            else:  # the pelvis' translations: a capture area
                coordinate.setRangeMin(-10.0)
                coordinate.setRangeMax(10.0)
            coordinate.setDefaultClamped(False)
    for marker, (body, where) in geometry.markers.items():
        model.addMarker(osim.Marker(marker, bodies[body], osim.Vec3(*where)))
    model.finalizeConnections()
    return model


def _axis(osim, transform_axis, coordinate, axis, function) -> None:
    if coordinate is not None:
        names = osim.ArrayStr()
        names.append(coordinate)
        transform_axis.setCoordinateNames(names)
    transform_axis.setAxis(osim.Vec3(*axis))
    # set_function copies: setFunction would take ownership of a Python-owned object (a crash)
    transform_axis.set_function(function)
