"""HumanEva-I raw motion capture → body_pose ground truth, as the toolkit's ``@mocap_stream`` does it.

A HumanEva-I subject folder holds, besides the videos, ``Mocap_Data/<Action>_<Trial>.mat`` (the
Vicon markers and the segment frames Vicon computed, written by the toolkit's ``readc3d``),
``Mocap_Data/Static.mat`` (the static trial) and ``Mocap_Data/<Subject>.mp`` (subject
measurements). This module reads them and turns them into the 20 body_pose endpoints with a port
of the toolkit's ``mocap_stream`` / ``cur_frame`` (:mod:`voxelmocap.io.humaneva_mocap_pose`),
synchronised to the video by ``sync_stream``'s common time and scaling
(:func:`voxelmocap.io.humaneva.sync_starts`). ``docs/humaneva_mocap.md`` lists the toolkit quirks
that are reproduced and the few places where this port must decide what the toolkit leaves open.

>>> stream = MocapStream.open("S1/Mocap_Data/Walking_1.mat", "S1/Mocap_Data/Static.mat",
...                           "S1/Mocap_Data/S1.mp")                          # doctest: +SKIP
>>> poses = stream.cur_frames(stream.positions(common_time, common_scaling, range(1, 100)))
... # doctest: +SKIP
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError
from ._files import read_text_file
from ._mat_guard import check_mat_sizes
from .body_pose_xml import MAX_COORDINATE, BodyPoseSequence
from .humaneva_mocap_pose import (
    FRAMES,
    LENGTH_PAIRS,
    VALIDITY_MARKERS,
    MarkerIndex,
    ToolkitPoses,
    toolkit_cur_frames,
)

__all__ = [
    "MP_KEYS",
    "MocapFiles",
    "MocapStream",
    "MocapTrial",
    "SubjectMeasurements",
    "find_labels",
    "find_mocap_files",
    "limb_parameters",
    "marker_index",
    "mocap_ground_truth",
    "poses_to_body_pose",
    "read_mocap_mat",
    "read_mp",
    "sequence_ground_truth",
]

#: The ``.mp`` keys ``ComputeLimbParameters`` reads (a missing one stops the toolkit).
MP_KEYS = ("LKneeWidth", "RKneeWidth", "LAnkleWidth", "RAnkleWidth", "LShoulderOffset",
           "RShoulderOffset", "LElbowWidth", "RElbowWidth", "LWristWidth", "RWristWidth",
           "HeadOffset")

#: Static-trial markers ``ComputeLimbParameters`` reads.
STATIC_MARKERS = ("LSHO", "RSHO", "STRN", "T10", "LBHD", "LFHD", "RFHD", "RBHD")

_MARKER_SIZE = 14.0  # the toolkit's assumed marker diameter (mm)


# ---------------------------------------------------------------------- label lookup
def _findstr(a: str, b: str) -> bool:
    """MATLAB ``~isempty(findstr(a, b))``: the shorter string occurs in the longer one."""
    if not a or not b:
        return False
    short, long = (a, b) if len(a) <= len(b) else (b, a)
    return short in long


def find_labels(labels: list[str], query: str) -> list[int]:
    """0-based indices of every label matching ``query`` the toolkit's way (``MarkerName2MarkerId``).

    QUIRK: matching is MATLAB ``findstr``, so a label that is a substring of the query matches as
    well as one that contains it (a label ``T1`` matches the query ``T10``), case-sensitively.
    """
    return [i for i, label in enumerate(labels) if _findstr(label, query)]


# ---------------------------------------------------------------------- .mat files
@dataclass
class MocapTrial:
    """One ``.mat`` file written by the toolkit's ``readc3d``.

    Attributes
    ----------
    path : Path
        The file.
    markers : (N, M, 3) float ndarray
        Marker trajectories, frame × marker × xyz, mm; a missing sample is (0, 0, 0).
    labels : list of str or None
        The ``POINT``/``LABELS`` parameter; None when the file has no ``ParameterGroup``.
    """

    path: Path
    markers: np.ndarray
    labels: list | None

    @property
    def n_frames(self) -> int:
        return int(self.markers.shape[0])


def _dim2_elements(arr: np.ndarray) -> list:
    """The elements MATLAB's ``for I = 1:size(x, 2)`` + ``x(I)`` visits (column-major)."""
    if arr.ndim < 2:
        arr = arr.reshape(1, -1)
    return list(arr.ravel(order="F")[: arr.shape[1]])


