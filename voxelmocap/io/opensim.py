"""The OpenSim hand-off (``export --opensim``): a scaled model, inverse kinematics, joint angles.

For one tracking result, :func:`export_opensim` writes (beside the result, or into ``out_dir``;
with a low-pass filter the stem carries ``_butterworth<f>Hz`` as the other exports do):

* ``<stem>_opensim.trc`` — the 15 landmarks as OpenSim wants them: Y up (Pose2Sim's ``zup2yup``:
  X ← world Y, Y ← world Z, Z ← world X), in metres, missing values ``NaN``;
* ``<stem>_scaled.osim`` — the skeleton model (:mod:`voxelmocap.io.opensim_model`) with the
  tracked body's dimensions (:func:`tracked_body`);
* ``<stem>.mot`` — the joint angles of OpenSim's inverse kinematics (InverseKinematicsSolver,
  the solver of OpenSim's IK tool) on those markers: one row per frame with a pose, time =
  (frame − 1) / frame rate (the data's rate; frames without a person are left out, so their
  time is missing), rotations in degrees (``inDegrees=yes``), the pelvis translation in metres;
* ``<stem>_ik_marker_errors.sto`` — per frame, each marker's distance from the model's (m), their
  root mean square and maximum (the columns of OpenSim's IK tool: ``marker_error_RMS``,
  ``marker_error_max``, ``total_squared_error``).

Inverse kinematics weighs every landmark alike (the 20 HumanEva endpoints are these same 15
joints, so they add nothing). The pelvis tilt is seen only through the hips hanging below the
pelvis marker: when they hang less than :data:`PELVIS_TILT_SEEN_MM` on either side (the body files
of rendered and HumanEva subjects: 0–10 mm), the pelvis markers lie on a line, the tilt trades
freely against the lumbar extension and the solver would leave it anywhere. A coordinate task
(:data:`LUMBAR_TASK_WEIGHT`) then holds the lumbar extension at 0: the pelvis takes the trunk's
(pelvis → thorax) sagittal orientation, and hip flexion is the thigh's angle from the trunk in
its sagittal plane. With hips hanging lower the markers decide alone (no task), and a tracked
pose is recovered exactly (measured: < 0.001° and < 0.001 mm with a 10 mm drop; with 5 mm the
tilt was already 0.8° off, with 2 mm 10°).

>>> export_opensim("RUN/S1/Walking_1.h5")        # doctest: +SKIP
OpenSimExport(...)
"""

from __future__ import annotations

import contextlib
import json
import logging
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..body.shapes import BodyDimensions
from ..errors import InputError
from ..joints import LANDMARK_NAMES

__all__ = ["LUMBAR_TASK_WEIGHT", "PELVIS_TILT_SEEN_MM", "IkSolution", "OpenSimExport",
           "export_opensim", "inverse_kinematics", "lumbar_task_weight", "opensim_paths",
           "require_opensim", "tracked_body"]

logger = logging.getLogger(__name__)

#: Hip drop (mm, both sides) from which the pelvis markers show the pelvis tilt (module docstring).
PELVIS_TILT_SEEN_MM = 10.0
#: Weight of the coordinate task holding lumbar_extension at 0 when they do not (rad⁻², against
#: the marker errors in m²). Smaller weights leave the solver short of the task's minimum: with
#: 1e-6 the lumbar extension of a rendered walk's ground truth wandered to 6–11°, with 1e-4 it
#: stayed within 0.03°.
LUMBAR_TASK_WEIGHT = 1e-4
#: Accuracy of the IK solver (OpenSim's IK tool default is 1e-5).
IK_ACCURACY = 1e-7
#: Largest difference (mm) between a segment length of the recorded body and the one the
#: landmarks show, before the landmarks' own lengths are used instead.
BODY_LENGTH_TOLERANCE_MM = 2.0


def require_opensim(source="--opensim"):
    """Import ``opensim``, or raise :class:`InputError` saying how to install it.

    OpenSim's logger writes every message also to ``opensim.log`` in the working directory; that
    file sink is removed, so an export leaves nothing but its outputs (messages still reach the
    console).
    """
    try:
        import opensim
    except ImportError:
        raise InputError(source, "needs the opensim package (pip install -e \".[opensim]\", "
                                 "OpenSim 4.6 from PyPI)") from None
    opensim.Logger.removeFileSink()
    return opensim


# ----------------------------------------------------------------------------------- the body
def _body_file(dataset, subject, name) -> Path | None:
    if not dataset or not subject or not name:
        return None
    subject_dir = Path(str(dataset)) / str(subject)
    if not subject_dir.is_dir():
        return None
    for folder in subject_dir.iterdir():
        if folder.is_dir() and folder.name.lower() == "mocap_data" and (folder / name).is_file():
            return folder / name
    return None


