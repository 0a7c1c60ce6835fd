"""`generate(heading_deg=...)` / `synth --heading`: the motion turned about the vertical through
its start, ground truth exact, the common-view check."""

from __future__ import annotations

import filecmp
import logging

import numpy as np
import pytest

from voxelmocap.cli import main
from voxelmocap.errors import InputError
from voxelmocap.io import body_pose_xml
from voxelmocap.io.calibration import read_rig
from voxelmocap.io.humaneva import Dataset
from voxelmocap.synth import default_rig_path, generate
from voxelmocap.synth.heading import frames_out_of_view, turn_about_vertical

N = 6
PELVIS = 1  # torsoDistal, the HumanEva endpoint at the canonical pelvis


def _rotated(points, degrees, pivot):
    """Closed form: rotate (x, y) about ``pivot`` counter-clockwise seen from above (Z up)."""
    a = np.deg2rad(degrees)
    out = np.array(points, dtype=float)
    x, y = out[..., 0] - pivot[0], out[..., 1] - pivot[1]
    out[..., 0] = np.cos(a) * x - np.sin(a) * y + pivot[0]
    out[..., 1] = np.sin(a) * x + np.cos(a) * y + pivot[1]
    return out


def test_turn_about_vertical_closed_form():
    # frame 0's root (index 0) at (100, 200, 900); a point 1 m along +x of it at frame 1
    pts = np.array([[[100.0, 200.0, 900.0], [50.0, 50.0, 0.0]],
                    [[400.0, 200.0, 910.0], [1100.0, 200.0, 30.0]]])
    out = turn_about_vertical(pts, 90.0, pivot_frame=0, root=0)
    # +x turns to +y (counter-clockwise from above); heights untouched; the pivot stays put
    np.testing.assert_allclose(out[1, 1], [100.0, 1200.0, 30.0], atol=1e-9)
    np.testing.assert_allclose(out[1, 0], [100.0, 500.0, 910.0], atol=1e-9)
    np.testing.assert_allclose(out[0, 0], pts[0, 0], atol=1e-9)
    np.testing.assert_allclose(out[0, 1], [250.0, 150.0, 0.0], atol=1e-9)
    # pivot of another frame; 180° mirrors the plan through it
    out = turn_about_vertical(pts, 180.0, pivot_frame=1, root=0)
    np.testing.assert_allclose(out[1, 1], [-300.0, 200.0, 30.0], atol=1e-9)
    # the input is not modified, 0° and 360° give the points back
    assert pts[1, 1, 0] == 1100.0
    np.testing.assert_allclose(turn_about_vertical(pts, 360.0, root=0), pts, atol=1e-9)
    with pytest.raises(ValueError):
        turn_about_vertical(pts[0], 10.0)


def test_frames_out_of_view_marks_the_camera_that_misses_a_point():
    rig = read_rig(default_rig_path())
    centre = [[0.0, 0.0, 100.0], [0.0, 0.0, 1700.0]]          # feet and head in the middle
    far = [[0.0, 0.0, 100.0], [0.0, -3500.0, 1000.0]]        # a hand beside camera C2
    behind = [[0.0, 0.0, 100.0], [6000.0, 800.0, 1500.0]]    # a point behind C1 (at x ≈ 4 m)
    miss = frames_out_of_view(rig, np.array([centre, far, behind]))
    assert miss.shape == (3, len(rig))
    assert not miss[0].any()
    c1, c2 = rig.names.index("C1"), rig.names.index("C2")
    assert miss[1, c2] and miss[2, c1]
    assert not miss[1].all()  # the cameras that do see it are not marked


def _capture_truth(monkeypatch):
    """Record the (unrounded) endpoints ``generate`` hands to the XML writer."""
    seen = []
    real = body_pose_xml.write_body_pose_xml

    def spy(path, frames, endpoints, *args, **kwargs):
        seen.append(np.array(endpoints, dtype=float))
        return real(path, frames, endpoints, *args, **kwargs)

    monkeypatch.setattr(body_pose_xml, "write_body_pose_xml", spy)
    return seen


