import json

from voxelmocap.cli import main


def test_demo_end_to_end_at_reduced_size(tmp_path, capsys):
    out = tmp_path / "demo"
    code = main(["demo", "--out", str(out), "--frames", "4", "--cameras", "3", "--layers", "2",
                 "--particles", "40", "--voxel-size", "30", "--no-progress"])
    assert code == 0
    text = capsys.readouterr().out
    assert "Walking" in text and "Average" in text and "MMTA" in text
    report = json.loads((out / "report.json").read_text())
    (seq,) = report["sequences"]
    assert seq["frames"] == 4 and 0 <= seq["mmta_pct"] <= 100
    # a short, well-initialised track stays near the truth (a lost track is > 300 mm off)
    assert seq["mu_mm"] < 200
    assert (out / "run" / "S1" / "Walking_1.bvh").exists()


def test_demo_rejects_unknown_motion(tmp_path, capsys):
    assert main(["demo", "--out", str(tmp_path), "--motion", "dance"]) == 2
    assert "unknown motion 'dance'" in capsys.readouterr().err