def _recorded_body(attrs, source) -> tuple[BodyDimensions | None, str]:
    text = attrs.get("body_dimensions")
    if text:
        try:
            data = {k: tuple(float(x) for x in v) if isinstance(v, list) else float(v)
                    for k, v in json.loads(str(text)).items()}
            return BodyDimensions(**data), "the body dimensions recorded in the result"
        except (ValueError, TypeError) as exc:
            raise InputError(source, f"body_dimensions is not a body's dimensions ({exc})") \
                from None
    described = str(attrs.get("body_model", ""))
    if described.startswith("subject body file "):
        from .body_file import read_body_file

        name = described[len("subject body file "):].split(";")[0].strip()
        path = _body_file(attrs.get("dataset"), attrs.get("subject"), name)
        if path is not None:
            return read_body_file(path), f"the subject body file {path}"
        return None, f"the subject body file {name} (not found beside the data set)"
    height = attrs.get("body_height_mm")
    if described.startswith("average adult scaled") and height is not None:
        return BodyDimensions.average(float(height)), f"the {described}"
    if described.startswith("average adult (no body file"):
        return BodyDimensions.average(), "the average adult"
    return None, described or "no body recorded"


def _measured_lengths(landmarks) -> dict:
    """Median segment lengths (mm) the landmarks show, per body-file key."""
    idx = {n: i for i, n in enumerate(LANDMARK_NAMES)}
    lm = np.asarray(landmarks, float)
    lm = lm[np.isfinite(lm).all(axis=(1, 2))]

    def dist(a, b):
        return float(np.median(np.linalg.norm(lm[:, idx[a]] - lm[:, idx[b]], axis=1)))

    return {"torso": (dist("thorax", "pelvis"),), "head": (dist("head", "thorax"),),
            **{key: (dist(f"l_{a}", f"l_{b}"), dist(f"r_{a}", f"r_{b}"))
               for key, (a, b) in {"upper_arm": ("shoulder", "elbow"),
                                   "forearm": ("elbow", "wrist"), "thigh": ("hip", "knee"),
                                   "shin": ("knee", "ankle")}.items()}}


def tracked_body(result, source="result") -> tuple[BodyDimensions, str]:
    """The body a result was tracked with, and a phrase saying where it came from.

    In order: the ``body_dimensions`` the result records (a fitted or inherited body); the
    subject body file it names (``Mocap_Data/<Subject>_body.toml`` under the recorded data set,
    when it is still there); the average adult scaled to the recorded height. The segment lengths
    are checked against the landmarks of the frames with a person (a tracked pose is a pose of
    the tracked body, so they agree to rounding); when nothing is recorded, or the lengths
    disagree by more than :data:`BODY_LENGTH_TOLERANCE_MM` (a body file edited since), the body
    is measured from the landmarks themselves (:meth:`BodyDimensions.from_landmarks`, medians
    over the frames).

    Parameters
    ----------
    result : TrackResult
    source : str or os.PathLike
        Named in messages.
    """
    usable = np.isfinite(result.landmarks).all(axis=(1, 2)) & np.asarray(result.observed, bool)
    if not usable.any():
        raise InputError(source, "no frame with a person and all 15 landmarks: no body to build "
                                 "and nothing for OpenSim to fit")
    landmarks = result.landmarks[usable]
    dims, where = _recorded_body(result.attrs, source)
    if dims is not None:
        measured = _measured_lengths(landmarks)
        worst = max(abs(np.atleast_1d(getattr(dims, k)) - np.asarray(v)).max()
                    for k, v in measured.items())
        if worst <= BODY_LENGTH_TOLERANCE_MM:
            return dims, where
        where = f"{where} differs from the landmarks by up to {worst:.1f} mm"
    logger.warning(f"{source}: {where}; the body is measured from the tracked landmarks")
    return (BodyDimensions.from_landmarks(landmarks, source=str(source)),
            "measured from the tracked landmarks")


# ------------------------------------------------------------------------ inverse kinematics
def lumbar_task_weight(dims: BodyDimensions) -> float:
    """:data:`LUMBAR_TASK_WEIGHT` when the pelvis markers cannot show the tilt, else 0."""
    return LUMBAR_TASK_WEIGHT if min(dims.hip_drop) < PELVIS_TILT_SEEN_MM else 0.0


