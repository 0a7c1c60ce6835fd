"""The port of the HumanEva toolkit's ``mocap_stream``/``cur_frame`` against the toolkit's own output.

The reference vectors (``../shared/humaneva_toolkit_vectors``: synthetic inputs in the toolkit's
formats, and what the unmodified toolkit computed from them in GNU Octave) are the truth; those
tests skip when the folder is absent. The self-contained tests check the interpolation against
scipy's ``Slerp`` in closed form, and the label/``.mp`` lookups against hand-worked cases.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest
from humaneva_mocap_fixture import (
    LABELS,
    PHYSICAL,
    synthetic_markers,
    write_mocap_mat,
    write_mp,
)
from scipy.spatial.transform import Rotation, Slerp

from voxelmocap.io.humaneva_mocap import (
    MocapStream,
    SubjectMeasurements,
    find_labels,
    poses_to_body_pose,
)
from voxelmocap.io.humaneva_mocap_pose import SEGMENT_NAMES, quat_from_matrix, quat_slerp
from voxelmocap.joints import ENDPOINT_NAMES

VECTORS = Path(__file__).resolve().parents[2] / ".." / "shared" / "humaneva_toolkit_vectors"


def _cases() -> list[dict]:
    path = VECTORS / "inputs" / "cases.tsv"
    if not path.is_file():
        return []
    out = []
    for line in path.read_text().splitlines():
        name, trial, static, mp, offset, scaling, ks = line.split("\t")
        out.append({"name": name, "trial": trial, "static": static, "mp": mp,
                    "offset": 0.0 if offset == "default" else float(offset),
                    "scaling": 1.0 if scaling == "default" else float(scaling),
                    "frames": [int(k) for k in ks.split()]})
    return out


CASES = _cases()
CASE_IDS = [c["name"] for c in CASES] or ["vectors-absent"]


@pytest.fixture(params=CASES or [None], ids=CASE_IDS)
def case(request):
    if request.param is None:
        pytest.skip("HumanEva toolkit reference vectors not available (outputs of the official "
                    "toolkit for synthetic mocap, expected in ../shared/humaneva_toolkit_vectors "
                    "beside the checkout; not shipped)")
    c = request.param
    inputs = VECTORS / "inputs"
    stream = MocapStream.open(inputs / f"{c['trial']}.mat", inputs / f"{c['static']}.mat",
                              inputs / f"{c['mp']}.mp")
    poses = stream.cur_frames(stream.positions(c["offset"], c["scaling"], c["frames"]))
    return c, stream, poses


def _rows(name: str) -> list[dict]:
    with open(VECTORS / "expected" / name, newline="") as fh:
        return list(csv.DictReader(fh))


def test_vectors_status_validity_endpoints(case):
    c, _, poses = case
    rows = _rows(f"{c['name']}.csv")
    assert [int(r["frame_id"]) for r in rows] == c["frames"]
    np.testing.assert_array_equal(poses.positions, [float(r["position"]) for r in rows])
    assert list(poses.status) == [r["status"] for r in rows]
    worst = 0.0
    for i, r in enumerate(rows):
        if r["status"] != "ok":
            assert not poses.valid[i]
            assert np.isnan(poses.endpoints[i]).all()
            continue
        assert poses.valid[i] == bool(int(r["valid"])), r["frame_id"]
        assert poses.bad_marker_warning[i] == bool(int(r["bad_marker_warning"])), r["frame_id"]
        assert all(int(r[f"{n}Enabled"]) == int(r["valid"]) for n in ENDPOINT_NAMES)
        expected = np.array([[float(r[f"{n}_{a}"]) for a in "xyz"] for n in ENDPOINT_NAMES])
        got = poses.endpoints[i]
        np.testing.assert_array_equal(np.isnan(got), np.isnan(expected), err_msg=r["frame_id"])
        finite = np.isfinite(expected)
        worst = max(worst, float(np.abs(got[finite] - expected[finite]).max(initial=0.0)))
        lengths = np.array([float(r[f"length_{j}"]) for j in range(1, 19)])
        np.testing.assert_allclose(poses.lengths[i], lengths, rtol=0, atol=1e-9, equal_nan=True)
    # The acceptance bound is 1e-6 mm; a float64 port of the toolkit's arithmetic is ~1e-13.
    assert worst <= 1e-9, worst


def test_vectors_transforms(case):
    c, _, poses = case
    rows = _rows(f"{c['name']}_xforms.csv")
    assert rows, "no transforms to compare"
    frame_row = {k: i for i, k in enumerate(c["frames"])}
    for r in rows:
        i = frame_row[int(r["frame_id"])]
        m = np.array([float(r[f"m{a}{b}"]) for a in range(1, 5) for b in range(1, 5)]).reshape(4, 4)
        got = poses.xforms[i, SEGMENT_NAMES.index(r["segment"])]
        np.testing.assert_allclose(got[:3, :3], m[:3, :3], rtol=0, atol=1e-12, equal_nan=True,
                                   err_msg=f"{r['frame_id']} {r['segment']}")
        np.testing.assert_allclose(got[:, 3], m[:, 3], rtol=0, atol=1e-9, equal_nan=True)
        np.testing.assert_array_equal(got[3], m[3])


def test_vectors_limb_parameters(case):
    c, stream, _ = case
    rows = [r for r in _rows("params.csv") if r["case"] == c["name"]]
    expected = np.array([[float(r[f"c{j}"]) for j in range(1, 6)] for r in rows])
    np.testing.assert_allclose(stream.params, expected, rtol=0, atol=1e-9)


def test_vectors_body_pose_conversion(case):
    # Invalid frames → Enabled 0; NaN endpoints (valid frames at p = 30) → disabled, never NaN.
    c, _, poses = case
    keep = poses.status != "empty"
    gt = poses_to_body_pose(_take(poses, keep), np.asarray(c["frames"])[keep])
    assert np.isfinite(gt.endpoints).all()
    ok = poses.status[keep] == "ok"
    expected = (poses.valid[keep] & ok)[:, None] & np.isfinite(poses.endpoints[keep]).all(-1)
    np.testing.assert_array_equal(gt.enabled, expected)
    np.testing.assert_array_equal(gt.endpoints[gt.enabled], poses.endpoints[keep][gt.enabled])


def _take(poses, keep):
    from dataclasses import replace

    return replace(poses, positions=poses.positions[keep], status=poses.status[keep],
                   message=[m for m, k in zip(poses.message, keep, strict=True) if k],
                   valid=poses.valid[keep], endpoints=poses.endpoints[keep],
                   lengths=poses.lengths[keep], xforms=poses.xforms[keep],
                   bad_marker_warning=poses.bad_marker_warning[keep])


# ---------------------------------------------------------------------- self-contained
def _two_frame_stream(tmp_path, rotations, shifts, *, mutate=None):
    markers = synthetic_markers(rotations, shifts)
    if mutate is not None:
        mutate(markers)
    trial = write_mocap_mat(tmp_path / "T_1.mat", markers)
    static = write_mocap_mat(tmp_path / "Static.mat", synthetic_markers(rotations[:1], shifts[:1]),
                             compress=False)
    return MocapStream.open(trial, static, write_mp(tmp_path / "S.mp")), markers


def test_slerp_and_lerp_at_half_match_scipy(tmp_path):
    r1 = Rotation.from_euler("zx", [30, 10], degrees=True)
    r2 = Rotation.from_euler("zxy", [75, 25, -15], degrees=True)
    # The closed form is the shortest-path slerp; the toolkit takes it when the vector parts of
    # the two quaternions point the same way (checked here, so the reference is the right one).
    assert np.dot(r1.as_quat()[:3], r2.as_quat()[:3]) > 0
    shifts = [np.array([0.0, 0.0, 0.0]), np.array([40.0, -20.0, 10.0])]
    stream, markers = _two_frame_stream(tmp_path, [r1, r2], shifts)
    poses = stream.cur_frames([1.5])
    assert list(poses.status) == ["ok"] and poses.valid[0]
    half = Slerp([0, 1], Rotation.concatenate([r1, r2]))([0.5]).as_matrix()[0]
    flip = np.diag([-1.0, 1.0, -1.0])  # the toolkit's yRotation(π), up to 1.2e-16
    col = {label: i for i, label in enumerate(LABELS)}
    for segment, joint, post in (("head", "TRXO", np.eye(3)), ("upperLLeg", "LFEP", flip),
                                 ("lowerRLeg", "RFEO", flip)):
        xform = poses.xforms[0, SEGMENT_NAMES.index(segment)]
        np.testing.assert_allclose(xform[:3, :3], half @ post, atol=1e-12)
        np.testing.assert_allclose(xform[:3, 3], markers[:, col[joint]].mean(axis=0), atol=1e-9)
    # thigh distal end = hip + L3 · (slerped z axis turned by yRotation(π)), L3 the mean length
    hip = markers[:, col["LFEP"]]
    knee = markers[:, col["LFEO"]]
    l3 = np.linalg.norm(hip - knee, axis=1).mean()
    thigh_end = poses.endpoints[0, ENDPOINT_NAMES.index("upperLLegDistal")]
    np.testing.assert_allclose(thigh_end, hip.mean(axis=0) - l3 * half[:, 2], atol=1e-9)


def test_validity_uses_floor_and_ceil_and_the_coordinate_sum(tmp_path):
    rots = [Rotation.identity()] * 3
    shifts = [np.zeros(3)] * 3
    lwrb = PHYSICAL.index("LWRB")
    rasi = PHYSICAL.index("RASI")

    def mutate(m):
        m[1, lwrb] = 0.0  # frame 2: a missing marker
        m[2, rasi] = (5.0, -2.0, -3.0)  # frame 3: present, but x + y + z == 0

    stream, _ = _two_frame_stream(tmp_path, rots, shifts, mutate=mutate)
    poses = stream.cur_frames([1.0, 1.5, 2.0, 2.5, 3.0, 3.5])
    assert list(poses.status) == ["ok", "ok", "ok", "ok", "error", "empty"]
    # p = 1 reads frames 1 and 1 (ceil); p = 1.5 touches frame 2; p = 2.5 touches 2 and 3
    assert list(poses.valid) == [True, False, False, False, False, False]


def test_missing_axis_point_falls_back_to_identity_but_keeps_the_translation(tmp_path):
    turn = Rotation.from_euler("z", 40, degrees=True)
    shifts = [np.zeros(3), np.array([10.0, 0, 0]), np.array([20.0, 0, 0])]
    col = {label: i for i, label in enumerate(LABELS)}

    def mutate(m):
        m[0, col["HEDL"]] = 0.0  # the head's y-axis point, frame 1

    stream, markers = _two_frame_stream(tmp_path, [turn] * 3, shifts, mutate=mutate)
    poses = stream.cur_frames([1.0, 1.25, 2.5])
    assert list(poses.status) == ["ok"] * 3
    head = SEGMENT_NAMES.index("head")
    for i, a in enumerate((0.0, 0.25)):  # frames 1 and 2: identity axes, even at weight 0
        assert poses.bad_marker_warning[i]
        np.testing.assert_allclose(poses.xforms[i, head, :3, :3], np.eye(3), atol=1e-15)
        np.testing.assert_allclose(poses.xforms[i, head, :3, 3],
                                   (1 - a) * markers[0, col["TRXO"]] + a * markers[1, col["TRXO"]])
    assert not poses.bad_marker_warning[2]  # frames 2 and 3 are complete
    np.testing.assert_allclose(poses.xforms[2, head, :3, :3], turn.as_matrix(), atol=1e-12)


def test_orthogonality_test_is_one_sided(tmp_path):
    col = {label: i for i, label in enumerate(LABELS)}
    rots, shifts = [Rotation.identity()] * 3, [np.zeros(3)] * 3

    def tilt(sign):
        def mutate(m):
            # the pelvis x-axis point leans towards y: x·y = sign · 3e-4
            m[1, col["PELA"]] += (0.0, sign * 0.03, 0.0)
        return mutate

    for sign, status in ((1, "error"), (-1, "ok")):
        stream, _ = _two_frame_stream(tmp_path, rots, shifts, mutate=tilt(sign))
        assert list(stream.cur_frames([1.5, 2.5]).status) == [status, status]


def test_slerp_hemisphere_test_uses_the_vector_parts_only():
    # ±10° about x: the vector parts have opposite signs, so the toolkit negates the second
    # quaternion and goes the long way: half-way is a 180° turn, not the identity.
    c, s = np.cos(np.radians(5)), np.sin(np.radians(5))
    q = quat_slerp(np.array([c, s, 0, 0]), np.array([c, -s, 0, 0]), 0.5)
    np.testing.assert_allclose(np.abs(q), [0, 1, 0, 0], atol=1e-15)


def test_matrix_to_quaternion_takes_the_first_largest_diagonal_term():
    # 180° about y: yy = 4 is the largest term, so the "yy" branch gives (0, 0, 1, 0)
    q, non_unit = quat_from_matrix(np.diag([-1.0, 1.0, -1.0]))
    np.testing.assert_array_equal(q, [0.0, 0.0, 1.0, 0.0])
    assert not non_unit
    q, non_unit = quat_from_matrix(2 * np.eye(3))  # not a rotation: the toolkit would stop
    assert non_unit


def test_label_lookup_is_matlab_findstr():
    labels = ["T1", "T10", "LFEP", "", "RFRA", "S1:LSHO"]
    assert find_labels(labels, "T10") == [0, 1]  # the shorter label "T1" occurs in "T10"
    assert find_labels(labels, "LSHO") == [5]  # a prefixed label contains the query
    assert find_labels(labels, "LFE") == [2]
    assert find_labels(labels, "RFRM") == []


def test_mp_lookup_is_first_name_containing_the_query(tmp_path):
    mp = SubjectMeasurements(tmp_path / "x.mp", [("LKneeWidthX", 1.0), ("LKneeWidth", 2.0),
                                                 ("Head", 3.0)])
    assert mp.value("KneeWidth") == 1.0  # first *containing* name, not the exact one
    assert mp.value("LKneeWidth") == 1.0
    # a query longer than the NUL-padded name matrix matches a full-width name it contains
    assert mp.value("LKneeWidthXYZ") == 1.0
    with pytest.raises(Exception, match="HeadOffset"):
        mp.value("HeadOffset")  # "Head" is padded with NULs: not inside the query