def _text(value) -> str | None:
    """A MATLAB string (or a 1×1 cell holding one) as str; None for anything else."""
    while isinstance(value, np.ndarray) and value.dtype == object:
        if value.size != 1:
            return None
        value = value.reshape(-1)[0]
    if isinstance(value, str):
        return value
    if isinstance(value, np.ndarray) and value.dtype.kind == "U":
        if value.size == 0:
            return ""
        if value.size == 1:
            return str(value.reshape(-1)[0])
    return None


def _field(record, name: str, path, what: str):
    names = getattr(getattr(record, "dtype", None), "names", None) or ()
    if name not in names:
        raise InputError(path, f"{what} has no '{name}' field")
    return record[name]


def _struct_array(value, path, what: str) -> np.ndarray:
    if not isinstance(value, np.ndarray) or value.dtype.names is None:
        raise InputError(path, f"{what} is not a MATLAB struct array")
    return value


def _labels_from_groups(groups, path) -> list[str]:
    """The ``POINT``/``LABELS`` data, found as ``MarkerName2MarkerId`` finds it."""
    groups = _struct_array(groups, path, "ParameterGroup")
    # QUIRK: the *last* group whose name findstr-matches POINT, then the *last* parameter whose
    # name matches LABELS; only size(·, 2) entries are visited.
    point = None
    for group in _dim2_elements(groups):
        if _findstr(_text(_field(group, "name", path, "ParameterGroup")) or "", "POINT"):
            point = group
    if point is None:
        raise InputError(path, "no POINT group in ParameterGroup (the marker labels)")
    params = _struct_array(_field(point, "Parameter", path, "the POINT group"), path,
                           "the POINT group's Parameter")
    labels_param = None
    for param in _dim2_elements(params):
        if _findstr(_text(_field(param, "name", path, "a POINT parameter")) or "", "LABELS"):
            labels_param = param
    if labels_param is None:
        raise InputError(path, "no LABELS parameter in the POINT group (the marker labels)")
    data = _field(labels_param, "data", path, "POINT/LABELS")
    if not isinstance(data, np.ndarray) or data.dtype != object:
        raise InputError(path, "POINT/LABELS data is not a cell array of marker labels")
    labels = []
    for i, item in enumerate(_dim2_elements(data)):
        label = _text(item)
        if label is None:
            raise InputError(path, f"POINT/LABELS entry {i + 1} is not text")
        labels.append(label)
    return labels