@dataclass
class IkSolution:
    """Inverse kinematics of one marker file."""

    time: np.ndarray  #: (K,) s, the rows with markers
    coordinates: np.ndarray  #: (K, 27) rad (rotations) and m (pelvis translation)
    coordinate_names: list  #: the 27 names, :data:`~.opensim_model.COORDINATES` order
    marker_errors: np.ndarray  #: (K, 15) m, NaN where a marker is missing
    marker_names: list  #: the 15 marker names

    @property
    def marker_rms(self) -> np.ndarray:
        """(K,) m: root mean square of each row's marker errors (missing markers left out)."""
        return np.sqrt(np.nanmean(self.marker_errors**2, axis=1))


def _start_pose(model, state, markers: dict) -> None:
    """Put the pelvis on its markers (position, heading), the rest at 0, before assembling."""
    cs = model.getCoordinateSet()
    for i in range(cs.getSize()):
        cs.get(i).setValue(state, 0.0, False)
    pelvis, left, right = (markers.get(k) for k in ("pelvis", "l_hip", "r_hip"))
    if pelvis is not None:
        for k, name in enumerate(("pelvis_tx", "pelvis_ty", "pelvis_tz")):
            cs.get(name).setValue(state, float(pelvis[k]), False)
    if left is not None and right is not None:
        across = right - left  # the body's +Z; pelvis_rotation ψ turns Z to (sin ψ, 0, cos ψ)
        cs.get("pelvis_rotation").setValue(state, math.atan2(across[0], across[2]), False)
    model.assemble(state)


def inverse_kinematics(model, trc_path, *, lumbar_weight: float = 0.0,
                       accuracy: float = IK_ACCURACY) -> IkSolution:
    """OpenSim inverse kinematics of a TRC file on a model.

    Every frame with at least one marker is solved; missing markers are left out of their frame.
    The first frame of each stretch of frames starts from the pelvis on its markers and is
    assembled; the following ones are tracked from the previous solution.

    Parameters
    ----------
    model : opensim.Model
    trc_path : str or os.PathLike
        Markers named as the model's, in the units the file states.
    lumbar_weight : float
        Weight of the coordinate task holding ``lumbar_extension`` at 0 (module docstring,
        :func:`lumbar_task_weight`); 0 leaves it out.
    accuracy : float
        The solver's accuracy.

    Returns
    -------
    IkSolution
    """
    import opensim as osim

    state = model.initSystem()
    table = osim.TimeSeriesTableVec3(str(trc_path))
    names = list(table.getColumnLabels())
    times = np.array(table.getIndependentColumn())
    values = np.array([[[table.getRowAtIndex(i)[j][k] for k in range(3)]
                        for j in range(len(names))] for i in range(table.getNumRows())])
    present = np.isfinite(values).all(axis=2)
    units = table.getTableMetaDataAsString("Units") if table.hasTableMetaDataKey("Units") else "m"
    to_metres = {"mm": 1e-3, "cm": 1e-2, "m": 1.0}.get(units.strip().lower(), 1.0)
    weights = osim.SetMarkerWeights()
    for name in names:
        weights.cloneAndAppend(osim.MarkerWeight(name, 1.0))
    references = osim.MarkersReference(table, weights)
    tasks = osim.SimTKArrayCoordinateReference()
    if lumbar_weight > 0:
        task = osim.CoordinateReference("lumbar_extension", osim.Constant(0.0))
        task.setWeight(lumbar_weight)
        tasks.push_back(task)
    solver = osim.InverseKinematicsSolver(model, references, tasks, math.inf)
    solver.setAccuracy(accuracy)
    coordinate_set = model.getCoordinateSet()
    coordinate_names = [coordinate_set.get(i).getName() for i in range(coordinate_set.getSize())]
    rows = np.flatnonzero(present.any(axis=1))
    coordinates = np.full((len(rows), len(coordinate_names)), np.nan)
    errors = np.full((len(rows), len(names)), np.nan)
    previous = None
    for out, i in enumerate(rows):
        state.setTime(float(times[i]))
        if previous is None or i != previous + 1:  # a new stretch: start afresh
            _start_pose(model, state, {n: values[i, j] * to_metres
                                       for j, n in enumerate(names) if present[i, j]})
            solver.assemble(state)
        else:
            solver.track(state)
        previous = i
        coordinates[out] = [coordinate_set.get(k).getValue(state)
                            for k in range(len(coordinate_names))]
        current = osim.SimTKArrayDouble()
        solver.computeCurrentMarkerErrors(current)
        for k in range(solver.getNumMarkersInUse()):
            name = solver.getMarkerNameForIndex(k)
            if present[i, names.index(name)]:
                errors[out, names.index(name)] = current.getElt(k)
    return IkSolution(times[rows], coordinates, coordinate_names, errors, names)


