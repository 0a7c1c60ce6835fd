"""``scripts/bench_facing.py``: the runs it plans, how it judges a run, its summary line."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from voxelmocap.joints import LANDMARK_ENDPOINTS, LANDMARK_NAMES


@pytest.fixture(scope="module")
def bench(load_script):
    return load_script("bench_facing")


def test_plan_is_the_issues_protocols(bench):
    runs = bench.plan("facing", noise_seeds=(7, 8))
    assert len(runs) == 80
    assert {r["action"] for r in runs} == {"Walking", "Jog", "Box", "Gestures", "Combo"}
    assert sorted({r["heading"] for r in runs}) == [0, 45, 90, 135, 180, 225, 270, 315]
    # odd multiples of 45° with one noise seed, even ones with the other
    for r in runs:
        assert r["noise_seed"] == (8 if int(r["heading"]) // 45 % 2 else 7)
        assert r["frames"] == 40 and r["seed"] in (0, 1)
    assert len({r["key"] for r in runs}) == 40  # one render per clip and heading
    acc = bench.plan("accuracy", noise_seeds=(7, 8))
    assert len(acc) == 30 and {r["heading"] for r in acc} == {0}
    assert {(r["noise_seed"], r["seed"]) for r in acc if r["action"] == "Jog"} == \
        {(n, s) for n in (7, 8) for s in (0, 1, 2)}
    assert all(r["frames"] == 100 for r in acc)
    one = bench.plan("accuracy", noise_seeds=(7,), seeds=(0, 1))
    assert len(one) == 10 and {r["noise_seed"] for r in one} == {7}
    sub = bench.plan("facing", clips={"Walking"}, headings=(0, 180), seeds=(1,), frames=10)
    assert [(r["action"], r["heading"], r["seed"], r["frames"]) for r in sub] == \
        [("Walking", 0, 1, 10), ("Walking", 180, 1, 10)]
    assert sub[1]["key"] == "Walking_h180_n1_f10"


def _endpoints(landmarks):
    """(F, 20, 3) endpoints whose landmarks are ``landmarks`` (F, 15, 3)."""
    out = np.zeros(landmarks.shape[:1] + (20, 3))
    for j, idx in enumerate(LANDMARK_ENDPOINTS):
        out[:, list(idx)] = landmarks[:, j, None]
    return out


def _walker(n):
    """Landmarks (n, 15, 3) of a body facing +x (left towards +y), walking along +x."""
    base = {"thorax": (0, 0, 1400), "pelvis": (0, 0, 950), "head": (0, 0, 1700),
            "l_shoulder": (0, 180, 1400), "l_elbow": (0, 220, 1120), "l_wrist": (60, 230, 880),
            "r_shoulder": (0, -180, 1400), "r_elbow": (0, -220, 1120), "r_wrist": (60, -230, 880),
            "l_hip": (0, 100, 950), "l_knee": (40, 110, 500), "l_ankle": (0, 110, 80),
            "r_hip": (0, -100, 950), "r_knee": (40, -110, 500), "r_ankle": (0, -110, 80)}
    pts = np.array([base[name] for name in LANDMARK_NAMES], dtype=float)
    return pts[None] + np.arange(n)[:, None, None] * np.array([20.0, 0.0, 0.0])


def _turned(pts, degrees):
    a = np.deg2rad(degrees)
    rot = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    centre = pts[:, LANDMARK_NAMES.index("pelvis")][:, None]
    return (pts - centre) @ rot.T + centre


def _ev(est, gt):
    n = len(gt)
    return SimpleNamespace(frames=np.arange(1, n + 1), est=_endpoints(est), gt=_endpoints(gt),
                           est_enabled=np.ones((n, 20), bool))


def test_judge_a_right_a_backwards_and_a_turning_run(bench):
    gt = _walker(40)
    good = bench.judge(_ev(_turned(gt, 20.0), gt))
    assert good["facing_right"] and good["left_right_right"] and good["turned_round_at"] == 1
    assert good["judge_frame"] == 10 and good["heading_error_deg"] == pytest.approx(20.0)
    back = bench.judge(_ev(_turned(gt, 180.0), gt))
    assert not back["facing_right"] and not back["left_right_right"]
    assert back["turned_round_at"] is None and back["heading_error_deg"] == pytest.approx(180.0)
    assert not any(back["left_right"].values())
    # a start turned 180° that turns back by 10° a frame: within 45° from frame 15 on, and the
    # limbs over frames 10–40 mostly on the right side
    angles = np.clip(180.0 - 10.0 * np.arange(40), 0.0, None)
    est = np.stack([_turned(gt[k:k + 1], a)[0] for k, a in enumerate(angles)])
    turning = bench.judge(_ev(est, gt))
    assert turning["turned_round_at"] == 15
    assert turning["heading_error_deg"] == pytest.approx(90.0) and not turning["facing_right"]
    assert turning["left_right_right"]
    # a frame flagged without a person (every endpoint disabled) leaves the verdicts alone
    ev = _ev(_turned(gt, 20.0), gt)
    ev.est_enabled[3] = False
    judged = bench.judge(ev)
    assert judged["left_right_right"] and judged["frames_without_person"] == 1
    assert good["frames_without_person"] == 0
    # a short run is judged at its last frame
    assert bench.judge(_ev(gt[:6], gt[:6]))["judge_frame"] == 6


def test_summary_counts_and_tables(bench):
    gt = _walker(40)
    base = {"clip": "x.bvh", "start": 0.0, "subject": "S1", "frames": 40, "wall_seconds": 1.0,
            "seconds_per_frame": 0.5, "out_of_view_frames": 0}
    records = []
    for k, (action, heading, turn) in enumerate([("Walking", 0.0, 10.0), ("Walking", 45.0, 180.0),
                                                 ("Jog", 0.0, 0.0)]):
        records.append({**base, "action": action, "heading": heading, "noise_seed": 1,
                        "seed": 0, "mu_mm": 40.0 + 30 * k, "mmta_pct": 90.0,
                        **bench.judge(_ev(_turned(gt, turn), gt))})
    text = bench.summary(records, "facing", start_turned=True)
    lines = text.splitlines()
    assert lines[0] == "facing right in 2/3, left/right right in 2/3"
    assert "max 100.0 mm (Jog h0 n1 seed 0), 2 run(s) above 60 mm" in lines[1]
    assert "turned round within 30 frames in 2/3" in lines[2]
    assert "renders leaving the cameras' common view: none" in text
    assert any(line.startswith("Walking") and "1/2" in line for line in lines)
    assert "runs facing wrong or with a limb swapped (1):" in text


def _tree(root: Path) -> Path:
    """A HumanEva-like data set: ``Background/``, ``S1/`` with ``Mocap_Data``, another subject."""
    for rel in ["Background/Background_1_(C1).avi", "S1/Image_Data/Walking_1_(C1).avi",
                "S1/Calibration_Data/C1.cal", "S1/Mocap_Data/Walking_1.xml",
                "S1/Mocap_Data/S1_body.toml", "S2/Image_Data/Jog_1_(C1).avi"]:
        (root / rel).parent.mkdir(parents=True, exist_ok=True)
        (root / rel).write_text(rel)
    return root


def _files(root: Path) -> set:
    return {p.relative_to(root).as_posix() for p in root.rglob("*") if not p.is_dir()}


def test_stripped_copies_with_and_without_the_plate(bench, tmp_path):
    data = _tree(tmp_path / "data")
    kept = bench.stripped_copy(data, "S1", tmp_path / bench.STRIPPED[False])
    assert _files(kept) == {"Background/Background_1_(C1).avi",
                            "S1/Image_Data/Walking_1_(C1).avi", "S1/Calibration_Data/C1.cal"}
    bare = bench.stripped_copy(data, "S1", tmp_path / bench.STRIPPED[True], keep_background=False)
    assert bare.name == "stripped_noplate"
    assert _files(bare) == {"S1/Image_Data/Walking_1_(C1).avi", "S1/Calibration_Data/C1.cal"}
    assert (bare / "S1/Image_Data/Walking_1_(C1).avi").is_symlink()  # links, not copies


def test_no_plate_runs_have_their_own_folder(bench, tmp_path):
    args = SimpleNamespace(config=None, set=[], start_turned=False, tag=None, no_plate=True)
    _, tag = bench.build_config(args)
    assert tag.endswith("_default_noplate")
    args.no_plate = False
    assert bench.build_config(args)[1].endswith("_default")
    args.no_plate, args.tag = True, "mine"
    assert bench.build_config(args)[1] == "mine"
    # a folder with runs of one kind refuses the other
    with_plate = tmp_path / "with"
    (with_plate / "Walking_h0_n1_f100" / "seed0").mkdir(parents=True)
    bench.check_plate_kind(with_plate, False)
    with pytest.raises(SystemExit, match="holds runs with the background videos"):
        bench.check_plate_kind(with_plate, True)
    without = tmp_path / "without"
    bench.check_plate_kind(without, True)
    (without / "Walking_h0_n1_f100" / "seed0").mkdir(parents=True)
    bench.check_plate_kind(without, True)
    with pytest.raises(SystemExit, match="holds runs without the background videos"):
        bench.check_plate_kind(without, False)
