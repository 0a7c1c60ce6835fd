"""``run.outputs``: what a finished pass writes beside its result, and its messages' frame lists.

The body_pose XML is read back with the standard library's XML parser (not the package's
reader), the BVH with the package's BVH reader (its forward kinematics, held to other files in
``tests/io/test_bvh.py``). ``kernels_cached`` is tested with a run in ``test_pipeline.py``.
"""

import types
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from voxelmocap.body import BodyModel
from voxelmocap.io.bvh import read_bvh
from voxelmocap.joints import ENDPOINT_NAMES, LANDMARK_NAMES, endpoints_to_landmarks
from voxelmocap.run.outputs import frame_list, write_exports


@pytest.mark.parametrize("frames, n, text", [
    ([], 10, ""),
    ([7], 10, "7"),
    (np.arange(1, 11), 10, "1, 2, 3, 4, 5, 6, 7, 8, 9, 10"),
    (np.arange(1, 12), 10, "1, 2, 3, 4, 5, 6, 7, 8, 9, 10 … (1 more)"),
    (np.array([40, 3, 12, 5]), 2, "40, 3 … (2 more)"),
    ([np.int64(8), 9.0], 1, "8 … (1 more)"),
])
def test_frame_list(frames, n, text):
    assert frame_list(frames, n) == text


def _poses(n=6, seed=2):
    """``n`` seeded legal poses of the average adult, as endpoints ``(n, 20, 3)`` mm."""
    model = BodyModel()
    rng = np.random.default_rng(seed)
    states = model.clip(model.default_state() + rng.normal(size=(n, 27)) * np.r_[
        np.full(3, 150.0), np.full(24, 0.3)])
    return model.endpoints(states)


def _xml_frames(path):
    root = ET.parse(path).getroot()
    frames, points, enabled = [], [], []
    for frame in root.iter("Frame"):
        frames.append(int(frame.findtext("Number")))
        joints = frame.find("Pose").findall("Joint")
        assert [j.findtext("Name") for j in joints] == list(ENDPOINT_NAMES)
        points.append([[float(j.findtext(a)) for a in "XYZ"] for j in joints])
        enabled.append([j.findtext("Enabled") == "1" for j in joints])
    return root, np.array(frames), np.array(points), np.array(enabled)


def test_the_exports_hold_the_tracked_frames(tmp_path):
    """XML: the frames, every endpoint to its 6 decimals, disabled where nobody was seen, the
    run named in the root's attributes (the ground truth's data set name when it has one); BVH:
    one frame each at the run's rate, its joints where the landmarks are."""
    endpoints = _poses()
    frames = np.arange(11, 17)
    observed = np.array([True, True, False, True, False, True])
    seq = types.SimpleNamespace(subject="S2", action="Jog", trial=1)
    gt = types.SimpleNamespace(attributes={"DatasetName": "HumanEvaII", "Partition": "Test"})
    xml, bvh = tmp_path / "Jog_1.xml", tmp_path / "Jog_1.bvh"
    write_exports(xml, bvh, seq, gt, frames, endpoints, 50.0, observed=observed)

    root, got_frames, points, enabled = _xml_frames(xml)
    assert root.tag == "SEQUENCE"
    assert root.attrib == {"DatasetName": "HumanEvaII", "DatasetBasePath": "../",
                           "SubjectName": "S2", "ActionType": "Jog", "Trial": "1",
                           "FrameStart": "11", "FrameEnd": "16", "Partition": "Test"}
    np.testing.assert_array_equal(got_frames, frames)
    np.testing.assert_allclose(points, endpoints, rtol=0, atol=5e-7)
    np.testing.assert_array_equal(enabled, np.repeat(observed[:, None], 20, axis=1))

    clip = read_bvh(bvh, unit="cm")
    assert clip.n_frames == 6 and clip.fps == pytest.approx(50.0)
    positions = clip.positions()[:, [clip.index(name) for name in LANDMARK_NAMES]]
    np.testing.assert_allclose(positions, endpoints_to_landmarks(endpoints), atol=1e-3)


def test_without_ground_truth_or_flags_every_endpoint_is_enabled(tmp_path):
    endpoints = _poses(n=3, seed=5)
    seq = types.SimpleNamespace(subject="S1", action="Walking", trial=2)
    write_exports(tmp_path / "a.xml", tmp_path / "a.bvh", seq, None, [4, 5, 6], endpoints, 60.0)
    root, frames, points, enabled = _xml_frames(tmp_path / "a.xml")
    assert (root.get("DatasetName"), root.get("Partition"), root.get("Trial")) == \
        ("HumanEvaI", "Validate", "2")
    assert frames.tolist() == [4, 5, 6] and enabled.all()
    np.testing.assert_allclose(points, endpoints, rtol=0, atol=5e-7)
    assert read_bvh(tmp_path / "a.bvh", unit="cm").fps == pytest.approx(60.0)
