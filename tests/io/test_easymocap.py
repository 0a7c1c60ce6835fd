"""EasyMocap intri.yml / extri.yml: round trip, files as EasyMocap writes them, bad files."""

import re

import cv2
import numpy as np
import pytest

from voxelmocap.camera import Camera, Rig
from voxelmocap.errors import InputError
from voxelmocap.io.calibration import read_rig
from voxelmocap.io.easymocap import read_easymocap, write_easymocap
from voxelmocap.synth import default_rig_path


def _rig() -> Rig:
    return read_rig(default_rig_path()).select(["C1", "C2", "BW1"])


def _points():
    return np.random.default_rng(2).uniform([-1500, -1500, 0], [1500, 1500, 2000], (200, 3))


def test_round_trip_projects_identically(tmp_path):
    rig = _rig()
    intri, extri = write_easymocap(rig, tmp_path)
    # OpenCV itself reads what was written: K, metres, the Rodrigues vector
    fs = cv2.FileStorage(str(extri), cv2.FILE_STORAGE_READ)
    np.testing.assert_allclose(fs.getNode("T_C2").mat().reshape(3), rig["C2"].T / 1000.0,
                               rtol=1e-15)
    np.testing.assert_allclose(cv2.Rodrigues(fs.getNode("R_C2").mat())[0], rig["C2"].R,
                               atol=1e-9)
    fs.release()
    read, unsized = read_easymocap(intri, extri)
    assert read.names == rig.names and not unsized
    for cam in rig:
        assert read[cam.name].size == cam.size
        np.testing.assert_allclose(read[cam.name].project(_points()), cam.project(_points()),
                                   atol=1e-6)


def test_without_sizes_the_cameras_are_unsized(tmp_path):
    read, unsized = read_easymocap(*write_easymocap(_rig(), tmp_path, sizes=False))
    assert unsized == {"C1", "C2", "BW1"} and read["C1"].size == (1, 1)  # a placeholder


def _easymocap_style(cam: Camera, name: str, *, dist_key="dist", rvec=True) -> tuple[str, str]:
    """One camera as EasyMocap's FileStorage.write lays it out (CRLF, 6 decimals)."""
    K, dist, r, t = cam.to_opencv()

    def mat(key, value):
        value = np.atleast_2d(value)
        return (f"{key}: !!opencv-matrix\r\n  rows: {value.shape[0]}\r\n  cols: {value.shape[1]}"
                f"\r\n  dt: d\r\n  data: [{', '.join(f'{v:.6f}' for v in value.reshape(-1))}]\r\n")

    intri = mat(f"K_{name}", K) + mat(f"{dist_key}_{name}", dist[None])
    extri = (mat(f"R_{name}", r.reshape(3, 1)) if rvec else "") + mat(f"Rot_{name}", cam.R) \
        + mat(f"T_{name}", (t / 1000).reshape(3, 1))
    return intri, extri


@pytest.mark.parametrize("names_block", ['names:\r\n  - "1"\r\n  - "2"\r\n',
                                         "names:\r\n  - 1\r\n  - 2\r\n"])
def test_reads_files_as_easymocap_writes_them(tmp_path, names_block):
    rig = _rig()
    a = _easymocap_style(rig["C1"], "1")
    b = _easymocap_style(rig["C2"], "2", dist_key="D", rvec=False)  # older keys, Rot_ only
    head = "%YAML:1.0\r\n---\r\n" + names_block
    (tmp_path / "intri.yml").write_text(head + a[0] + b[0])
    (tmp_path / "extri.yml").write_text(head + a[1] + b[1])
    read, unsized = read_easymocap(tmp_path / "intri.yml", tmp_path / "extri.yml")
    assert read.names == ["1", "2"] and unsized == {"1", "2"}
    for name, cam in (("1", rig["C1"]), ("2", rig["C2"])):
        # 6 decimals in metres and in K: agreement to a few hundredths of a pixel
        np.testing.assert_allclose(read[name].project(_points()), cam.project(_points()),
                                   atol=0.05)


@pytest.mark.parametrize(("damage", "file", "message"), [
    (lambda t: t.replace("T_C2", "X_C2"), "extri.yml", "no 'T_C2'"),
    (lambda t: t.replace("names:", "nomen:"), "intri.yml", "no 'names' list"),
    (lambda t: "not: [yaml", "intri.yml", "OpenCV YAML"),
    (lambda t: t.replace("rows: 3\n  cols: 3", "rows: 2\n  cols: 3", 1), "intri.yml",
     "'K_C1' is not an opencv-matrix"),
    (lambda t: re.sub(r"(R_C1: !!opencv-matrix\n  rows: )3(\n  cols: 1\n  dt: d\n  data: \[)"
                      r"[^,]*, ", r"\g<1>2\g<2>", t), "extri.yml", "'R_C1' has 2 values, expected 3"),
    # a list at the top (OpenCV's getNode asserted: a traceback; found by the fuzz test)
    (lambda t: "-", "extri.yml", "not a map of named entries"),
    (lambda t: "%YAML:1.0\n---\n- 1\n- 2\n", "intri.yml", "not a map of named entries"),
])
def test_bad_files_name_the_file(tmp_path, damage, file, message):
    write_easymocap(_rig(), tmp_path)
    path = tmp_path / file
    path.write_text(damage(path.read_text()))
    with pytest.raises(InputError, match=message) as info:
        read_easymocap(tmp_path / "intri.yml", tmp_path / "extri.yml")
    assert str(info.value).startswith(str(path))
