import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from voxelmocap.io.bvh import read_bvh
from voxelmocap.io.bvh_writer import write_landmarks_bvh
from voxelmocap.joints import LANDMARK_NAMES

REST = np.array([
    [0, 0, 1450], [0, 0, 1000], [-180, 0, 1420], [-190, 0, 1130], [-195, 0, 880],
    [180, 0, 1420], [190, 0, 1130], [195, 0, 880], [-95, 0, 940], [-100, 0, 510],
    [-100, 0, 80], [95, 0, 940], [100, 0, 510], [100, 0, 80], [0, 0, 1700],
], dtype=float)


def moving_figure(n=12, seed=0):
    """Rigidly moving figure with a bending left elbow: exact for a rigid skeleton."""
    rng = np.random.default_rng(seed)
    frames = []
    for t in range(n):
        pose = REST.copy()
        bend = Rotation.from_euler("x", 1.2 * t / n)
        pose[4] = pose[3] + bend.apply(pose[4] - pose[3])
        rot = Rotation.from_rotvec(rng.normal(0, 0.4, 3))
        frames.append(rot.apply(pose - REST[1]) + REST[1] + [20.0 * t, -5.0 * t, 0])
    return np.array(frames)


@pytest.mark.parametrize("units", ["cm", "mm"])
def test_bvh_round_trip_through_the_independent_reader(tmp_path, units):
    landmarks = moving_figure()
    path = tmp_path / "tracked.bvh"
    write_landmarks_bvh(path, landmarks, fps=60.0, units=units)
    clip = read_bvh(path, unit=units)
    assert clip.n_frames == len(landmarks)
    assert clip.fps == pytest.approx(60.0)
    pos = clip.positions()
    idx = [clip.index(name) for name in LANDMARK_NAMES]
    np.testing.assert_allclose(pos[:, idx], landmarks, atol=1e-3)


def test_rotations_explain_single_child_bones(tmp_path):
    # with the position channels zeroed except the root, the rotations alone must still put the
    # left wrist (a single-child chain) at the right place
    landmarks = moving_figure()
    path = tmp_path / "t.bvh"
    write_landmarks_bvh(path, landmarks, fps=30.0, units="mm")
    clip = read_bvh(path, unit="mm")
    rot, _ = clip.global_transforms()
    e, w = clip.index("l_elbow"), clip.index("l_wrist")
    bone_rest = clip.offsets[w]
    # wrist = elbow + R_elbow_global · rest bone (BVH axes)
    _, pos = clip.global_transforms()
    np.testing.assert_allclose(pos[:, w], pos[:, e] + rot[:, e] @ bone_rest, atol=1e-6)


def test_rejects_bad_shapes(tmp_path):
    with pytest.raises(ValueError, match="15, 3"):
        write_landmarks_bvh(tmp_path / "x.bvh", np.zeros((3, 14, 3)), fps=60)
