"""Procedural motions: rigid bones, planted feet, plausible speeds and joint angles."""

from __future__ import annotations

import numpy as np
import pytest

from voxelmocap.errors import InputError
from voxelmocap.synth.motions import MOTIONS, procedural_points
from voxelmocap.synth.resample import AREA, place_in_area
from voxelmocap.synth.skeletons import CANONICAL_NAMES

C = {n: i for i, n in enumerate(CANONICAL_NAMES)}
FPS = 60.0
T = np.arange(0, 6.0, 1 / FPS)


def _angle(P, a, b, c):
    u, v = P[:, C[a]] - P[:, C[b]], P[:, C[c]] - P[:, C[b]]
    cos = np.sum(u * v, -1) / np.linalg.norm(u, axis=-1) / np.linalg.norm(v, axis=-1)
    return 180 - np.degrees(np.arccos(np.clip(cos, -1, 1)))


@pytest.mark.parametrize("kind", MOTIONS)
def test_bones_are_rigid_and_the_body_stays_on_the_floor(kind):
    P = procedural_points(kind, T, height=1750, seed=3)
    for a, b in [("l_hip", "l_knee"), ("r_knee", "r_ankle"), ("l_shoulder", "l_elbow"),
                 ("r_elbow", "r_wrist"), ("pelvis", "thorax"), ("thorax", "head_top")]:
        length = np.linalg.norm(P[:, C[a]] - P[:, C[b]], axis=-1)
        assert np.ptp(length) < 1e-6 * length.mean()
    toes = P[:, [C["l_toe"], C["r_toe"]], 2]
    assert toes.min() == pytest.approx(0.012 * 1750, abs=3)  # toe joint height when planted
    assert np.all(P[..., 2] > 0)
    knee = _angle(P, "l_hip", "l_knee", "l_ankle")
    assert 0 <= knee.min() and knee.max() < 120
    placed = place_in_area(P, FPS)
    assert np.all(np.abs(placed[:, C["pelvis"], :2]) <= np.array(AREA) + 1e-6)


@pytest.mark.parametrize("kind, speed, knee_swing", [("walk", (0.85, 1.2), (45, 75)),
                                                      ("jog", (2.0, 2.6), (60, 110))])
def test_locomotion_speed_planted_feet_and_knee_curve(kind, speed, knee_swing):
    P = procedural_points(kind, T, height=1750, seed=1)
    v = np.linalg.norm(np.diff(P[:, C["pelvis"], :2], axis=0), axis=1) * FPS / 1000
    assert speed[0] < v.mean() < speed[1]
    for side in "lr":
        toe = P[:, C[f"{side}_toe"]]
        planted = toe[1:, 2] < 0.012 * 1750 + 0.5
        slide = np.linalg.norm(np.diff(toe[:, :2], axis=0), axis=1)[planted & (toe[:-1, 2] < 21.5)]
        assert planted.mean() > 0.25
        assert np.median(slide) < 1e-6  # the stance foot does not slide
        knee = _angle(P, f"{side}_hip", f"{side}_knee", f"{side}_ankle")
        assert knee_swing[0] < knee.max() < knee_swing[1]
    both_off = (P[:, C["l_toe"], 2] > 25) & (P[:, C["r_toe"], 2] > 25)
    if kind == "jog":
        assert both_off.mean() > 0.05  # flight phase
    else:
        assert both_off.mean() == 0.0  # walking always has a foot on the ground


def test_arm_swing_is_opposite_to_the_legs_in_walking():
    P = procedural_points("walk", T, seed=0)
    pel = P[:, C["pelvis"]]
    fwd = np.gradient(pel[:, :2], axis=0)
    fwd /= np.linalg.norm(fwd, axis=1, keepdims=True)
    lw = np.sum((P[:, C["l_wrist"], :2] - pel[:, :2]) * fwd, axis=1)
    la = np.sum((P[:, C["l_ankle"], :2] - pel[:, :2]) * fwd, axis=1)
    assert np.corrcoef(lw, la)[0, 1] < -0.5


def test_same_seed_same_motion_and_unknown_name():
    a = procedural_points("box", T[:50], seed=4)
    np.testing.assert_array_equal(a, procedural_points("box", T[:50], seed=4))
    assert not np.allclose(a, procedural_points("box", T[:50], seed=5))
    with pytest.raises(InputError, match="unknown motion"):
        procedural_points("dance", T[:5])


def test_walking_knee_curve_has_the_double_hump_and_the_pelvis_bobs_smoothly():
    P = procedural_points("walk", T, height=1750, seed=2)
    knee = _angle(P, "l_hip", "l_knee", "l_ankle")
    toe_z = P[:, C["l_toe"], 2]
    stance = toe_z < 0.012 * 1750 + 0.5
    # stance: flexed at loading, extended at mid-stance; swing: the large flexion peak
    assert knee[stance].min() < 20 and 25 < knee[stance].max() < 55
    assert knee[~stance].max() > knee[stance].max()
    z = P[:, C["pelvis"], 2]
    assert 30 < np.ptp(z) < 90  # vertical excursion, mm
    assert np.abs(np.diff(z)).max() * FPS < 600  # no jumps: < 0.6 m/s vertical


@pytest.mark.parametrize("kind", MOTIONS)
def test_the_whole_body_stays_in_every_camera_of_the_default_rig(kind):
    from voxelmocap.io.calibration import read_rig
    from voxelmocap.synth import default_rig_path

    rig = read_rig(default_rig_path())
    P = place_in_area(procedural_points(kind, np.arange(0, 12, 1 / 15), seed=1), 15.0)
    for cam in rig:
        assert cam.in_image(cam.project(P.reshape(-1, 3))).all(), cam.name
