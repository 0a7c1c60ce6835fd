"""A HumanEva-I tree whose ground truth exists only as raw mocap (``.mat`` + ``.mp``).

The ground truth is computed as the toolkit does (synchronised by the ``.ofs``), written by
``voxelmocap groundtruth``, shown by ``info``, scored by ``evaluate`` exactly as the same data in
body_pose XML, and used by ``track`` to initialise.
"""

from __future__ import annotations

import csv
import shutil
from pathlib import Path

import numpy as np
import pytest
from humaneva_fixture import make_tiny_dataset
from humaneva_mocap_fixture import PHYSICAL, standing_markers, write_subject_mocap

from voxelmocap.cli import main
from voxelmocap.io.body_pose_xml import read_body_pose_xml, write_body_pose_xml
from voxelmocap.io.humaneva import Dataset, write_ofs
from voxelmocap.io.reports import evaluate_files, format_table, report_json
from voxelmocap.joints import ENDPOINT_NAMES

VECTORS = Path(__file__).resolve().parents[2] / ".." / "shared" / "humaneva_toolkit_vectors"
#: The vectors' case walk_sync: p = 2.3716 + (k − 1)·1.98815, as HumanEva's .ofs give.
MC_ST, MC_SC = 2.3716, 1.98815


def _tree(root: Path, source: str) -> Path:
    """One camera with im_st = 1, so the toolkit's common time and scaling are the .ofs values."""
    make_tiny_dataset(root, cameras=("C1",), leads=(0,), n_frames=12, with_gt=False,
                      backgrounds=False)
    write_ofs(root / "S1" / "Sync_Data" / "Walking_1_(C1).ofs", 1, MC_ST, MC_SC)
    mocap = root / "S1" / "Mocap_Data"
    if source == "vectors":
        if not VECTORS.is_dir():
            pytest.skip("HumanEva toolkit reference vectors not available (outputs of the "
                        "official toolkit for synthetic mocap, expected in "
                        "../shared/humaneva_toolkit_vectors beside the checkout; not shipped)")
        mocap.mkdir(parents=True, exist_ok=True)
        shutil.copy(VECTORS / "inputs" / "Walking_1.mat", mocap / "Walking_1.mat")
        shutil.copy(VECTORS / "inputs" / "Static.mat", mocap / "Static.mat")
        shutil.copy(VECTORS / "inputs" / "S9.mp", mocap / "S1.mp")
    else:
        markers = standing_markers(30)
        markers[7, PHYSICAL.index("LKNE")] = 0.0  # invalidates the frames around mocap frame 8
        write_subject_mocap(root / "S1", "S1", "Walking_1", markers)
    return root


@pytest.fixture(params=["vectors", "synthetic"])
def raw_tree(request, tmp_path) -> Path:
    return _tree(tmp_path / "raw", request.param)


def test_ground_truth_is_the_toolkits_walk_sync(tmp_path):
    root = _tree(tmp_path / "raw", "vectors")
    seq = Dataset(root).sequence("S1", "Walking_1")
    assert seq.ground_truth_path is None
    assert seq.ground_truth_source == "raw mocap Walking_1.mat + S1.mp"
    gt = seq.ground_truth()
    with open(VECTORS / "expected" / "walk_sync.csv", newline="") as fh:
        rows = [r for r in csv.DictReader(fh) if r["status"] != "empty"]
    np.testing.assert_array_equal(gt.frames, [int(r["frame_id"]) for r in rows])
    for i, r in enumerate(rows):
        expected = np.array([[float(r[f"{n}_{a}"]) for a in "xyz"] for n in ENDPOINT_NAMES])
        assert gt.enabled[i].all() == bool(int(r["valid"]))
        np.testing.assert_allclose(gt.endpoints[i], expected, rtol=0, atol=1e-9)
    assert not gt.enabled.all(), "walk_sync has invalid frames; the tree must keep them disabled"