@pytest.mark.parametrize("heading", [90.0, 225.0])
def test_turned_ground_truth_is_the_straight_one_rotated_about_the_start(tmp_path, monkeypatch,
                                                                         heading):
    seen = _capture_truth(monkeypatch)
    common = dict(motion="jog", frames=N, subject="S1", seed=4, cameras=["C1", "BW2"],
                  background_frames=2, progress=False)
    generate(tmp_path / "h0", **common)
    generate(tmp_path / "ht", heading_deg=heading, **common)
    straight, turned = seen
    pivot = straight[0, PELVIS, :2]
    expected = _rotated(straight, heading, pivot)
    np.testing.assert_allclose(turned, expected, rtol=0, atol=1e-6)
    # the written files (6 decimals) say the same, frame 1's pelvis stays where it was
    gt0 = Dataset(tmp_path / "h0").sequence("S1", "Jog_1").ground_truth()
    gtt = Dataset(tmp_path / "ht").sequence("S1", "Jog_1").ground_truth()
    np.testing.assert_allclose(gtt.endpoints, _rotated(gt0.endpoints, heading,
                                                       gt0.endpoints[0, PELVIS, :2]),
                               rtol=0, atol=3e-6)
    np.testing.assert_allclose(gtt.endpoints[0, PELVIS], gt0.endpoints[0, PELVIS], atol=1e-6)
    assert gtt.attributes["Heading"] == f"{heading:g}" and "Heading" not in gt0.attributes
    # the motion really turned: the jog's direction of travel turned by the heading
    travel0 = gt0.endpoints[-1, PELVIS, :2] - gt0.endpoints[0, PELVIS, :2]
    travelt = gtt.endpoints[-1, PELVIS, :2] - gtt.endpoints[0, PELVIS, :2]
    cross = travel0[0] * travelt[1] - travel0[1] * travelt[0]
    turn = np.degrees(np.arctan2(cross, travel0 @ travelt)) % 360
    assert turn == pytest.approx(heading, abs=1e-3)
    # and the turned person stays in the whole rig's common view
    rig = read_rig(default_rig_path())
    assert not frames_out_of_view(rig, gtt.endpoints).any()


def test_heading_zero_writes_the_same_files_as_no_heading(tmp_path):
    """``--heading 0`` is the default: byte-identical videos, ground truth and body file."""
    args = ["synth", "--motion", "walk", "--frames", "2", "--cameras", "C1", "--codec", "FFV1",
            "--seed", "2", "--no-progress"]
    assert main([*args, str(tmp_path / "a")]) == 0
    assert main([*args, "--heading", "0", str(tmp_path / "b")]) == 0
    files = sorted(p.relative_to(tmp_path / "a") for p in (tmp_path / "a").rglob("*")
                   if p.is_file())
    assert any(p.suffix == ".avi" for p in files) and any(p.suffix == ".xml" for p in files)
    match, mismatch, errors = filecmp.cmpfiles(tmp_path / "a", tmp_path / "b",
                                               [str(p) for p in files], shallow=False)
    assert not mismatch and not errors and len(match) == len(files)


def test_heading_through_the_command_turns_the_truth(tmp_path):
    args = ["synth", "--motion", "box", "--frames", "2", "--cameras", "BW1", "--seed", "1",
            "--no-progress"]
    assert main([*args, str(tmp_path / "a")]) == 0
    assert main([*args, "--heading", "-90", str(tmp_path / "b")]) == 0
    a = Dataset(tmp_path / "a").sequence("S1", "Box_1").ground_truth().endpoints
    b = Dataset(tmp_path / "b").sequence("S1", "Box_1").ground_truth().endpoints
    np.testing.assert_allclose(b, _rotated(a, -90.0, a[0, PELVIS, :2]), rtol=0, atol=3e-6)


def test_a_turn_that_leaves_the_common_view_is_logged(tmp_path, caplog):
    # the procedural walk's 2 s from the middle of the area, turned 180°, walks out of C1's
    # view (the straight one stays in it)
    common = dict(motion="walk", frames=24, fps=12.0, cameras=["C1"], background_frames=2,
                  progress=False)
    rig = read_rig(default_rig_path()).select(["C1"])
    with caplog.at_level(logging.WARNING, logger="voxelmocap.synth.writer"):
        generate(tmp_path / "a", **common)
        assert not caplog.records
        generate(tmp_path / "b", heading_deg=180.0, **common)
    assert any("leaves the cameras' common view" in r.getMessage() for r in caplog.records)
    a = Dataset(tmp_path / "a").sequence("S1", "Walking_1").ground_truth().endpoints
    b = Dataset(tmp_path / "b").sequence("S1", "Walking_1").ground_truth().endpoints
    assert not frames_out_of_view(rig, a).any() and frames_out_of_view(rig, b).any()


@pytest.mark.parametrize("bad", ["nan", "inf"])
def test_bad_heading_is_one_input_error_and_writes_nothing(tmp_path, bad):
    with pytest.raises(InputError, match="--heading"):
        generate(tmp_path / "x", motion="walk", frames=2, cameras=["C1"], progress=False,
                 heading_deg=float(bad))
    assert not (tmp_path / "x").exists()

