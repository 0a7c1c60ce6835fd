"""``io.calibration_files``: which file of a folder is its calibration, and reading any of them
into a rig in millimetres.

The rigs read back are checked by projecting points with OpenCV from the source cameras'
parameters; the TOML unit rule on rigs whose camera spacing is known in closed form.
"""

import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from voxelmocap.errors import InputError
from voxelmocap.io.calibration import read_rig, write_calibration_toml
from voxelmocap.io.calibration_files import (
    METRE_SPACING,
    calibration_format,
    find_calibration,
    read_calibration_file,
)
from voxelmocap.io.easymocap import write_easymocap
from voxelmocap.io.qualisys import read_qca

if sys.version_info >= (3, 11):
    import tomllib
else:  # the package's own dependency there
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[2]
RIG = read_rig(ROOT / "calib" / "humaneva_i_like", names=["C1", "C2", "C3"])
DEMO_QCA = ROOT / "tests" / "data" / "pose2sim_demo_Calib.qca.txt"


def _points(n=200, seed=0):
    return np.random.default_rng(seed).uniform([-1500, -1500, 0], [1500, 1500, 1900], (n, 3))


def _projects_as_the_source(rig, source=RIG, atol=1e-6):
    """Every camera of ``rig`` projects like ``source``'s, as OpenCV projects with the source's
    own parameters (in mm)."""
    assert rig.names == source.names
    pts = _points()
    for cam in source:
        K, dist, rvec, tvec = cam.to_opencv()
        expected, _ = cv2.projectPoints(pts, rvec, tvec, K, dist)
        np.testing.assert_allclose(rig[cam.name].project(pts), expected.reshape(-1, 2), atol=atol)
        assert tuple(rig[cam.name].size) == tuple(cam.size)


@pytest.mark.parametrize("name, fmt", [
    ("Calib.qca.txt", "qualisys"), ("calib.QCA", "qualisys"), ("calibration.toml", "toml"),
    ("Calib_board.TOML", "toml"), ("config.toml", None), ("Config_Demo.toml", None),
    ("intri.yml", "easymocap"), ("EXTRI.yaml", "easymocap"), ("intri.json", None),
    ("calib.xml", None), ("camera.cal", None),
])
def test_the_format_is_the_files_name(name, fmt):
    assert calibration_format(Path("some/folder") / name) == fmt


def _touch(folder, *names):
    folder.mkdir(parents=True, exist_ok=True)
    for name in names:
        (folder / name).write_text("")
    return folder


def test_the_calibration_of_a_folder(tmp_path):
    """A TOML wins over the .qca.txt it was converted from; the project's config.toml and hidden
    files are not calibrations; EasyMocap's pair is named by its intri.yml."""
    both = _touch(tmp_path / "a", "Calib.qca.txt", "Calib_qualisys.toml", "config.toml",
                  ".hidden.toml")
    assert find_calibration(both) == both / "Calib_qualisys.toml"
    assert find_calibration(_touch(tmp_path / "b", "Calib.qca.txt", "config.toml")) == \
        tmp_path / "b" / "Calib.qca.txt"
    assert find_calibration(_touch(tmp_path / "c", "extri.yml", "intri.yml")) == \
        tmp_path / "c" / "intri.yml"


def test_no_calibration_or_several_are_refused_naming_the_folder(tmp_path):
    several = _touch(tmp_path / "a", "one.toml", "two.toml", "Calib.qca.txt")
    with pytest.raises(InputError) as info:
        find_calibration(several)
    assert str(info.value) == (f"{several}: several calibration files (one.toml, two.toml): "
                               "choose one with --calibration")
    names = [f"f{i}.json" for i in range(10)] + ["config.toml"]
    none = _touch(tmp_path / "b", *names)
    with pytest.raises(InputError) as info:
        find_calibration(none)
    assert info.value.problem.startswith("no calibration file (a Pose2Sim/anipose .toml, a "
                                         "Qualisys .qca.txt or EasyMocap intri.yml + extri.yml)")
    # the first 8 names in order, so that a wrong folder is recognised
    assert info.value.problem.endswith("(it holds config.toml, f0.json, f1.json, f2.json, "
                                       "f3.json, f4.json, f5.json, f6.json)")
    with pytest.raises(InputError, match=r"\(it holds nothing\)"):
        find_calibration(_touch(tmp_path / "c"))