def read_mocap_mat(path, *, what: str = "mocap trial", need_labels: bool = True) -> MocapTrial:
    """Read a mocap ``.mat`` file (``Markers`` and the ``ParameterGroup`` labels).

    Parameters
    ----------
    path : str or os.PathLike
        The ``.mat`` file (MATLAB v4–v7; v7.3/HDF5 is refused).
    what : str
        What the file is, for messages.
    need_labels : bool
        Whether a missing ``ParameterGroup`` is an error (the static trial may lack it: the toolkit
        then uses the dynamic trial's).

    Raises
    ------
    InputError
        Missing or unreadable file, no ``Markers`` or not (N, M, 3) numbers, no ``ParameterGroup``
        (when needed), no ``POINT`` group or ``LABELS`` parameter, labels that are not text.
    """
    import scipy.io

    path = Path(path)
    if not path.is_file():
        if path.is_dir():
            raise InputError(path, f"is a folder, not a {what}")
        if path.is_symlink():
            raise InputError(path, f"is a symbolic link that leads nowhere (broken, or a loop), "
                                   f"not a {what}")
        raise InputError(path, f"{what} not found" if not path.exists() else f"is not a {what}")
    check_mat_sizes(path)  # what it declares must fit in it before SciPy allocates it
    try:
        data = scipy.io.loadmat(str(path), variable_names=["Markers", "ParameterGroup"])
    except NotImplementedError:
        raise InputError(path, "MATLAB v7.3 (HDF5) files are not supported; re-save it with "
                               "save(..., '-v7')") from None
    except Exception as exc:  # scipy raises many exception types on corrupt files
        raise InputError(path, f"cannot read the MAT file ({exc.__class__.__name__}: "
                               f"{' '.join(str(exc).split())[:120]})") from None
    if "Markers" not in data:
        raise InputError(path, "no 'Markers' variable (marker data must be present)")
    markers = data["Markers"]
    if not isinstance(markers, np.ndarray) or markers.dtype.kind not in "fiub" \
            or markers.ndim != 3 or markers.shape[2] != 3 or 0 in markers.shape:
        shape = getattr(markers, "shape", "?")
        raise InputError(path, f"'Markers' must be an N×M×3 array of numbers, got {shape} "
                               f"{getattr(markers, 'dtype', type(markers).__name__)}")
    labels = None
    if "ParameterGroup" in data:
        labels = _labels_from_groups(data["ParameterGroup"], path)
    elif need_labels:
        raise InputError(path, "no 'ParameterGroup' variable (the marker labels)")
    return MocapTrial(path=path, markers=np.asarray(markers, dtype=float), labels=labels)


def _one_marker(trial: MocapTrial, labels: list[str], query: str, purpose: str) -> int:
    found = find_labels(labels, query)
    if len(found) != 1:
        which = "no marker label matches" if not found else \
            f"{len(found)} marker labels ({', '.join(labels[i] for i in found[:4])}) match"
        raise InputError(trial.path, f"{which} '{query}' ({purpose}); the toolkit needs exactly "
                                     "one")
    if found[0] >= trial.markers.shape[1]:
        raise InputError(trial.path, f"label '{query}' is marker {found[0] + 1} but 'Markers' "
                                     f"holds {trial.markers.shape[1]}")
    return found[0]


def marker_index(trial: MocapTrial) -> MarkerIndex:
    """Resolve the columns ``cur_frame`` reads from the trial's labels.

    Raises
    ------
    InputError
        A segment origin or joint-centre label missing or ambiguous, its three axis points past
        the last marker, or a physical marker of the validity test missing.
    """
    if trial.labels is None:
        raise InputError(trial.path, "no marker labels")
    labels = trial.labels
    n_markers = trial.markers.shape[1]
    index = {}
    for name, coord, joint, _ in FRAMES:
        index[coord] = _one_marker(trial, labels, coord, f"origin of the {name} axis set")
        if index[coord] + 3 >= n_markers:
            raise InputError(trial.path, f"the {name} axis set needs the 3 markers after "
                                         f"'{coord}' (marker {index[coord] + 1} of {n_markers})")
        index[joint] = _one_marker(trial, labels, joint, f"joint centre of the {name}")
    for pair in LENGTH_PAIRS:
        for label in pair or ():
            index[label] = _one_marker(trial, labels, label, "limb length")
    validity = []
    for names in VALIDITY_MARKERS:
        names = (names,) if isinstance(names, str) else names
        found = sorted(i for n in names for i in find_labels(labels, n))
        if not found:
            raise InputError(trial.path, f"no marker label matches '{'/'.join(names)}' (one of "
                                         "the 39 physical markers the validity test reads)")
        if found[0] >= n_markers:
            raise InputError(trial.path, f"label '{labels[found[0]]}' is marker {found[0] + 1} "
                                         f"but 'Markers' holds {n_markers}")
        validity.append(found[0])  # QUIRK: the smallest matching index
    return MarkerIndex(label=index, validity=np.array(validity, dtype=int))


