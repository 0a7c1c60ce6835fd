"""Landmark exports: TRC, C3D and CSV of a tracked synthetic walk read back by two readers each."""

import csv
import warnings

import numpy as np
import pytest

from voxelmocap.cli import main
from voxelmocap.config import TrackConfig, with_overrides
from voxelmocap.io.exports import landmark_table
from voxelmocap.io.results import read_result, write_result
from voxelmocap.io.trc import read_trc
from voxelmocap.joints import LANDMARK_NAMES
from voxelmocap.run.pipeline import track_sequence
from voxelmocap.smoothing import butterworth

TOL_MM = 1e-3  # the acceptance bound


@pytest.fixture(scope="module")
def tracked(walk_dataset, tmp_path_factory):
    """The rendered 8-frame walk tracked (3 × 60 particles) with every export, at 50 Hz."""
    run = tmp_path_factory.mktemp("exports")
    config = with_overrides(TrackConfig(), **{"filter.layers": 3, "filter.particles": 60,
                                              "export.formats": ["trc", "c3d", "csv"]})
    outcome = track_sequence(walk_dataset, "S1", "Walking_1", run, config=config, seed=2,
                             frames="2:8", progress=False, log=lambda *_: None, fps=50.0)
    return outcome, read_result(outcome.result_path)


def test_track_writes_the_configured_exports(tracked):
    outcome, result = tracked
    assert sorted(p.suffix for p in outcome.export_paths) == [".c3d", ".csv", ".trc"]
    assert all(p.parent == outcome.result_path.parent and p.stem == "Walking_1"
               for p in outcome.export_paths)
    # the result carries the confidence the exports use
    assert result.landmark_spread.shape == (7, 15) and result.confidence.shape == (7, 15)
    assert np.all(np.isfinite(result.landmark_spread)) and np.all(result.landmark_spread >= 0)
    assert np.all((result.confidence >= 0) & (result.confidence <= 1)) and result.observed.all()


def _pose2sim_trc(path):
    """Pose2Sim's own TRC reading (``common.py: extract_trc_data``): names, (F, 1+3M) array."""
    lines = path.read_text().splitlines()
    names = lines[3].strip().split("\t")[2::3]
    data = np.genfromtxt(path, skip_header=5, delimiter="\t")[:, 1:]
    return names, data, lines[2].split("\t")


def test_trc_round_trip_by_two_readers(tracked):
    outcome, result = tracked
    path = outcome.result_path.with_suffix(".trc")
    names, data, header = _pose2sim_trc(path)
    assert names == list(LANDMARK_NAMES)
    assert header[:5] == ["50", "50", "7", "15", "mm"] and header[6] == "2"
    np.testing.assert_allclose(data[:, 0], (np.arange(2, 9) - 1) / 50.0, atol=1e-6)
    np.testing.assert_allclose(data[:, 1:].reshape(7, 15, 3), result.landmarks, rtol=0,
                               atol=TOL_MM)
    trc = read_trc(path)
    assert trc.names == list(LANDMARK_NAMES) and trc.frame_rate == 50.0 and trc.units == "mm"
    np.testing.assert_array_equal(trc.frames, result.frames)
    np.testing.assert_allclose(trc.positions, result.landmarks, rtol=0, atol=TOL_MM)


def test_c3d_round_trip_by_two_readers(tracked):
    c3d = pytest.importorskip("c3d")
    ezc3d = pytest.importorskip("ezc3d")
    outcome, result = tracked
    path = outcome.result_path.with_suffix(".c3d")
    with open(path, "rb") as handle, warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # "No analog data found in file."
        reader = c3d.Reader(handle)
        frames = [(i, p.copy()) for i, p, _ in reader.read_frames()]
        labels = [s.strip() for s in reader.point_labels]
        rate, units = reader.point_rate, reader.get("POINT:UNITS").string_value.strip()
    assert labels == list(LANDMARK_NAMES) and rate == 50.0 and units == "mm"
    assert [i for i, _ in frames] == list(result.frames)
    points = np.array([p for _, p in frames])
    np.testing.assert_allclose(points[:, :, :3], result.landmarks, rtol=0, atol=TOL_MM)
    # the residual is the particle spread in whole mm, clipped to 1…255 mm
    np.testing.assert_array_equal(points[:, :, 3],
                                  np.clip(np.rint(result.landmark_spread), 1, 255))

    e = ezc3d.c3d(str(path))
    assert e["parameters"]["POINT"]["LABELS"]["value"] == list(LANDMARK_NAMES)
    assert e["parameters"]["POINT"]["RATE"]["value"][0] == 50.0
    assert e["parameters"]["POINT"]["UNITS"]["value"][0].strip() == "mm"
    assert e["header"]["points"]["first_frame"] + 1 == result.frames[0]  # ezc3d counts from 0
    xyz = e["data"]["points"][:3].transpose(2, 1, 0)
    np.testing.assert_allclose(xyz, result.landmarks, rtol=0, atol=TOL_MM)
    # ezc3d reads every point as valid (residual >= 0). Its residual *values* of float files are
    # not compared: it reads the residual from the other byte (pyomeca/ezc3d#386, open).
    assert np.all(e["data"]["meta_points"]["residuals"] >= 0)


