"""``scripts/landmark_bias.py``: errors in the truth's pelvis frame, and the runs it finds."""

from __future__ import annotations

import numpy as np
import pytest

from voxelmocap.body import BodyModel
from voxelmocap.body.state import STATE_INDEX


@pytest.fixture(scope="module")
def bias(load_script):
    return load_script("landmark_bias")


def test_a_constant_offset_in_the_body_frame_is_found_in_every_frame(bias):
    """Landmarks of a body turned to random headings (and leaning), each estimate displaced by
    the same offset in the body's own frame (x: right hip → left hip, z: pelvis → thorax):
    the errors in that frame are that offset in every frame, whatever the heading."""
    rng = np.random.default_rng(5)
    model = BodyModel()
    states = np.repeat(model.default_state()[None], 6, axis=0)
    states[:, STATE_INDEX["root_yaw"]] = rng.uniform(-np.pi, np.pi, 6)
    states[:, :2] = rng.uniform(-500.0, 500.0, (6, 2))
    gt = model.landmarks(states)
    offset = np.array([30.0, -12.0, 45.0])
    x = gt[:, 8] - gt[:, 11]
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    z = gt[:, 0] - gt[:, 1]
    z -= np.sum(z * x, axis=1, keepdims=True) * x
    z /= np.linalg.norm(z, axis=1, keepdims=True)
    y = np.cross(z, x)
    est = gt + (offset[0] * x + offset[1] * y + offset[2] * z)[:, None, :]
    d = bias.body_frame_errors(est, gt)
    np.testing.assert_allclose(d, np.broadcast_to(offset, d.shape), atol=1e-9)


def test_a_limb_end_moved_along_its_limb_counts_along_it(bias):
    """Each wrist and ankle of random poses moved beyond (or short of) its joint along the limb
    by a known length: the component along the estimated limb is that length; the true ends
    read zero."""
    from voxelmocap.joints import LANDMARK_NAMES

    rng = np.random.default_rng(9)
    model = BodyModel()
    states = model.clip(model.default_state()[None] + rng.normal(size=(8, 27)) * np.r_[
        np.full(3, 50.0), np.full(24, 0.3)])
    gt = model.landmarks(states)
    index = {n: i for i, n in enumerate(LANDMARK_NAMES)}
    est = gt.copy()
    lengths = (10.0, 20.0, -15.0, 30.0)
    for (joint, end), length in zip(bias.LIMB_ENDS, lengths, strict=True):
        axis = gt[:, index[end]] - gt[:, index[joint]]
        est[:, index[end]] += length * axis / np.linalg.norm(axis, axis=1, keepdims=True)
    np.testing.assert_allclose(bias.along_limb(est, gt), lengths, atol=1e-9)
    np.testing.assert_allclose(bias.along_limb(gt, gt), 0.0, atol=1e-12)


def test_finds_the_runs_of_a_bench_facing_tag_folder(bias, tmp_path):
    for render, seed in (("Jog_h0_n1_f100", 0), ("Jog_h0_n1_f100", 2), ("Box_h45_n2_f40", 1)):
        folder = tmp_path / "tag" / render / f"seed{seed}" / "S2"
        folder.mkdir(parents=True)
        (folder / "Jog_1.h5").touch()
    found = list(bias.runs(tmp_path / "tag", None, str(tmp_path / "renders")))
    assert [label for label, _, _ in found] == ["Box_h45_n2_f40 seed1", "Jog_h0_n1_f100 seed0",
                                                 "Jog_h0_n1_f100 seed2"]
    assert found[1][2] == tmp_path / "renders" / "Jog_h0_n1_f100" / "data" / "S2" / \
        "Mocap_Data" / "Jog_1.xml"