# ---------------------------------------------------------------------- .mp files
@dataclass
class SubjectMeasurements:
    """A Vicon ``.mp`` subject file: ``$Name = value`` entries in file order."""

    path: Path
    entries: list  #: [(name, value), …]

    def value(self, query: str) -> float:
        """The toolkit's ``readmp(file, query)``: the first entry whose name contains ``query``.

        QUIRK: the toolkit stores the names as rows of a char matrix padded with NUL to the
        longest name and compares rows with ``findstr``; a query longer than that width matches
        only a full-width name that it contains. Reproduced exactly.
        """
        width = max((len(n) for n, _ in self.entries), default=0)
        for name, val in self.entries:
            if _findstr(name + "\0" * (width - len(name)), query):
                return val
        raise InputError(self.path, f"no ${query} entry (ComputeLimbParameters needs it)")


_MP_LINE = re.compile(r"^[ \t]*\$[ \t]*([^\s=$]+)[ \t]*=[ \t]*([^\s=$]+)[ \t]*$")


def read_mp(path) -> SubjectMeasurements:
    """Read a ``.mp`` file: one ``$Name = number`` per line (blank lines are skipped).

    The toolkit tokenises the file on ``=``, ``$`` and space and takes the tokens in threes; any
    other line layout shifts its reading, so here it is an error naming the line.

    Raises
    ------
    InputError
        Missing or unreadable file, a line not of the form ``$Name = number``, or no entry.
    """
    path = Path(path)
    text = read_text_file(path, "subject file (.mp)", encoding="latin-1")
    entries = []
    for number, line in enumerate(text.splitlines(), start=1):
        if not line.strip():
            continue
        match = _MP_LINE.match(line)
        if match is None:
            raise InputError(path, f"line {number} is not '$Name = value': "
                                   f"{line.strip()[:40]!r}")
        try:
            value = float(match[2])
        except ValueError:
            raise InputError(path, f"line {number}: {match[2][:20]!r} is not a number") from None
        if not abs(value) <= MAX_COORDINATE:  # nan, inf, or no length a body has
            raise InputError(path, f"line {number}: {match[2][:20]!r} is not a finite number "
                                   "in range")
        entries.append((match[1], value))
    if not entries:
        raise InputError(path, "no '$Name = value' entries")
    return SubjectMeasurements(path=path, entries=entries)


# ---------------------------------------------------------------------- limb parameters
def _mean_distance(markers: np.ndarray, a: int, b: int) -> float:
    d = markers[:, a] - markers[:, b]
    dist = np.sqrt((d[:, 0] ** 2 + d[:, 1] ** 2) + d[:, 2] ** 2)
    return float(np.cumsum(dist)[-1] / len(dist))  # MATLAB's mean: a left-to-right sum


def limb_parameters(static: MocapTrial, mp: SubjectMeasurements) -> np.ndarray:
    """``ComputeLimbParameters``: the 10×5 conic parameters from the static trial and the ``.mp``.

    QUIRK: the torso radius Params(1,1) = mean |LSHO − RSHO| / 2 − 7 over *all* static frames,
    missing (0, 0, 0) samples included. The shoulder offsets Params(6,1) and Params(8,1) are the
    ``.mp`` values unhalved.

    Raises
    ------
    InputError
        A static marker missing, ambiguous or past the last marker; a missing ``.mp`` key.
    """
    labels = static.labels or []
    col = {m: _one_marker(static, labels, m, "static trial, ComputeLimbParameters")
           for m in STATIC_MARKERS}
    mk = static.markers
    values = {k: mp.value(k) for k in MP_KEYS}
    half = _MARKER_SIZE / 2.0
    p = np.zeros((10, 5))
    p[0, 0] = _mean_distance(mk, col["LSHO"], col["RSHO"]) / 2.0
    p[0, 0] = p[0, 0] - half
    p[0, 1] = p[0, 0]
    p[0, 2] = _mean_distance(mk, col["STRN"], col["T10"]) / (2 * p[0, 0])
    p[0, 3] = 1.0
    thigh_top = (p[0, 0] + half) / 2.0
    p[1, :4] = thigh_top, values["LKneeWidth"] / 2.0, 1.0, 1.0
    p[2, :4] = values["LKneeWidth"] / 2.0, values["LAnkleWidth"] / 2.0, 1.0, 1.0
    p[3, :4] = thigh_top, values["RKneeWidth"] / 2.0, 1.0, 1.0
    p[4, :4] = values["RKneeWidth"] / 2.0, values["RAnkleWidth"] / 2.0, 1.0, 1.0
    p[5, :4] = values["LShoulderOffset"], values["LElbowWidth"] / 2.0, 1.0, 1.0
    p[6, :4] = values["LElbowWidth"] / 2.0, values["LWristWidth"] / 2.0, 1.0, 1.0
    p[7, :4] = values["RShoulderOffset"], values["RElbowWidth"] / 2.0, 1.0, 1.0
    p[8, :4] = values["RElbowWidth"] / 2.0, values["RWristWidth"] / 2.0, 1.0, 1.0
    p[9, 0] = _mean_distance(mk, col["LBHD"], col["RFHD"]) / 2.0
    p[9, 1] = p[9, 0]
    p[9, 2] = 1.0
    p[9, 3] = _mean_distance(mk, col["LFHD"], col["RFHD"]) / (2 * p[9, 0])
    p[9, 4] = values["HeadOffset"] / 180 * np.pi
    return p