def test_csv_round_trip(tracked):
    outcome, result = tracked
    path = outcome.result_path.with_suffix(".csv")
    with open(path, newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert len(rows) == 7 * 15
    assert [r["landmark"] for r in rows[:15]] == list(LANDMARK_NAMES)
    xyz = np.array([[float(r[k]) for k in ("x_mm", "y_mm", "z_mm")] for r in rows])
    np.testing.assert_allclose(xyz.reshape(7, 15, 3), result.landmarks, rtol=0, atol=TOL_MM)
    conf = np.array([float(r["confidence"]) for r in rows]).reshape(7, 15)
    np.testing.assert_allclose(conf, result.confidence, atol=1e-6)
    assert {r["observed"] for r in rows} == {"1"}
    times = np.array([float(r["time_s"]) for r in rows[::15]])
    np.testing.assert_allclose(times, (result.frames - 1) / 50.0, atol=1e-6)


def test_export_command_smooths_and_names_the_filter(tracked, tmp_path, capsys):
    outcome, result = tracked
    out = tmp_path / "out"
    assert main(["export", str(outcome.result_path), "--format", "trc,csv", "--smooth", "10",
                 "--out", str(out)]) == 0
    trc = read_trc(out / "Walking_1_butterworth10Hz.trc")
    expected = butterworth(result.landmarks, 50.0, cutoff_hz=10.0, order=4)
    np.testing.assert_allclose(trc.positions, expected, rtol=0, atol=TOL_MM)
    assert np.abs(expected - result.landmarks).max() > 0.1  # the filter did something
    assert (out / "Walking_1_butterworth10Hz.csv").exists()
    # a run folder exports every result in it, beside the result
    assert main(["export", str(outcome.result_path.parent.parent), "--format", "c3d"]) == 0
    assert outcome.result_path.with_suffix(".c3d").exists()


def test_gaps_and_unobserved_frames_are_empty_and_never_bridged(tracked, tmp_path):
    _, result = tracked
    # drop frame 5 (a gap) and flag frame 7 as not observed
    keep = result.frames != 5
    for name in ("frames", "state", "landmarks", "endpoints", "part_scores", "ess", "betas",
                 "seconds", "log_likelihood", "map_state", "landmark_spread", "confidence",
                 "observed"):
        setattr(result, name, getattr(result, name)[keep])
    result.observed[result.frames == 7] = False
    table = landmark_table(result, cutoff_hz=10.0)
    np.testing.assert_array_equal(table.frames, np.arange(2, 9))
    missing = np.isnan(table.positions).all(axis=(1, 2))
    np.testing.assert_array_equal(missing, np.isin(table.frames, [5, 7]))
    np.testing.assert_array_equal(table.observed, ~np.isin(table.frames, [5, 7]))
    # each stretch is filtered on its own: frames 2-4 equal the filter of frames 2-4 alone
    alone = butterworth(result.landmarks[:3], 50.0, cutoff_hz=10.0)
    np.testing.assert_allclose(table.positions[:3], alone, atol=1e-9)
    path = tmp_path / "r.h5"
    write_result(path, result)
    assert main(["export", str(path), "--format", "trc,c3d,csv"]) == 0
    trc = read_trc(path.with_suffix(".trc"))
    assert np.isnan(trc.positions[3]).all() and np.isfinite(trc.positions[2]).all()


def test_y_up_axes_follow_pose2sim(tracked):
    _, result = tracked
    world = landmark_table(result).positions
    y_up = landmark_table(result, axes="y_up").positions
    # Pose2Sim's zup2yup: X <- Y, Y <- Z (up), Z <- X
    np.testing.assert_array_equal(y_up[..., 0], world[..., 1])
    np.testing.assert_array_equal(y_up[..., 1], world[..., 2])
    np.testing.assert_array_equal(y_up[..., 2], world[..., 0])


def test_track_export_options(walk_dataset, tmp_path, capsys):
    base = ["track", str(walk_dataset), "--subject", "S1", "--sequence", "Walking_1", "--frames",
            "1:2", "--layers", "1", "--particles", "20", "--no-progress"]
    assert main([*base, "--export", "none", "--out", str(tmp_path / "a")]) == 0
    assert sorted(p.suffix for p in (tmp_path / "a" / "S1").iterdir()) == [".bvh", ".h5", ".xml"]
    assert main([*base, "--export", "csv", "--smooth", "5", "--out", str(tmp_path / "b")]) == 0
    assert (tmp_path / "b" / "S1" / "Walking_1_butterworth5Hz.csv").exists()
    capsys.readouterr()
    # a cut-off above Nyquist is refused before anything is tracked or written
    assert main([*base, "--smooth", "45", "--out", str(tmp_path / "c")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "export.cutoff_hz" in err[0] and "half the frame rate" in err[0]
    assert not (tmp_path / "c").exists()
    # --resume may change the exports: they are not tracking
    assert main([*base, "--resume", "--export", "trc", "--out", str(tmp_path / "a")]) == 0
    assert (tmp_path / "a" / "S1" / "Walking_1.trc").exists()


def _read_c3d_screen(path):
    c3d = pytest.importorskip("c3d")
    with open(path, "rb") as handle, warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        reader = c3d.Reader(handle)
        return reader.get_screen_axis(), np.array([p[:, :3] for _, p, _ in reader.read_frames()])


def test_y_up_exports_say_so_and_never_overwrite_the_world_files(tracked, tmp_path):
    outcome, _ = tracked
    result = read_result(outcome.result_path)  # (another test edits the fixture's copy)
    out = tmp_path / "out"
    assert main(["export", str(outcome.result_path), "--format", "trc,c3d,csv",
                 "--out", str(out)]) == 0
    world = {p.name: p.read_bytes() for p in out.iterdir()}
    assert sorted(world) == ["Walking_1.c3d", "Walking_1.csv", "Walking_1.trc"]
    assert main(["export", str(outcome.result_path), "--format", "trc,c3d,csv", "--axes", "y_up",
                 "--smooth", "10", "--out", str(out)]) == 0
    # the world-frame files are untouched; the Y-up ones carry the frame in their names
    assert {p.name: p.read_bytes() for p in out.iterdir() if p.name in world} == world
    stem = "Walking_1_butterworth10Hz_yup"
    assert sorted(p.name for p in out.iterdir() if p.name not in world) == [
        f"{stem}.c3d", f"{stem}.csv", f"{stem}.trc"]
    expected = butterworth(result.landmarks, 50.0, cutoff_hz=10.0, order=4)[..., [1, 2, 0]]

    # TRC: its first line names the axes, for our reader and for a person
    trc = read_trc(out / f"{stem}.trc")
    assert trc.axes == "y_up" and read_trc(out / "Walking_1.trc").axes == "world"
    assert "Y up" in (out / f"{stem}.trc").read_text().splitlines()[0]
    np.testing.assert_allclose(trc.positions, expected, rtol=0, atol=TOL_MM)
    # C3D: POINT:X_SCREEN / Y_SCREEN
    screen, points = _read_c3d_screen(out / f"{stem}.c3d")
    assert screen == ("+X", "+Y") and _read_c3d_screen(out / "Walking_1.c3d")[0] == ("+X", "+Z")
    np.testing.assert_allclose(points, expected, rtol=0, atol=TOL_MM)
    # CSV: the position columns name the axes
    with open(out / f"{stem}.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert list(rows[0])[3:6] == ["x_yup_mm", "y_yup_mm", "z_yup_mm"]
    xyz = np.array([[float(r[k]) for k in ("x_yup_mm", "y_yup_mm", "z_yup_mm")] for r in rows])
    np.testing.assert_allclose(xyz.reshape(7, 15, 3), expected, rtol=0, atol=TOL_MM)


@pytest.mark.parametrize("fmt", ["trc", "csv"])
def test_a_y_up_export_is_read_back_in_its_axes(tracked, tmp_path, fmt):
    """evaluate --reference on our own Y-up export: the file's axes are honoured (error 0), and
    a mapping that says other axes is refused."""
    import json

    outcome, _ = tracked
    assert main(["export", str(outcome.result_path), "--format", fmt, "--axes", "y_up",
                 "--out", str(tmp_path)]) == 0
    mapping = tmp_path / "map.toml"
    mapping.write_text("[landmarks]\n" + "".join(f'{n} = "{n}"\n' for n in LANDMARK_NAMES))
    report = tmp_path / "r.json"
    assert main(["evaluate", str(outcome.result_path), "--reference",
                 str(tmp_path / f"Walking_1_yup.{fmt}"), "--mapping", str(mapping),
                 "--json", str(report)]) == 0
    assert json.loads(report.read_text())["mu_mm"] < TOL_MM
    mapping.write_text(mapping.read_text() + '[reference]\naxes = "world"\n')
    assert main(["evaluate", str(outcome.result_path), "--reference",
                 str(tmp_path / f"Walking_1_yup.{fmt}"), "--mapping", str(mapping)]) == 2


def test_opensim_reads_a_trc_with_frames_without_a_person(tracked, tmp_path):
    """OpenSim 4.6 refuses a row whose last marker is empty: missing values are written NaN."""
    osim = pytest.importorskip("opensim")
    result = read_result(tracked[0].result_path)
    result.observed[-2:] = False
    path = tmp_path / "r.h5"
    write_result(path, result)
    assert main(["export", str(path), "--format", "trc", "--axes", "y_up"]) == 0
    table = osim.TimeSeriesTableVec3(str(tmp_path / "r_yup.trc"))
    assert table.getNumRows() == 7 and list(table.getColumnLabels()) == list(LANDMARK_NAMES)
    last = table.getRowAtIndex(6)
    assert all(np.isnan(last[j][k]) for j in range(15) for k in range(3))
    first = table.getRowAtIndex(0)
    np.testing.assert_allclose([[first[j][k] for k in range(3)] for j in range(15)],
                               result.landmarks[0][:, [1, 2, 0]], rtol=0, atol=TOL_MM)