def test_a_pose2sim_toml_in_metres_and_an_anipose_toml_in_mm(tmp_path):
    metres, mm = tmp_path / "Calib_m.toml", tmp_path / "Calib_mm.toml"
    write_calibration_toml(RIG, metres, translation_scale=1000.0)
    write_calibration_toml(RIG, mm)
    first = tomllib.loads(metres.read_text())["cam_0"]["translation"]
    np.testing.assert_allclose(first, RIG["C1"].to_opencv()[3] / 1000.0)    # metres indeed
    for path, unit in ((metres, "metres"), (mm, "mm")):
        notes = []
        rig, unsized = read_calibration_file(path, notes=notes)
        _projects_as_the_source(rig)
        assert unsized == set()
        assert len(notes) == 1 and notes[0].startswith(f"{path.name}: translations taken as {unit}")
    # a unit stated is taken as stated, and says nothing
    notes = []
    _projects_as_the_source(read_calibration_file(metres, units="m", notes=notes)[0])
    _projects_as_the_source(read_calibration_file(mm, units="mm", notes=notes)[0])
    assert notes == []
    wrong = read_calibration_file(metres, units="mm")[0]
    np.testing.assert_allclose(wrong["C2"].center, RIG["C2"].center / 1000.0, rtol=1e-9)
    with pytest.raises(ValueError, match="units must be"):
        read_calibration_file(mm, units="cm")


@pytest.mark.parametrize("spacing, unit", [(METRE_SPACING - 1.0, "metres"),
                                           (METRE_SPACING + 1.0, "mm")])
def test_metres_are_told_from_mm_by_the_cameras_spacing(tmp_path, spacing, unit):
    """Two cameras looking along Z (no rotation) at ±spacing on X: each ``spacing`` from their
    centroid, on the metres side of the rule below METRE_SPACING."""
    cams = "".join(f"""
[cam_{i}]
name = "K{i}"
size = [640, 480]
matrix = [[500.0, 0.0, 320.0], [0.0, 500.0, 240.0], [0.0, 0.0, 1.0]]
distortions = [0.0, 0.0, 0.0, 0.0]
rotation = [0.0, 0.0, 0.0]
translation = [{sign * spacing!r}, 0.0, 0.0]
""" for i, sign in enumerate((1.0, -1.0)))
    path = tmp_path / "calib.toml"
    path.write_text(cams)
    notes = []
    rig, _ = read_calibration_file(path, notes=notes)
    scale = 1000.0 if unit == "metres" else 1.0
    np.testing.assert_allclose(rig["K0"].center, [-spacing * scale, 0.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(rig["K1"].center, [spacing * scale, 0.0, 0.0], atol=1e-9)
    assert notes == [f"calib.toml: translations taken as {unit} (cameras {spacing:.3g} units "
                     "from their centroid, on median)"]


def test_qualisys_and_easymocap_files_are_read_by_their_readers(tmp_path):
    notes = []
    rig, unsized = read_calibration_file(DEMO_QCA, notes=notes)
    direct = read_qca(DEMO_QCA)
    assert unsized == set() and rig.names == direct.names
    for a, b in zip(rig, direct, strict=True):
        for x, y in zip(a.to_opencv(), b.to_opencv(), strict=True):
            np.testing.assert_array_equal(x, y)
    binned = read_calibration_file(DEMO_QCA, binning_factor=2.0)[0]
    assert [tuple(c.size) for c in binned] == [tuple(int(v) // 2 for v in c.size) for c in rig]

    intri, extri = write_easymocap(RIG, tmp_path / "em")
    for path in (intri, extri):                    # either file names the pair
        rig, unsized = read_calibration_file(path)
        _projects_as_the_source(rig)
        assert unsized == set()
    write_easymocap(RIG, tmp_path / "unsized", sizes=False)
    assert read_calibration_file(tmp_path / "unsized" / "intri.yml")[1] == {"C1", "C2", "C3"}
    intri.unlink()
    with pytest.raises(InputError) as info:
        read_calibration_file(extri)
    assert str(info.value) == (f"{tmp_path / 'em' / 'intri.yml'}: EasyMocap intri.yml not found "
                               "(intri.yml and extri.yml go together)")


def test_a_missing_file_or_an_unknown_format_names_the_file(tmp_path):
    with pytest.raises(InputError) as info:
        read_calibration_file(tmp_path / "Calib.toml")
    assert str(info.value) == f"{tmp_path / 'Calib.toml'}: calibration file not found"
    other = tmp_path / "calib.json"
    other.write_text("{}")
    with pytest.raises(InputError) as info:
        read_calibration_file(other)
    assert str(info.value) == (f"{other}: unknown calibration format (expected a Pose2Sim/anipose "
                               ".toml, a Qualisys .qca.txt or EasyMocap intri.yml + extri.yml)")
