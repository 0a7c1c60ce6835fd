"""Synthetic HumanEva-I raw mocap files (``.mat`` as ``readc3d`` writes them, ``.mp``) for the tests.

The label layout follows ``humaneva_toolkit_vectors/README.md`` §3.1: 39 physical markers, 7 model
outputs, then 19 segments as ``<SEG>O, <SEG>P, <SEG>A, <SEG>L`` (origin, then points on the local
z, x and y axes).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import scipy.io
from scipy.spatial.transform import Rotation

PHYSICAL = ["LFHD", "RFHD", "LBHD", "RBHD", "C7", "T10", "CLAV", "STRN", "RBAK", "LSHO", "LUPA",
            "LELB", "LFRM", "LWRA", "LWRB", "LFIN", "RSHO", "RUPA", "RELB", "RFRA", "RWRA", "RWRB",
            "RFIN", "LASI", "RASI", "LPSI", "RPSI", "LTHI", "LKNE", "LTIB", "LANK", "LHEE", "LTOE",
            "RTHI", "RKNE", "RTIB", "RANK", "RHEE", "RTOE"]
MODEL = ["LHipAngles", "RHipAngles", "LKneeAngles", "RKneeAngles", "LShoulderAngles",
         "RShoulderAngles", "CentreOfMass"]
SEGMENTS = ["PEL", "TRX", "HED", "LCL", "LHU", "LRA", "LHN", "RCL", "RHU", "RRA", "RHN", "LFE",
            "LTI", "LFO", "LTO", "RFE", "RTI", "RFO", "RTO"]
LABELS = PHYSICAL + MODEL + [s + suffix for s in SEGMENTS for suffix in "OPAL"]

MP_VALUES = {"Bodymass": 71.8, "Height": 1776, "LKneeWidth": 104, "RKneeWidth": 102.5,
             "LAnkleWidth": 72, "RAnkleWidth": 71, "LShoulderOffset": 46.5, "RShoulderOffset": 44,
             "LElbowWidth": 68, "RElbowWidth": 69.5, "LWristWidth": 55, "RWristWidth": 54,
             "HeadOffset": 12.5}

#: Rough segment origins of a standing subject (mm, z up).
_ORIGINS = {"PEL": (0, 0, 950), "TRX": (0, 0, 1450), "HED": (0, 0, 1550), "LCL": (0, 170, 1420),
            "LHU": (0, 190, 1130), "LRA": (0, 200, 880), "LHN": (0, 200, 800),
            "RCL": (0, -170, 1420), "RHU": (0, -190, 1130), "RRA": (0, -200, 880),
            "RHN": (0, -200, 800), "LFE": (0, 90, 480), "LTI": (0, 90, 80), "LFO": (60, 90, 40),
            "LTO": (150, 90, 20), "RFE": (0, -90, 480), "RTI": (0, -90, 80), "RFO": (60, -90, 40),
            "RTO": (150, -90, 20)}


def synthetic_markers(rotations, shifts, *, seed: int = 0) -> np.ndarray:
    """``(N, 122, 3)`` markers: every segment frame rotated by ``rotations[n]`` (scipy Rotation,
    applied to the segment's local axes) and shifted by ``shifts[n]``; physical markers random."""
    rng = np.random.default_rng(seed)
    n = len(shifts)
    markers = np.zeros((n, len(LABELS), 3))
    physical = rng.uniform(-300, 300, size=(len(PHYSICAL), 3)) + (0, 0, 1000)
    for f in range(n):
        markers[f, : len(PHYSICAL)] = physical + shifts[f]
        markers[f, len(PHYSICAL): len(PHYSICAL) + len(MODEL)] = rng.uniform(-90, 90, (7, 3))
        axes = rotations[f].as_matrix()  # columns: local x, y, z in world coordinates
        for s, seg in enumerate(SEGMENTS):
            base = len(PHYSICAL) + len(MODEL) + 4 * s
            origin = np.asarray(_ORIGINS[seg], float) + shifts[f]
            markers[f, base] = origin
            markers[f, base + 1] = origin + 100 * axes[:, 2]  # P: local z
            markers[f, base + 2] = origin + 100 * axes[:, 0]  # A: local x
            markers[f, base + 3] = origin + 100 * axes[:, 1]  # L: local y
    return markers


def standing_markers(n_frames: int = 3, *, seed: int = 0) -> np.ndarray:
    """A slowly turning subject: ``(n_frames, 122, 3)``."""
    rots = [Rotation.from_euler("zx", [10 + 7 * f, 3 * f], degrees=True) for f in range(n_frames)]
    shifts = [np.array([5.0 * f, 2.0 * f, 0.0]) for f in range(n_frames)]
    return synthetic_markers(rots, shifts, seed=seed)


def _cell(items) -> np.ndarray:
    out = np.empty((1, len(items)), dtype=object)
    for i, item in enumerate(items):
        out[0, i] = item
    return out


def _struct(rows: list[dict]) -> np.ndarray:
    names = list(rows[0])
    out = np.empty((1, len(rows)), dtype=[(n, object) for n in names])
    for i, row in enumerate(rows):
        for n in names:
            out[0, i][n] = row[n]
    return out


def parameter_groups(labels, *, point_name: str = "POINT", labels_name: str = "LABELS"):
    """A ``readc3d``-style 1×G ``ParameterGroup`` struct array with the labels in POINT/LABELS."""
    def param(name, data, dim):
        return {"name": _cell([name]), "datatype": np.array([[-1.0]]), "dim": np.array([dim], float),
                "data": data, "description": _cell([""])}

    point = [param("USED", np.array([[len(labels)]], float), [1]),
             param(labels_name, _cell(list(labels)), [30, len(labels)]),
             param("UNITS", _cell(["mm"]), [2])]
    analog = [param("USED", np.array([[0.0]]), [1])]
    return _struct([{"name": _cell([point_name]), "description": _cell(["points"]),
                     "Parameter": _struct(point)},
                    {"name": _cell(["ANALOG"]), "description": _cell(["analog"]),
                     "Parameter": _struct(analog)}])


def write_mocap_mat(path, markers, labels=LABELS, *, groups=True, compress=True, **extra) -> Path:
    """Write a ``.mat`` as the toolkit's ``readc3d`` + ``save`` would (``groups=False``: no
    ``ParameterGroup``; ``markers=None``: no ``Markers``)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    data = {"VideoFrameRate": np.array([[120.0]]), "AnalogSignals": np.zeros((0, 0)),
            "AnalogFrameRate": np.array([[0.0]]), "Event": np.zeros((0, 0))}
    if markers is not None:
        data["Markers"] = np.asarray(markers, float)
    if groups is True:
        data["ParameterGroup"] = parameter_groups(labels)
    elif groups is not False:
        data["ParameterGroup"] = groups
    data.update(extra)
    scipy.io.savemat(str(path), data, do_compression=compress, oned_as="row")
    # SciPy writes the time of writing into the header's text: a fixed text instead, so the
    # same call gives the same bytes (the fuzz tests mutate these bytes: their draws must not
    # depend on the clock)
    raw = bytearray(Path(path).read_bytes())
    raw[:116] = b"MATLAB 5.0 MAT-file, written by voxelmocap's tests".ljust(116)
    Path(path).write_bytes(bytes(raw))
    return path


def write_mp(path, values=None, *, drop=()) -> Path:
    """Write a ``.mp`` subject file (``$Name = value`` lines), leaving out the keys in ``drop``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    values = MP_VALUES if values is None else values
    path.write_text("".join(f"${k} = {v:g}\n" for k, v in values.items() if k not in drop))
    return path


def write_subject_mocap(subject_dir, subject: str, sequence: str, markers, static=None) -> None:
    """``Mocap_Data/<sequence>.mat``, ``Static.mat`` and ``<subject>.mp`` under ``subject_dir``."""
    mdir = Path(subject_dir) / "Mocap_Data"
    write_mocap_mat(mdir / f"{sequence}.mat", markers)
    write_mocap_mat(mdir / "Static.mat", standing_markers(4, seed=1) if static is None else static,
                    compress=False)
    write_mp(mdir / f"{subject}.mp")
