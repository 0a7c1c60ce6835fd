"""evaluate --reference: a TRC / CSV of named points and a mapping, against closed-form errors."""

import json

import numpy as np
import pytest

from voxelmocap.cli import main
from voxelmocap.errors import InputError
from voxelmocap.evaluation import evaluate_points, mmta_mmtp
from voxelmocap.io.reference import parse_mapping
from voxelmocap.io.results import TrackResult, write_result
from voxelmocap.io.trc import read_trc
from voxelmocap.joints import LANDMARK_NAMES

LM = list(LANDMARK_NAMES)


def _result(path, n=10, rate=60.0, first=5, seed=0):
    rng = np.random.default_rng(seed)
    res = TrackResult(
        frames=np.arange(first, first + n), state=rng.normal(size=(n, 27)),
        landmarks=rng.normal(size=(n, 15, 3)) * 400 + [0, 0, 1000],
        endpoints=rng.normal(size=(n, 20, 3)), part_scores=rng.random((n, 10, 4)),
        ess=rng.random((n, 2)), betas=rng.random((n, 2)), seconds=rng.random(n),
        log_likelihood=rng.normal(size=n), map_state=rng.normal(size=(n, 27)),
        state_names=[f"s{i}" for i in range(27)], part_names=[f"p{i}" for i in range(10)],
        attrs={"frame_rate": rate, "complete": True})
    write_result(path, res)
    return res


def _pose2sim_trc(path, names, frames, xyz_m, rate):
    """A TRC as Pose2Sim writes it (metres, Y up), written here independently of io/trc.py."""
    header = ["PathFileType\t4\t(X/Y/Z)\t" + path.name,
              "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\t"
              "OrigDataStartFrame\tOrigNumFrames",
              f"{rate:g}\t{rate:g}\t{len(frames)}\t{len(names)}\tm\t{rate:g}\t{frames[0]}\t"
              f"{len(frames)}",
              "Frame#\tTime\t" + "\t\t\t".join(names) + "\t\t\t",
              "\t\t" + "\t".join(f"X{i + 1}\tY{i + 1}\tZ{i + 1}" for i in range(len(names))) + "\t"]
    rows = [f"{f}\t{f / rate}\t" + "\t".join(repr(float(v)) for v in xyz_m[i].ravel())
            for i, f in enumerate(frames)]
    path.write_text("\n".join(header + rows) + "\n")


def test_evaluate_against_a_pose2sim_trc(tmp_path, capsys):
    res = _result(tmp_path / "run" / "S1" / "Walking_1.h5")
    n = len(res.frames)
    rng = np.random.default_rng(1)
    # known errors: head off by 30 mm, l_knee by 150 mm, pelvis exact (the mean of two hips)
    offsets = {"head": [0, 30.0, 0], "l_knee": [90.0, 0, 120.0], "pelvis": [0, 0, 0]}
    spread = rng.normal(size=(n, 3)) * 100
    world = {"Head": res.landmarks[:, LM.index("head")] + offsets["head"],
             "LKnee": res.landmarks[:, LM.index("l_knee")] + offsets["l_knee"],
             "RHip": res.landmarks[:, LM.index("pelvis")] + spread,
             "LHip": res.landmarks[:, LM.index("pelvis")] - spread}
    names = list(world)
    xyz = np.stack([world[k] for k in names], axis=1)[..., [1, 2, 0]] / 1000.0  # Y up, metres
    # the reference counts frames from 0: reference frame = result frame - 5
    _pose2sim_trc(tmp_path / "ref.trc", names, list(range(n)), xyz, 60.0)
    (tmp_path / "map.toml").write_text(
        '[landmarks]\nhead = "Head"\nl_knee = "LKnee"\npelvis = ["RHip", "LHip"]\n'
        '[reference]\naxes = "y_up"\nframe_offset = -5\n')
    report = tmp_path / "report.json"
    assert main(["evaluate", str(tmp_path / "run"), "--reference", str(tmp_path / "ref.trc"),
                 "--mapping", str(tmp_path / "map.toml"), "--json", str(report)]) == 0
    out = json.loads(report.read_text())
    assert out["frames"] == n and out["landmarks"] == ["pelvis", "l_knee", "head"]
    np.testing.assert_allclose(out["per_landmark_mm"], [0.0, 150.0, 30.0], atol=1e-6)
    assert out["mu_mm"] == pytest.approx(60.0, abs=1e-6) and out["sigma_mm"] == pytest.approx(
        0.0, abs=1e-6)
    assert out["mmta_pct"] == pytest.approx(200 / 3) and out["mmtp_mm"] == pytest.approx(15.0)
    assert out["per_landmark_mmta_pct"] == [100.0, 0.0, 100.0]
    assert "l_knee" in capsys.readouterr().out