# ---------------------------------------------------------------------- the stream
@dataclass
class MocapStream:
    """The toolkit's ``mocap_stream``: a trial, its marker columns and the limb parameters."""

    trial: MocapTrial
    index: MarkerIndex
    params: np.ndarray  #: (10, 5)
    static_path: Path
    mp_path: Path

    @classmethod
    def open(cls, trial_path, static_path, mp_path) -> MocapStream:
        """Read the dynamic trial, the static trial and the ``.mp`` file (``mocap_stream``).

        QUIRK: a static ``.mat`` without ``ParameterGroup`` takes the trial's labels (the toolkit
        loads both files into one workspace).
        """
        trial = read_mocap_mat(trial_path)
        static = read_mocap_mat(static_path, what="static trial", need_labels=False)
        if static.labels is None:
            static.labels = trial.labels
        mp = read_mp(mp_path)
        return cls(trial=trial, index=marker_index(trial), params=limb_parameters(static, mp),
                   static_path=Path(static_path), mp_path=Path(mp_path))

    @property
    def n_frames(self) -> int:
        """Number of mocap samples N."""
        return self.trial.n_frames

    @staticmethod
    def positions(offset: float, scaling: float, frame_ids) -> np.ndarray:
        """Stream positions p = offset + (k − 1)·scaling of 1-based frame ids k (``cur_frame``)."""
        k = np.asarray(frame_ids, dtype=float)
        return offset + (k - 1) * scaling

    def cur_frames(self, positions) -> ToolkitPoses:
        """``cur_frame`` at each position (see :func:`toolkit_cur_frames`)."""
        return toolkit_cur_frames(self.trial.markers, self.index, self.params, positions)

    def synchronised_frames(self, common_time: float, common_scaling: float) -> np.ndarray:
        """Every synchronised frame F ≥ 1 whose position has ceil(p) ≤ N (not "empty")."""
        if not common_scaling > 0:
            raise InputError(self.trial.path, f"mocap scaling {common_scaling} is not positive")
        upper = int(max(0.0, np.floor((self.n_frames - common_time) / common_scaling))) + 3
        frames = np.arange(1, upper + 1)
        p = self.positions(common_time, common_scaling, frames)
        return frames[np.ceil(p) <= self.n_frames]


