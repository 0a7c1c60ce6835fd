"""Qualisys .qca.txt: Pose2Sim's own numbers on its demo, and a synthetic file of known cameras."""

import json
import re
from pathlib import Path

import cv2
import numpy as np
import pytest

from voxelmocap.camera import Camera, Rig
from voxelmocap.errors import InputError
from voxelmocap.io.qualisys import qca_to_opencv, read_qca

DATA = Path(__file__).resolve().parents[1] / "data"
#: Pose2Sim 0.10.49's demo calibration, copied unchanged (BSD-3-Clause; tests/data/README.md).
DEMO_QCA = DATA / "pose2sim_demo_Calib.qca.txt"


def _known_rig() -> Rig:
    rng = np.random.default_rng(5)
    cams = []
    for i, angle in enumerate((0.3, 2.0, 4.1, 5.5)):
        centre = np.array([3500 * np.cos(angle), 3500 * np.sin(angle), 1500 + 200 * i])
        forward = np.array([0.0, 0.0, 1000.0]) - centre
        forward /= np.linalg.norm(forward)
        right = np.cross(forward, [0.0, 0.0, 1.0])
        right /= np.linalg.norm(right)
        down = np.cross(forward, right)
        R = np.stack([right, down, forward])
        cams.append(Camera(f"cam{i * 5 + 2}", fc=rng.uniform(1500, 1700, 2),
                           cc=(540 + rng.uniform(-20, 20), 960 + rng.uniform(-20, 20)),
                           kc=np.array([-0.05, 0.12, 0.001, -0.0007, 0.0]), R=R, T=-R @ centre,
                           size=(1088, 1920)))
    return Rig(cams)


def _qca_text(rig, *, left=24, top=40, binning=1, extra="", rotation="0", model="none") -> str:
    """QTM's conventions written out from the known cameras (sub-pixels, sensor window, centre,
    rotation with y up / z backwards)."""
    out = []
    for cam in rig:
        w, h = cam.size
        M = (np.diag([1.0, -1.0, -1.0]) @ cam.R).tolist()
        c = cam.center.tolist()
        (fx, fy), (cx, cy) = cam.fc.tolist(), cam.cc.tolist()
        k1, k2, p1, p2, _ = cam.kc.tolist()
        s = 64 * binning
        rot = " ".join(f'r{i + 1}{j + 1}="{M[i][j]!r}"' for i in range(3) for j in range(3))
        out.append(
            f'<camera serial="{cam.name}" model="{model}" viewrotation="{rotation}" '
            f'avg-residual="0.5"><fov_video left="{left}" top="{top}" '
            f'right="{left + w * binning - 1}" bottom="{top + h * binning - 1}"/>'
            f'<transform x="{c[0]!r}" y="{c[1]!r}" z="{c[2]!r}" {rot}/>'
            f'<intrinsic focalLengthU="{fx * s!r}" focalLengthV="{fy * s!r}" '
            f'centerPointU="{(cx + left) * s!r}" centerPointV="{(cy + top) * s!r}" '
            f'radialDistortion1="{k1 * s!r}" radialDistortion2="{k2 * s!r}" '
            f'radialDistortion3="0" tangentalDistortion1="{p1 * s!r}" '
            f'tangentalDistortion2="{p2 * s!r}" skew="0"/></camera>')
    return f"<calibration><cameras>{''.join(out)}{extra}</cameras></calibration>"


def _points(n=300, seed=0):
    return np.random.default_rng(seed).uniform([-900, -900, 0], [900, 900, 1900], (n, 3))


def test_synthetic_qca_projects_as_the_known_cameras(tmp_path):
    rig = _known_rig()
    path = tmp_path / "Calib.qca.txt"
    path.write_text(_qca_text(rig))
    read = read_qca(path)
    # natural order of the serials: cam2, cam7, cam12, cam17 (not cam12 before cam2)
    assert read.names == ["cam2", "cam7", "cam12", "cam17"]
    pts = _points()
    for cam in rig:
        got = read[cam.name]
        assert got.size == cam.size
        rvec, _ = cv2.Rodrigues(cam.R)
        K = np.array([[cam.fc[0], 0, cam.cc[0]], [0, cam.fc[1], cam.cc[1]], [0, 0, 1]])
        expected, _ = cv2.projectPoints(pts, rvec, cam.T, K, cam.kc)
        np.testing.assert_allclose(got.project(pts), expected.reshape(-1, 2), atol=1e-6)
        np.testing.assert_allclose(got.center, cam.center, atol=1e-9)


