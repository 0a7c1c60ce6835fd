"""export --opensim: the OpenSim model, inverse kinematics and joint angles, against three truths.

* the tracker's own forward kinematics (``voxelmocap.body``): IK on the landmarks of known states
  must give back those states' angles (a tracked pose is a pose of the model);
* the rendered walk's ground-truth landmarks: knee and hip flexion computed in closed form from
  the points must equal OpenSim's angles on the same points;
* a tracked rendered walk (the acceptance): OpenSim reads the files back, the markers fit, and
  knee and hip flexion agree with the ground truth's within the tracking error's reach.
"""

import importlib.util
import json
from dataclasses import asdict

import numpy as np
import pytest

from voxelmocap.body import BodyModel
from voxelmocap.body.shapes import BodyDimensions
from voxelmocap.body.state import STATE_INDEX
from voxelmocap.cli import main
from voxelmocap.errors import InputError
from voxelmocap.evaluation import hip_flexion, knee_flexion
from voxelmocap.io.body_pose_xml import read_body_pose_xml
from voxelmocap.io.exports import landmark_table
from voxelmocap.io.opensim import opensim_paths, tracked_body
from voxelmocap.io.results import TrackResult, read_result, write_result
from voxelmocap.joints import LANDMARK_NAMES, endpoints_to_landmarks

_I = {name: i for i, name in enumerate(LANDMARK_NAMES)}


def _result(path, landmarks, *, frames=None, rate=50.0, attrs=None, observed=None):
    n = len(landmarks)
    frames = np.arange(1, n + 1) if frames is None else np.asarray(frames)
    res = TrackResult(
        frames=frames, state=np.zeros((n, 27)), landmarks=np.asarray(landmarks, float),
        endpoints=np.zeros((n, 20, 3)), part_scores=np.zeros((n, 10, 4)), ess=np.ones((n, 1)),
        betas=np.ones((n, 1)), seconds=np.ones(n), log_likelihood=np.zeros(n),
        map_state=np.zeros((n, 27)), state_names=[f"s{i}" for i in range(27)],
        part_names=[f"p{i}" for i in range(10)],
        attrs={"frame_rate": rate, "complete": True, **(attrs or {})}, observed=observed)
    write_result(path, res)
    return res


def _body_attrs(dims):
    return {"body_dimensions": json.dumps(asdict(dims)), "body_model": "fitted"}


def _read_table(osim, path):
    """(times, {column: values}) of an OpenSim .mot / .sto, read by OpenSim."""
    table = osim.TimeSeriesTable(str(path))
    labels = list(table.getColumnLabels())
    values = np.array([[table.getRowAtIndex(i)[j] for j in range(len(labels))]
                       for i in range(table.getNumRows())])
    return np.array(table.getIndependentColumn()), dict(zip(labels, values.T, strict=True))


# ------------------------------------------------------------------------------ no opensim
def test_the_tracked_body_comes_from_the_result_and_is_checked(tmp_path, caplog):
    dims = BodyDimensions.average(1700.0).replace(thigh=(400.0, 410.0), hip_drop=(0.0, 5.0))
    model = BodyModel(dims)
    lm = model.landmarks(np.tile(model.default_state(), (3, 1)))
    res = _result(tmp_path / "a.h5", lm, attrs=_body_attrs(dims))
    assert tracked_body(res) == (dims, "the body dimensions recorded in the result")
    # a body file named by the result, under the recorded data set
    from voxelmocap.io.body_file import write_body_file

    (tmp_path / "data" / "S2" / "Mocap_Data").mkdir(parents=True)
    write_body_file(tmp_path / "data" / "S2" / "Mocap_Data" / "S2_body.toml", dims, "S2")
    res.attrs = {"body_model": "subject body file S2_body.toml", "subject": "S2",
                 "dataset": str(tmp_path / "data"), "frame_rate": 50.0}
    found, where = tracked_body(res)
    assert where.endswith("S2_body.toml") and found.thigh == (400.0, 410.0)
    # landmarks of another body: the file is not trusted, the landmarks' lengths are used
    other = BodyModel(dims.replace(shin=(380.0, 380.0)))
    res.landmarks = other.landmarks(np.tile(other.default_state(), (3, 1)))
    found, where = tracked_body(res, "a.h5")
    assert where == "measured from the tracked landmarks"
    assert found.shin == pytest.approx((380.0, 380.0)) and "differs" in caplog.text
    res.landmarks[:] = np.nan
    with pytest.raises(InputError, match="no frame with a person and all 15 landmarks"):
        tracked_body(res, "a.h5")


