"""Skeleton families → canonical points and HumanEva endpoints; BVH resampling."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from voxelmocap.errors import InputError
from voxelmocap.io.bvh import read_bvh
from voxelmocap.joints import ENDPOINT_NAMES
from voxelmocap.synth.skeletons import (
    CANONICAL_NAMES,
    HEAD_TOP_RATIO,
    bvh_canonical_points,
    detect_family,
    endpoints_from_canonical,
)

MOCAP = Path(__file__).resolve().parents[2] / ".." / "shared" / "mocap"
C = {n: i for i, n in enumerate(CANONICAL_NAMES)}
FAMILY = {"05_01.bvh": "cmu_makehuman", "02_03.bvh": "cmu_makehuman",
          "dataset-1_punch_normal_002.bvh": "bandai",
          "dataset-2_wave-right-hand_normal_001.bvh": "bandai", "01_01.bvh": "cmu_cgspeed"}
BONES = [("l_shoulder", "l_elbow"), ("l_elbow", "l_wrist"), ("r_hip", "r_knee"),
         ("r_knee", "r_ankle"), ("head", "head_top")]


def _clip(name):
    path = MOCAP / name
    if not path.exists():
        pytest.skip("real motion-capture clips not available (the CMU / Bandai Namco BVH files the "
                    "project develops with, expected in ../shared/mocap beside the checkout; "
                    "not shipped)")
    return read_bvh(path)


@pytest.mark.parametrize("name", sorted(FAMILY))
def test_shared_clips_map_to_plausible_rigid_canonical_points(name):
    clip = _clip(name)
    assert detect_family(clip.names).name == FAMILY[name]
    P = bvh_canonical_points(clip, np.arange(0, min(clip.n_frames, 200), 7) * clip.frame_time)
    for a, b in BONES:  # rigid bones: constant lengths over frames
        length = np.linalg.norm(P[:, C[a]] - P[:, C[b]], axis=-1)
        assert np.ptp(length) < 1e-6 * length.mean() + 1e-6
    torso = np.linalg.norm(P[:, C["thorax"]] - P[:, C["pelvis"]], axis=-1)
    head = np.linalg.norm(P[:, C["head_top"]] - P[:, C["thorax"]], axis=-1)
    assert 350 < torso.mean() < 650
    assert head[0] == pytest.approx(HEAD_TOP_RATIO * torso[0], rel=0.02)
    # the head top is above the head joint, which is above the thorax, in upright frames
    upright = P[:, C["head_top"], 2] > P[:, C["pelvis"], 2] + 500
    assert upright.mean() > 0.9
    assert np.all(P[upright, C["head_top"], 2] > P[upright, C["thorax"], 2])
    # left is left: (left × up) is forward, the way the feet point
    fwd = np.cross(P[:, C["l_hip"]] - P[:, C["r_hip"]], P[:, C["thorax"]] - P[:, C["pelvis"]])
    toes = 0.5 * (P[:, C["l_toe"]] + P[:, C["r_toe"]]) - 0.5 * (P[:, C["l_ankle"]]
                                                                + P[:, C["r_ankle"]])
    assert np.mean(np.sum(fwd[:, :2] * toes[:, :2], axis=1) > 0) > 0.9


def test_resampling_hits_frames_exactly_and_interpolates_between():
    clip = _clip("02_03.bvh")
    at_frames = bvh_canonical_points(clip, np.array([3, 4]) * clip.frame_time)
    direct = bvh_canonical_points(clip)[[3, 4]]
    np.testing.assert_allclose(at_frames, direct, atol=1e-9)
    mid = bvh_canonical_points(clip, np.array([3.5]) * clip.frame_time)[0]
    # halfway in time the pelvis is halfway (root translation is linear, rotations are slerped)
    np.testing.assert_allclose(mid[C["pelvis"]], direct[:, C["pelvis"]].mean(axis=0), atol=15)
    femur = np.linalg.norm(mid[C["l_hip"]] - mid[C["l_knee"]])
    assert femur == pytest.approx(np.linalg.norm(direct[0, C["l_hip"]] - direct[0, C["l_knee"]]))
    with pytest.raises(InputError, match="times outside"):
        bvh_canonical_points(clip, [clip.n_frames * clip.frame_time + 1])


def test_endpoint_duplicates_follow_the_contract():
    P = np.random.default_rng(0).normal(size=(4, 20, 3))
    E = endpoints_from_canonical(P)
    e = {n: E[:, i] for i, n in enumerate(ENDPOINT_NAMES)}
    np.testing.assert_array_equal(e["torsoProximal"], P[:, C["thorax"]])
    np.testing.assert_array_equal(e["headProximal"], P[:, C["thorax"]])
    np.testing.assert_array_equal(e["torsoDistal"], P[:, C["pelvis"]])
    np.testing.assert_array_equal(e["upperLArmDistal"], e["lowerLArmProximal"])
    np.testing.assert_array_equal(e["upperRLegDistal"], P[:, C["r_knee"]])
    np.testing.assert_array_equal(e["lowerRLegDistal"], P[:, C["r_ankle"]])
    np.testing.assert_array_equal(e["headDistal"], P[:, C["head_top"]])
    np.testing.assert_array_equal(e["lowerLArmDistal"], P[:, C["l_wrist"]])


def test_unknown_skeleton_is_an_input_error():
    with pytest.raises(InputError, match="unknown skeleton"):
        detect_family(["Root", "Thing1", "Thing2"], source="x.bvh")