def test_evaluate_equals_the_same_ground_truth_in_xml(raw_tree, tmp_path, capsys):
    # the same tree with the ground truth as body_pose XML (written by 'groundtruth') instead
    xml_tree = tmp_path / "xml"
    shutil.copytree(raw_tree, xml_tree)
    out = xml_tree / "S1" / "Mocap_Data" / "Walking_1.xml"
    assert main(["groundtruth", str(raw_tree), "--subject", "S1", "--sequence", "Walking_1",
                 "--out", str(out)]) == 0
    assert "wrote" in capsys.readouterr().out
    for name in ("Walking_1.mat", "Static.mat", "S1.mp"):
        (xml_tree / "S1" / "Mocap_Data" / name).unlink()
    assert Dataset(xml_tree).sequence("S1", "Walking_1").ground_truth_source == \
        "body_pose XML Walking_1.xml"

    # a tracker's result: the ground truth with 40 mm noise on frames 1..12
    gt = Dataset(raw_tree).sequence("S1", "Walking_1").ground_truth()
    rng = np.random.default_rng(0)
    keep = gt.frames <= 12
    estimate = gt.endpoints[keep] + rng.normal(0, 40, size=gt.endpoints[keep].shape)
    write_body_pose_xml(tmp_path / "run" / "S1" / "Walking_1.xml", gt.frames[keep], estimate)

    scored = {name: evaluate_files(tmp_path / "run", root)
              for name, root in (("raw", raw_tree), ("xml", xml_tree))}
    assert format_table(scored["raw"], 100.0) == format_table(scored["xml"], 100.0)
    raw, xml = (report_json(scored[k], 100.0)["average"] for k in ("raw", "xml"))
    assert raw.keys() == xml.keys()
    for key in raw:  # the XML keeps 6 decimals
        assert raw[key] == pytest.approx(xml[key], abs=1e-5), key
    assert scored["raw"][0].scores.frames > 0
    tables = []
    for root in (raw_tree, xml_tree):
        assert main(["evaluate", str(tmp_path / "run"), "--dataset", str(root)]) == 0
        tables.append(capsys.readouterr().out)
    assert tables[0] == tables[1]


def test_groundtruth_command_writes_what_the_sequence_computes(raw_tree, tmp_path, capsys):
    out = tmp_path / "gt.xml"
    assert main(["groundtruth", str(raw_tree), "--subject", "S1", "--sequence", "Walking_1",
                 "--out", str(out)]) == 0
    text = capsys.readouterr().out
    written = read_body_pose_xml(out)
    gt = Dataset(raw_tree).sequence("S1", "Walking_1").ground_truth()
    np.testing.assert_array_equal(written.frames, gt.frames)
    np.testing.assert_array_equal(written.enabled, gt.enabled)
    np.testing.assert_allclose(written.endpoints, gt.endpoints, atol=1e-6)  # %f in the XML
    assert written.attributes["SubjectName"] == "S1"
    assert written.attributes["FrameEnd"] == str(gt.frames[-1])
    n_invalid = int((~gt.enabled.all(axis=1)).sum())
    assert n_invalid > 0  # both sources hold invalid frames
    assert f"{len(gt)} frames" in text and f"{len(gt) - n_invalid} fully enabled" in text


def test_info_names_the_ground_truth_source(raw_tree, capsys):
    assert main(["info", str(raw_tree)]) == 0
    out = capsys.readouterr().out
    assert "ground truth source: raw mocap Walking_1.mat + S1.mp" in out
    (raw_tree / "S1" / "Mocap_Data" / "Walking_1.mat").unlink()
    assert main(["info", str(raw_tree)]) == 0
    assert "ground truth source: none" in capsys.readouterr().out


def test_track_initialises_from_the_raw_mocap_ground_truth(tmp_path):
    from voxelmocap.config import TrackConfig, with_overrides
    from voxelmocap.run.pipeline import track_sequence

    root = make_tiny_dataset(tmp_path / "raw", with_gt=False)  # 3 cameras, common time 1
    write_subject_mocap(root / "S1", "S1", "Walking_1", standing_markers(30))
    assert Dataset(root).sequence("S1", "Walking_1").ground_truth_path is None
    config = with_overrides(TrackConfig(), **{"filter.layers": 1, "filter.particles": 10,
                                              "init.method": "ground_truth"})
    outcome = track_sequence(root, "S1", "Walking_1", tmp_path / "run", config=config,
                             frames="1:1", progress=False, log=lambda *_: None)
    assert outcome.init_method.startswith("the ground truth of frame 1")