# -------------------------------------------------------------------------------- the files
@dataclass
class OpenSimExport:
    """What :func:`export_opensim` wrote and how well the model fits."""

    paths: list  #: the TRC, the model, the motion, the marker errors
    body: str  #: where the body's dimensions came from
    marker_rms_mm: np.ndarray  #: (K,) per solved frame
    frames: int  #: frames solved


def opensim_paths(result_path, cutoff_hz: float | None = None, out_dir=None) -> dict:
    """The files :func:`export_opensim` writes (module docstring), by kind."""
    result_path = Path(result_path)
    folder = result_path.parent if out_dir is None else Path(out_dir)
    stem = result_path.stem + ("" if cutoff_hz is None else f"_butterworth{cutoff_hz:g}Hz")
    return {"trc": folder / f"{stem}_opensim.trc", "model": folder / f"{stem}_scaled.osim",
            "motion": folder / f"{stem}.mot",
            "errors": folder / f"{stem}_ik_marker_errors.sto"}


def _table(osim, time, columns, labels, metadata: dict):
    table = osim.TimeSeriesTable()
    table.setColumnLabels(labels)
    for t, row in zip(time, columns, strict=True):
        table.appendRow(float(t), osim.RowVector([float(v) for v in row]))
    for key, value in metadata.items():
        table.addTableMetaDataString(key, str(value))
    return table


def export_opensim(result_path, *, cutoff_hz: float | None = None, order: int = 4, out_dir=None,
                   result=None, body=None) -> OpenSimExport:
    """Write the OpenSim hand-off of one result (module docstring).

    Parameters
    ----------
    result_path : str or os.PathLike
        ``RUN/<Subject>/<Action>_<Trial>.h5``.
    cutoff_hz, order
        Zero-lag Butterworth low-pass of the landmarks first (as for the other exports).
    out_dir : str or os.PathLike, optional
        Folder of the files (default: the result's).
    result : TrackResult, optional
        The result, when already read.
    body : (BodyDimensions, str), optional
        :func:`tracked_body` of the result, when already found.

    Returns
    -------
    OpenSimExport

    Raises
    ------
    InputError
        No ``opensim`` package, a result without any complete frame, an output that cannot be
        written. Every file is written to a temporary name and renamed when complete.
    """
    from ._atomic import atomic_path
    from .exports import landmark_table
    from .opensim_model import build_model
    from .results import read_result
    from .trc import write_trc

    osim = require_opensim()
    result = read_result(result_path) if result is None else result
    table = landmark_table(result, cutoff_hz=cutoff_hz, order=order, axes="y_up",
                           source=result_path)
    dims, body = tracked_body(result, result_path) if body is None else body
    paths = opensim_paths(result_path, cutoff_hz, out_dir)
    model = build_model(dims, name=f"voxelmocap_{Path(result_path).stem}")
    model.set_credits(f"voxelmocap: the tracked skeleton of {Path(result_path).name}; body: "
                      f"{body}")
    with contextlib.ExitStack() as stack:
        # every file under a temporary name, all renamed once the last one is written
        tmp = {kind: stack.enter_context(atomic_path(path)) for kind, path in paths.items()}
        write_trc(tmp["trc"], table.positions, table.names, frame_rate=table.frame_rate,
                  frames=table.frames, axes="y_up", units="m", file_name=paths["trc"].name)
        solution = inverse_kinematics(model, tmp["trc"], lumbar_weight=lumbar_task_weight(dims))
        model.printToXML(str(tmp["model"]))
        rotational = [model.getCoordinateSet().get(n).getMotionType()
                      == osim.Coordinate.Rotational for n in solution.coordinate_names]
        angles = np.where(rotational, np.degrees(solution.coordinates), solution.coordinates)
        motion = _table(osim, solution.time, angles, solution.coordinate_names,
                        {"inDegrees": "yes", "DataRate": f"{table.frame_rate:g}",
                         "source": f"voxelmocap export --opensim of {Path(result_path).name}"})
        osim.STOFileAdapter.write(motion, str(tmp["motion"]))
        squared = np.nansum(solution.marker_errors**2, axis=1)
        summary = np.column_stack([solution.marker_errors, squared, solution.marker_rms,
                                   np.nanmax(solution.marker_errors, axis=1)])
        errors = _table(osim, solution.time, summary,
                        [*solution.marker_names, "total_squared_error", "marker_error_RMS",
                         "marker_error_max"], {"inDegrees": "no", "units": "m"})
        osim.STOFileAdapter.write(errors, str(tmp["errors"]))
    return OpenSimExport(list(paths.values()), body, solution.marker_rms * 1000.0,
                         len(solution.time))