def test_without_opensim_the_command_says_how_to_install_it(tmp_path, monkeypatch, capsys):
    import sys

    model = BodyModel()
    _result(tmp_path / "a.h5", model.landmarks(model.default_state()[None]))
    monkeypatch.setitem(sys.modules, "opensim", None)  # import opensim → ImportError
    assert main(["export", str(tmp_path / "a.h5"), "--opensim"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--opensim" in err[0] and ".[opensim]" in err[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.h5"]


# ---------------------------------------------------------------------------- with opensim
osim_needed = pytest.mark.skipif(
    importlib.util.find_spec("opensim") is None,
    reason="the opensim package is not installed (pip install -e \".[opensim]\")")
if importlib.util.find_spec("opensim") is not None:
    # the models these tests load back would log to ./opensim.log (the checkout) otherwise
    from voxelmocap.io.opensim import require_opensim

    require_opensim()


def _moving_states(model, n, seed):
    """``n`` legal states sweeping every joint smoothly (a different phase per joint)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / n
    x = np.tile(model.default_state(), (n, 1))
    x[:, 0], x[:, 1] = 300 * np.sin(2 * np.pi * t), 600 * t
    x[:, 3] = 2.5 + 0.4 * np.sin(2 * np.pi * t)
    spans = {"root_pitch": (-10, 10), "root_roll": (-8, 8), "waist_flex": (-10, 30),
             "waist_side": (-10, 10), "waist_twist": (-20, 20), "neck_flex": (-20, 20),
             "neck_side": (-15, 15), "elbow": (20, 110), "knee": (10, 90),
             "shoulder_flex": (-30, 70), "shoulder_abd": (5, 40), "shoulder_rot": (-30, 30),
             "hip_flex": (-20, 60), "hip_abd": (-10, 20), "hip_rot": (-20, 20)}
    for name, i in STATE_INDEX.items():
        key = name.split("_", 1)[1] if name[:2] in ("l_", "r_") else name
        if key in spans:
            lo, hi = np.radians(spans[key])
            x[:, i] = lo + (hi - lo) * (0.5 + 0.5 * np.sin(2 * np.pi * t + rng.uniform(0, 6.3)))
    return x


def _expected_coordinates(x):
    """The model's coordinates (degrees; pelvis translation in m) of tracker states ``x``
    (the correspondence of ``voxelmocap.io.opensim_model``'s docstring)."""
    d = np.degrees
    out = {"pelvis_rotation": d(x[:, 3]), "pelvis_tilt": -d(x[:, 4]), "pelvis_list": d(x[:, 5]),
           "pelvis_tx": x[:, 1] / 1000, "pelvis_ty": x[:, 2] / 1000, "pelvis_tz": x[:, 0] / 1000,
           "lumbar_extension": -d(x[:, 6]), "lumbar_bending": d(x[:, 7]),
           "lumbar_rotation": d(x[:, 8]), "neck_extension": -d(x[:, 9]),
           "neck_bending": d(x[:, 10])}
    for side in "lr":
        for ours, theirs, sign in (("arm_flex", "shoulder_flex", 1), ("arm_add", "shoulder_abd", -1),
                                   ("arm_rot", "shoulder_rot", 1), ("hip_flexion", "hip_flex", 1),
                                   ("hip_adduction", "hip_abd", -1),
                                   ("hip_rotation", "hip_rot", 1)):
            out[f"{ours}_{side}"] = sign * d(x[:, STATE_INDEX[f"{side}_{theirs}"]])
        out[f"elbow_flex_{side}"] = d(x[:, STATE_INDEX[f"{side}_elbow"]])
        out[f"knee_angle_{side}"] = d(x[:, STATE_INDEX[f"{side}_knee"]])
    return out


@osim_needed
def test_inverse_kinematics_gives_back_the_tracker_poses(tmp_path):
    """Landmarks of known tracker states (an asymmetric body whose hips hang 25/35 mm below the
    pelvis, so the markers show the pelvis tilt): every coordinate comes back."""
    import opensim as osim

    dims = BodyDimensions.average(1650.0).replace(
        hip_drop=(25.0, 35.0), shoulder_offset=(170.0, 180.0), forearm=(240.0, 250.0))
    model = BodyModel(dims)
    x = _moving_states(model, 12, seed=0)
    _result(tmp_path / "a.h5", model.landmarks(x), attrs=_body_attrs(dims))
    assert main(["export", str(tmp_path / "a.h5"), "--opensim"]) == 0
    paths = opensim_paths(tmp_path / "a.h5")
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        ["a.h5", *(p.name for p in paths.values())])
    loaded = osim.Model(str(paths["model"]))
    loaded.initSystem()
    assert loaded.getNumCoordinates() == 27 and loaded.getMarkerSet().getSize() == 15
    time, mot = _read_table(osim, paths["motion"])
    np.testing.assert_allclose(time, np.arange(12) / 50.0, atol=1e-6)  # the data's rate
    for name, expected in _expected_coordinates(x).items():
        tol = 1e-5 if name.endswith(("_tx", "_ty", "_tz")) else 0.01  # m, degrees
        np.testing.assert_allclose(mot[name], expected, rtol=0, atol=tol, err_msg=name)
    _, errors = _read_table(osim, paths["errors"])
    assert errors["marker_error_RMS"].max() < 1e-5  # m
    assert osim.Storage(str(paths["motion"])).isInDegrees()


@osim_needed
def test_angles_of_the_ground_truth_equal_the_closed_form(walk_dataset, tmp_path):
    """OpenSim on the rendered walk's ground-truth landmarks gives the knee and hip flexion
    computed from the points. The truth's pelvis marker is the hips' midpoint (they lie on a
    line), so the lumbar task applies and hip flexion is measured from the trunk, as the closed
    form does. Tolerance 0.5°: the model's segments are the truth's median lengths, which moves
    its joints by a little over a millimetre (the marker RMS below), 0.2° over a 430 mm shank."""
    import opensim as osim

    gt = read_body_pose_xml(walk_dataset / "S1" / "Mocap_Data" / "Walking_1.xml")
    lm = endpoints_to_landmarks(gt.endpoints)
    dims = BodyDimensions.from_landmarks(lm)
    assert max(dims.hip_drop) < 10.0
    _result(tmp_path / "gt.h5", lm, frames=gt.frames, attrs=_body_attrs(dims))
    assert main(["export", str(tmp_path / "gt.h5"), "--opensim"]) == 0
    paths = opensim_paths(tmp_path / "gt.h5")
    _, mot = _read_table(osim, paths["motion"])
    for side in "lr":
        np.testing.assert_allclose(mot[f"knee_angle_{side}"], knee_flexion(lm, side), atol=0.5)
        np.testing.assert_allclose(mot[f"hip_flexion_{side}"], hip_flexion(lm, side), atol=0.5)
    assert np.abs(mot["lumbar_extension"]).max() < 0.1
    _, errors = _read_table(osim, paths["errors"])
    assert errors["marker_error_RMS"].max() < 0.002  # m


@osim_needed
def test_frames_without_a_person_are_left_out_and_smoothing_names_the_files(tmp_path):
    import opensim as osim

    model = BodyModel()
    x = _moving_states(model, 40, seed=1)  # one cycle in 40 frames: 1.5 Hz at 60 Hz
    observed = np.ones(40, bool)
    observed[15] = False
    _result(tmp_path / "a.h5", model.landmarks(x), frames=np.arange(11, 51), rate=60.0,
            attrs=_body_attrs(model.dimensions), observed=observed)
    assert main(["export", str(tmp_path / "a.h5"), "--opensim", "--smooth", "2",
                 "--format", "csv", "--out", str(tmp_path / "out")]) == 0
    paths = opensim_paths(tmp_path / "a.h5", 2.0, tmp_path / "out")
    assert paths["motion"].name == "a_butterworth2Hz.mot"
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == sorted(
        ["a_butterworth2Hz.csv", *(p.name for p in paths.values())])
    time, mot = _read_table(osim, paths["motion"])
    frames = np.arange(11, 51)[observed]
    np.testing.assert_allclose(time, (frames - 1) / 60.0, atol=1e-6)
    # OpenSim was given the smoothed landmarks (each stretch filtered on its own), Y up, in m
    smoothed = landmark_table(read_result(tmp_path / "a.h5"), cutoff_hz=2.0, axes="y_up")
    trc = osim.TimeSeriesTableVec3(str(paths["trc"]))
    given = np.array([[[trc.getRowAtIndex(i)[j][k] for k in range(3)] for j in range(15)]
                      for i in range(trc.getNumRows())])
    np.testing.assert_allclose(given * 1000, smoothed.positions, rtol=0, atol=1e-3)
    assert trc.getTableMetaDataAsString("Units") == "m" and np.isnan(given[15]).all()
    assert np.abs(mot["knee_angle_r"] - _expected_coordinates(x)["knee_angle_r"][observed]
                  ).max() > 1.0  # the filter changed the angles
    times, errors = _read_table(osim, paths["errors"])
    np.testing.assert_allclose(times, time)
    assert np.all(np.isfinite(errors["marker_error_RMS"]))


# ------------------------------------------------------------------ acceptance: a tracked walk
@pytest.fixture(scope="module")
def tracked_walk(walk_dataset, tmp_path_factory):
    """The rendered walk tracked as ``track`` does by default (6 layers × 600 particles, from
    frame 1's ground truth, with the subject's body file)."""
    from voxelmocap.config import TrackConfig, with_overrides
    from voxelmocap.run.pipeline import track_sequence

    run = tmp_path_factory.mktemp("opensim_run")
    config = with_overrides(TrackConfig(), **{"export.formats": []})
    outcome = track_sequence(walk_dataset, "S1", "Walking_1", run, config=config, seed=0,
                             progress=False, log=lambda *_: None)
    return run, outcome.result_path


@osim_needed
@pytest.mark.slow
def test_export_opensim_of_a_tracked_walk(tracked_walk, walk_dataset, capsys):
    """The acceptance: ``voxelmocap export RUN --opensim`` on a rendered walk.

    Tolerances. The markers: the model is the tracked body and a tracked pose is one of its
    poses, so OpenSim fits them to well under a millimetre (measured 0.2 mm: the rendered
    subject's hips hang 0–4 mm below the pelvis, so the lumbar task trades a little marker error).
    The knee: OpenSim's angle is the tracked landmarks' own (within 0.1°); against the ground
    truth it is off by what the tracked hip, knee and ankle are off, which bounds it frame by
    frame — a segment whose ends move by e₁ and e₂ turns by at most asin((e₁ + e₂) / length),
    up to 13° here, where the right hip, knee and ankle are 22–30 mm off — and on average within
    10° (measured on these 8 frames with seeds 0 / 1 / 2: left 3.0 / 4.4 / 4.5°, right
    6.8 / 7.5 / 8.5°, the tracked right knee more bent than the truth; on a 20-frame walk 2.5° and
    2.8°). Hip flexion also carries the pelvis frame's error (hips 190 mm apart, trunk 530 mm,
    each end 20–30 mm off): on average within 12° (measured 5.9–8.2° here, 3.5° / 3.7° on 20
    frames).
    """
    import opensim as osim

    run, result_path = tracked_walk
    assert main(["export", str(run), "--opensim"]) == 0
    printed = capsys.readouterr().out.splitlines()
    paths = opensim_paths(result_path)
    assert [str(p) for p in paths.values()] == printed[:4]
    assert "OpenSim inverse kinematics of 8 frames, marker RMS" in printed[4]
    loaded = osim.Model(str(paths["model"]))
    loaded.initSystem()
    time, mot = _read_table(osim, paths["motion"])
    result = read_result(result_path)
    np.testing.assert_allclose(time, (result.frames - 1) / result.attrs["frame_rate"],
                               atol=1e-6)
    _, errors = _read_table(osim, paths["errors"])
    assert errors["marker_error_RMS"].max() < 0.001  # m

    gt = read_body_pose_xml(walk_dataset / "S1" / "Mocap_Data" / "Walking_1.xml")
    truth = endpoints_to_landmarks(gt.endpoints)[np.isin(gt.frames, result.frames)]
    tracked = result.landmarks
    error = np.linalg.norm(tracked - truth, axis=2)  # (F, 15) mm
    for side in "lr":
        ik = mot[f"knee_angle_{side}"]
        np.testing.assert_allclose(ik, knee_flexion(tracked, side), atol=0.1)
        hip, knee, ankle = (error[:, _I[f"{side}_{j}"]] for j in ("hip", "knee", "ankle"))
        lengths = [np.linalg.norm(truth[:, _I[f"{side}_{a}"]] - truth[:, _I[f"{side}_{b}"]],
                                  axis=1) for a, b in (("hip", "knee"), ("knee", "ankle"))]
        bound = np.degrees(np.arcsin(np.minimum(1, (hip + knee) / lengths[0]))
                           + np.arcsin(np.minimum(1, (knee + ankle) / lengths[1])))
        off = np.abs(ik - knee_flexion(truth, side))
        assert np.all(off <= bound + 0.1), (off, bound)
        assert off.mean() < 10.0, off
        assert np.abs(mot[f"hip_flexion_{side}"] - hip_flexion(truth, side)).mean() < 12.0


@osim_needed
def test_a_failing_inverse_kinematics_leaves_nothing_behind(tmp_path, monkeypatch, capsys):
    import voxelmocap.io.opensim as handoff

    model = BodyModel()
    _result(tmp_path / "a.h5", model.landmarks(_moving_states(model, 4, seed=2)),
            attrs=_body_attrs(model.dimensions))

    def broken(*args, **kwargs):
        raise InputError("opensim", "the solver failed")

    monkeypatch.setattr(handoff, "inverse_kinematics", broken)
    assert main(["export", str(tmp_path / "a.h5"), "--opensim"]) == 2
    assert "the solver failed" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.h5"]  # no file, no temporary