def test_evaluate_against_our_own_csv_and_missing_values(tmp_path):
    res = _result(tmp_path / "r.h5", n=4)
    assert main(["export", str(tmp_path / "r.h5"), "--format", "csv"]) == 0
    csv_path = tmp_path / "r.csv"
    lines = csv_path.read_text().splitlines()
    # blank the head of the second frame: left out, not counted as a miss
    row = 1 + 15 + LM.index("head")
    cells = lines[row].split(",")
    cells[3:6] = ["", "", ""]
    lines[row] = ",".join(cells)
    csv_path.write_text("\n".join(lines) + "\n")
    (tmp_path / "map.toml").write_text("[landmarks]\n" + "".join(f'{n} = "{n}"\n' for n in LM))
    assert main(["evaluate", str(tmp_path / "r.h5"), "--reference", str(csv_path), "--mapping",
                 str(tmp_path / "map.toml"), "--json", str(tmp_path / "e.json")]) == 0
    out = json.loads((tmp_path / "e.json").read_text())
    assert out["frames"] == 4 and out["mu_mm"] == pytest.approx(0.0, abs=1e-5)
    assert out["mmta_pct"] == 100.0
    assert res.frames[0] == 5


def test_evaluate_points_equals_the_humaneva_definitions_without_gaps():
    rng = np.random.default_rng(3)
    est = rng.normal(size=(30, 15, 3)) * 80
    ref = np.zeros_like(est)
    scores, per_frame = evaluate_points(est, ref, LM, delta=100.0)
    errors = np.linalg.norm(est, axis=2)
    mmta, mmtp, _ = mmta_mmtp(errors, 100.0)
    assert scores.mmta_pct == pytest.approx(mmta) and scores.mmtp_mm == pytest.approx(mmtp)
    assert scores.mu_mm == pytest.approx(errors.mean(axis=1).mean())
    assert scores.sigma_mm == pytest.approx(errors.mean(axis=1).std())
    np.testing.assert_allclose(scores.per_landmark_mm, errors.mean(axis=0))
    # a NaN reference value is left out of its frame (neither matched nor missed)
    ref[0, 0] = np.nan
    with_gap, _ = evaluate_points(est, ref, LM)
    e0 = errors[0, 1:]
    assert with_gap.frames == 30
    np.testing.assert_allclose(with_gap.per_landmark_mm[0], errors[1:, 0].mean())
    per_frame = 100.0 * (errors < 100).sum(axis=1) / 15
    per_frame[0] = 100.0 * (e0 < 100).sum() / 14
    assert with_gap.mmta_pct == pytest.approx(per_frame.mean())


@pytest.mark.parametrize(("data", "message"), [
    ({}, "no \\[landmarks\\] table"),
    ({"landmarks": {"nose": "Nose"}}, "unknown landmark 'nose'"),
    ({"landmarks": {"head": ["a", "b", "c"]}}, "name or a list of two"),
    ({"landmarks": {"head": "H"}, "reference": {"axes": "x_up"}}, "reference.axes"),
    ({"landmarks": {"head": "H"}, "reference": {"frame_offset": 1.5}}, "frame_offset"),
    ({"landmarks": {"head": "H"}, "extra": {}}, "unknown table \\[extra\\]"),
])
def test_bad_mappings(data, message):
    with pytest.raises(InputError, match=message):
        parse_mapping(data, "map.toml")


def test_trc_reader_accepts_opensim_layout(tmp_path):
    """OpenSim's own files: a blank line after the header, trailing tabs, cm, missing values."""
    path = tmp_path / "o.trc"
    path.write_text("PathFileType\t4\t(X/Y/Z)\to.trc\n"
                    "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\t"
                    "OrigDataStartFrame\tOrigNumFrames\n"
                    "100.00\t100.00\t2\t2\tcm\t100.00\t1\t2\n"
                    "Frame#\tTime\tA\t\t\tB\t\t\t\n"
                    "\t\tX1\tY1\tZ1\tX2\tY2\tZ2\t\n"
                    "\n"
                    "1\t0.00\t1\t2\t3\t\t\t\t\n"
                    "2\t0.01\t4\t5\t6\t7\t8\t9\n")
    trc = read_trc(path)
    assert trc.names == ["A", "B"] and trc.frame_rate == 100.0 and trc.units == "cm"
    np.testing.assert_array_equal(trc.frames, [1, 2])
    np.testing.assert_allclose(trc.positions[1], [[40, 50, 60], [70, 80, 90]])
    assert np.isnan(trc.positions[0, 1]).all()
