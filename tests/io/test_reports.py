import json
from pathlib import Path

import numpy as np
import pytest

from voxelmocap.cli import main
from voxelmocap.errors import InputError
from voxelmocap.io.body_pose_xml import read_body_pose_xml, write_body_pose_xml
from voxelmocap.io.reports import evaluate_files, format_table, report_json
from voxelmocap.io.results import TrackResult, write_result


def write_h5(path, frames, endpoints):
    n = len(frames)
    write_result(path, TrackResult(
        frames=np.asarray(frames), state=np.zeros((n, 27)), landmarks=np.zeros((n, 15, 3)),
        endpoints=endpoints, part_scores=np.zeros((n, 10, 4)), ess=np.zeros((n, 1)),
        betas=np.zeros((n, 1)), seconds=np.ones(n), log_likelihood=np.zeros(n),
        map_state=np.zeros((n, 27)), state_names=["x"] * 27, part_names=["p"] * 10))


@pytest.fixture
def run_and_truth(tiny_dataset, tmp_path):
    gt = read_body_pose_xml(tiny_dataset / "S1" / "Mocap_Data" / "Walking_1.xml")
    # frames 1–4 of the result: offsets 30, 60, 90, 150 mm along x for every endpoint
    offsets = np.array([30.0, 60.0, 90.0, 150.0])
    est = gt.endpoints[:4] + offsets[:, None, None] * np.array([1.0, 0.0, 0.0])
    return tiny_dataset, gt, est


@pytest.mark.parametrize("kind", ["h5", "xml"])
def test_hand_worked_scores_from_h5_and_xml(run_and_truth, tmp_path, kind):
    dataset, gt, est = run_and_truth
    run = tmp_path / f"run_{kind}"
    if kind == "h5":
        write_h5(run / "S1" / "Walking_1.h5", gt.frames[:4], est)
    else:
        write_body_pose_xml(run / "S1" / "Walking_1.xml", gt.frames[:4], est)
    (seq,) = evaluate_files(run, dataset, delta=100.0)
    sc = seq.scores
    assert sc.frames == 4 and sc.skipped == 0
    assert sc.mu_mm == pytest.approx(82.5, abs=1e-4)  # mean of 30, 60, 90, 150
    assert sc.sigma_mm == pytest.approx(np.std([30, 60, 90, 150]), abs=1e-4)
    assert sc.mmta_pct == pytest.approx(75.0)  # three frames fully matched, one not
    assert sc.mmtp_mm == pytest.approx(60.0, abs=1e-4)
    assert sc.humaneva_error_mm == pytest.approx(82.5, abs=1e-4)
    table = format_table([seq], 100.0)
    assert "Walking" in table and "Average" in table and "82.50" in table


def test_cli_json_csv_and_plots(run_and_truth, tmp_path, capsys):
    dataset, gt, est = run_and_truth
    run = tmp_path / "run"
    write_h5(run / "S1" / "Walking_1.h5", gt.frames[:4], est)
    out = tmp_path / "report"
    code = main(["evaluate", str(run), "--dataset", str(dataset), "--json", str(out / "r.json"),
                 "--csv", str(out / "csv"), "--plots", str(out / "plots"), "--delta", "70"])
    assert code == 0
    report = json.loads((out / "r.json").read_text())
    assert report["delta_mm"] == 70
    (s,) = report["sequences"]
    assert {"subject", "action", "trial", "frames", "mu_mm", "sigma_mm", "mmtp_mm", "mmta_pct",
            "humaneva_error_mm"} <= set(s)
    assert s["mmta_pct"] == pytest.approx(50.0)  # 30 and 60 are < 70
    assert report["average"]["mmta_pct"] == pytest.approx(50.0)
    rows = (out / "csv" / "per_frame.csv").read_text().splitlines()
    assert len(rows) == 5
    assert len((out / "csv" / "per_joint.csv").read_text().splitlines()) == 1 + 4 * 15
    assert (out / "plots" / "error_per_frame.png").stat().st_size > 1000