def poses_to_body_pose(poses: ToolkitPoses, frames, attributes: dict | None = None
                       ) -> BodyPoseSequence:
    """Toolkit results as a body_pose sequence (what the toolkit's ``exportXML`` would hold).

    * A frame the toolkit marks invalid has all 20 endpoints disabled (``Enabled = 0``), as
      ``cur_frame`` does.
    * A frame the toolkit cannot compute (``Bad marker data.``, or reading frame N + 1) is kept
      with every endpoint disabled and coordinates 0, so that it is counted as skipped.
    * An endpoint that is NaN (or beyond ±1e7 mm) on a valid frame — the toolkit yields NaN while
      valid = 1 when a limb has no sample left for its length — is disabled and set to 0: the XML
      format has no NaN, and the evaluation must skip it rather than propagate NaN.
    """
    ok = poses.status == "ok"
    if not np.all(ok | (poses.status == "error")):
        raise ValueError("empty rows (past the end of the mocap) have no pose")
    endpoints = poses.endpoints.copy()
    finite = np.all(np.isfinite(endpoints) & (np.abs(endpoints) <= MAX_COORDINATE), axis=-1)
    enabled = finite & (poses.valid & ok)[:, None]
    endpoints[~finite] = 0.0
    return BodyPoseSequence(frames=np.asarray(frames, dtype=int), endpoints=endpoints,
                            enabled=enabled, attributes=dict(attributes or {}),
                            errors=np.full(len(endpoints), -1.0))


# ---------------------------------------------------------------------- files of a sequence
@dataclass(frozen=True)
class MocapFiles:
    """The raw mocap files of one sequence (``static``/``mp`` are the expected paths, may be missing)."""

    trial: Path
    static: Path
    mp: Path

    def describe(self) -> str:
        return f"raw mocap {self.trial.name} + {self.mp.name}"


def _find_child(parent: Path, name: str, want_dir: bool) -> Path | None:
    if not parent.is_dir():
        return None
    exact = parent / name
    if (exact.is_dir() if want_dir else exact.is_file()):
        return exact
    for child in parent.iterdir():
        if child.name.lower() == name.lower() and (child.is_dir() if want_dir else
                                                   child.is_file()):
            return child
    return None


def find_mocap_files(subject_dir, subject: str, sequence: str) -> MocapFiles | None:
    """``Mocap_Data/<sequence>.mat``, ``Static.mat`` and ``<subject>.mp`` (names case-insensitive).

    Returns None when the trial ``.mat`` does not exist (a ``.c3d`` alone is not read: run the
    toolkit's ``readc3d`` once, or any C3D reader, to write the ``.mat``).
    """
    mocap_dir = _find_child(Path(subject_dir), "Mocap_Data", want_dir=True)
    if mocap_dir is None:
        return None
    trial = _find_child(mocap_dir, f"{sequence}.mat", want_dir=False)
    if trial is None:
        return None
    static = _find_child(mocap_dir, "Static.mat", want_dir=False) or mocap_dir / "Static.mat"
    mp = _find_child(mocap_dir, f"{subject}.mp", want_dir=False) or mocap_dir / f"{subject}.mp"
    return MocapFiles(trial=trial, static=static, mp=mp)


def mocap_ground_truth(files: MocapFiles, common_time: float, common_scaling: float,
                       attributes: dict | None = None) -> tuple[BodyPoseSequence, ToolkitPoses]:
    """Ground truth of every synchronised frame the mocap covers, and the raw toolkit results."""
    stream = MocapStream.open(files.trial, files.static, files.mp)
    frames = stream.synchronised_frames(common_time, common_scaling)
    poses = stream.cur_frames(stream.positions(common_time, common_scaling, frames))
    attrs = dict(attributes or {})
    if len(frames):
        attrs.update(FrameStart=int(frames[0]), FrameEnd=int(frames[-1]))
    attrs["Source"] = f"{files.describe()} (HumanEva toolkit mocap_stream, ported)"
    return poses_to_body_pose(poses, frames, attrs), poses


def sequence_ground_truth(seq) -> BodyPoseSequence | None:
    """Ground truth of a :class:`~voxelmocap.io.humaneva.Sequence` from its raw mocap, or None."""
    files = find_mocap_files(seq.subject_dir, seq.subject, seq.name)
    if files is None:
        return None
    attrs = {"DatasetName": "HumanEvaI", "SubjectName": seq.subject, "ActionType": seq.action,
             "Trial": seq.trial}
    return mocap_ground_truth(files, seq.common_time, seq.common_scaling, attrs)[0]