def test_binning_divides_as_pose2sim(tmp_path):
    # Pose2Sim divides the sub-pixel values by 64 × binning, then subtracts the (unbinned) window
    # offset; the image is the window divided by binning.
    rig = _known_rig()
    path = tmp_path / "Calib.qca.txt"
    path.write_text(_qca_text(rig, left=0, top=0, binning=2))
    for cam, c in zip(rig, qca_to_opencv(path, binning_factor=2), strict=True):
        assert c["size"] == cam.size
        np.testing.assert_allclose(c["K"][[0, 1, 0, 1], [0, 1, 2, 2]],
                                   [*cam.fc, *cam.cc], rtol=1e-12)


def test_marker_cameras_are_skipped(tmp_path):
    rig = _known_rig()
    marker = _qca_text(rig[:1], model="Oqus 700").split("<cameras>")[1].split("</cameras>")[0]
    marker = marker.replace('serial="cam2"', 'serial="m1"')
    path = tmp_path / "Calib.qca.txt"
    path.write_text(_qca_text(rig[1:], extra=marker))
    assert read_qca(path).names == ["cam7", "cam12", "cam17"]


@pytest.mark.parametrize(("text", "message"), [
    (lambda r: _qca_text(r, rotation="90"), "viewrotation=90"),
    (lambda r: _qca_text(r).replace('focalLengthU="', 'focalLengthU="x'), "focalLengthU"),
    (lambda r: _qca_text(r).replace("<transform", "<nottransform"), "has no <transform>"),
    (lambda r: _qca_text(r, model="Oqus"), "only marker cameras"),
    (lambda r: "<calibration><cameras>", "malformed XML"),
    (lambda r: "<foo/>", "expected <calibration>"),
    (lambda r: re.sub(r'r11="[^"]*"', 'r11="3.0"', _qca_text(r), count=1), "not a rotation"),
])
def test_bad_qca_is_one_line_naming_the_file(tmp_path, text, message):
    path = tmp_path / "Calib.qca.txt"
    path.write_text(text(_known_rig()))
    with pytest.raises(InputError, match=message) as info:
        read_qca(path)
    assert str(info.value).startswith(str(path)) and "\n" not in str(info.value)


def test_unused_terms_are_noted(tmp_path):
    path = tmp_path / "Calib.qca.txt"
    path.write_text(_qca_text(_known_rig()).replace('radialDistortion3="0"',
                                                    'radialDistortion3="0.01"', 1))
    notes = []
    read_qca(path, notes=notes)
    assert len(notes) == 1 and "radialDistortion3=0.01 is not used" in notes[0]


def test_demo_matches_pose2sim_conversion():
    """Pose2Sim 0.10.49's calib_qca_fun on its demo (scripts/qca_reference.py wrote the fixture)."""
    reference = json.loads((DATA / "pose2sim_demo_qca.json").read_text())["cameras"]
    rig = read_qca(DEMO_QCA)
    assert rig.names == [c["name"] for c in reference]
    for cam, ref in zip(rig, reference, strict=True):
        K, dist, rvec, tvec = cam.to_opencv()
        assert list(cam.size) == [int(v) for v in ref["size"]]
        np.testing.assert_allclose(K, ref["matrix"], rtol=1e-12)
        np.testing.assert_allclose(dist, [*ref["distortions"], 0.0], atol=1e-15)
        np.testing.assert_allclose(rvec, ref["rotation"], atol=1e-12)
        np.testing.assert_allclose(tvec, np.array(ref["translation_m"]) * 1000.0, atol=1e-9)
        # and the projection of points in the capture volume, by OpenCV from Pose2Sim's values
        pts = _points(seed=1)
        expected, _ = cv2.projectPoints(pts / 1000.0, np.array(ref["rotation"]),
                                        np.array(ref["translation_m"]), np.array(ref["matrix"]),
                                        np.array(ref["distortions"]))
        np.testing.assert_allclose(cam.project(pts), expected.reshape(-1, 2), atol=1e-6)