def test_average_pools_frames(run_and_truth, tmp_path):
    dataset, gt, est = run_and_truth
    run = tmp_path / "run"
    write_h5(run / "S1" / "Walking_1.h5", gt.frames[:4], est)
    seqs = evaluate_files(run, dataset)
    assert report_json(seqs, 100.0)["average"]["mu_mm"] == pytest.approx(82.5, abs=1e-4)


def test_errors(tiny_dataset, tmp_path):
    with pytest.raises(InputError, match="run folder not found"):
        evaluate_files(tmp_path / "none", tiny_dataset)
    (tmp_path / "empty" / "S1").mkdir(parents=True)
    with pytest.raises(InputError, match="no result files"):
        evaluate_files(tmp_path / "empty", tiny_dataset)
    run = tmp_path / "run"
    write_h5(run / "S1" / "Walking_1.h5", [500], np.zeros((1, 20, 3)))
    with pytest.raises(InputError, match="no frame in common"):
        evaluate_files(run, tiny_dataset)


def test_unfinished_run_is_noted(run_and_truth, tmp_path):
    dataset, gt, est = run_and_truth
    run = tmp_path / "run"
    write_h5(run / "S1" / "Walking_1.h5", gt.frames[:4], est)  # attrs lack complete=True
    seqs = evaluate_files(run, dataset)
    assert "unfinished run" in format_table(seqs, 100.0)


def _files_under(folder):
    return sorted(p.relative_to(folder) for p in folder.rglob("*"))


@pytest.mark.parametrize("bad", ["json", "csv", "plots"])
def test_cli_checks_every_output_before_writing(run_and_truth, tmp_path, capsys, bad):
    dataset, gt, est = run_and_truth
    run = tmp_path / "run"
    write_h5(run / "S1" / "Walking_1.h5", gt.frames[:4], est)
    out = tmp_path / "report"
    out.mkdir()
    blocker = out / "a_file"
    blocker.write_text("not a folder")
    places = {"json": out / "r.json", "csv": out / "csv", "plots": out / "plots"}
    places[bad] = blocker / "below"  # under a file: cannot be created, even by root
    code = main(["evaluate", str(run), "--dataset", str(dataset), "--json", str(places["json"]),
                 "--csv", str(places["csv"]), "--plots", str(places["plots"])])
    err = capsys.readouterr().err
    assert code == 2
    assert len(err.strip().splitlines()) == 1 and str(blocker) in err
    assert _files_under(out) == [blocker.relative_to(out)]  # nothing written, nothing stray


def test_json_is_strict_and_huge_coordinates_are_refused(run_and_truth, tmp_path):
    dataset, gt, est = run_and_truth
    text = (dataset / "S1" / "Mocap_Data" / "Walking_1.xml").read_text()
    first_x = text.index("<X>") + 3
    bad = tmp_path / "gt.xml"
    bad.write_text(text[:first_x] + "1e308" + text[text.index("</X>", first_x):])
    with pytest.raises(InputError, match="not a position") as info:
        read_body_pose_xml(bad)
    assert str(info.value).startswith(str(bad))
    # A report with unbounded scores is still strict JSON: null, never Infinity or NaN.
    run = tmp_path / "run"
    write_h5(run / "S1" / "Walking_1.h5", gt.frames[:4], est)
    seqs = evaluate_files(run, dataset)
    import dataclasses

    seqs[0].scores = dataclasses.replace(seqs[0].scores, mu_mm=float("inf"))
    report = report_json(seqs, 100.0)
    assert report["sequences"][0]["mu_mm"] is None


def test_evaluate_mmta_script_unwritable_json(run_and_truth, tmp_path, capsys):
    import runpy
    import sys

    dataset, gt, est = run_and_truth
    result = tmp_path / "est.xml"
    write_body_pose_xml(result, gt.frames[:4], est)
    blocker = tmp_path / "file"
    blocker.write_text("x")
    script = Path(__file__).resolve().parents[2] / "scripts" / "evaluate_mmta.py"
    argv = sys.argv
    sys.argv = [str(script), str(result), str(dataset / "S1" / "Mocap_Data" / "Walking_1.xml"),
                "--json", str(blocker / "r.json")]
    try:
        with pytest.raises(SystemExit) as info:
            runpy.run_path(str(script), run_name="__main__")
    finally:
        sys.argv = argv
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and str(blocker) in err
