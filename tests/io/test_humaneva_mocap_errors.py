"""Bad raw mocap input: one InputError line naming the file; exit 2 without traceback on the CLI.

Also fuzzes the ``.mat`` and ``.mp`` readers: arbitrary bytes and mutated valid files either parse
or raise :class:`~voxelmocap.errors.InputError`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from fuzzing import is_one_line_about, mutated, refusal
from humaneva_fixture import make_tiny_dataset
from humaneva_mocap_fixture import (
    LABELS,
    parameter_groups,
    standing_markers,
    write_mocap_mat,
    write_mp,
    write_subject_mocap,
)
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from voxelmocap.cli import main
from voxelmocap.errors import InputError
from voxelmocap.io.body_pose_xml import write_body_pose_xml
from voxelmocap.io.humaneva_mocap import MocapStream, marker_index, read_mocap_mat, read_mp


def _renamed(old: str, new: str) -> list[str]:
    return [new if label == old else label for label in LABELS]


def _break(kind: str, mocap: Path) -> tuple[Path, str]:
    """Break one file of a valid ``Mocap_Data``; returns (the file at fault, expected text)."""
    trial, static, mp = mocap / "Walking_1.mat", mocap / "Static.mat", mocap / "S1.mp"
    markers = standing_markers(6)
    if kind == "no Markers":
        write_mocap_mat(trial, None)
        return trial, "no 'Markers'"
    if kind == "Markers not N×M×3":
        write_mocap_mat(trial, markers[:, :, :2])
        return trial, "N×M×3"
    if kind == "no ParameterGroup":
        write_mocap_mat(trial, markers, groups=False)
        return trial, "no 'ParameterGroup'"
    if kind == "no POINT group":
        write_mocap_mat(trial, markers, groups=parameter_groups(LABELS, point_name="VIDEO"))
        return trial, "no POINT group"
    if kind == "no LABELS parameter":
        write_mocap_mat(trial, markers, groups=parameter_groups(LABELS, labels_name="NAMES"))
        return trial, "no LABELS parameter"
    if kind == "missing segment marker":
        write_mocap_mat(trial, markers, _renamed("LHUO", "XHUX"))
        return trial, "'LHUO'"
    if kind == "ambiguous segment marker":
        write_mocap_mat(trial, markers, _renamed("LHNO", "LHUO"))
        return trial, "2 marker labels"
    if kind == "labels past the markers":
        write_mocap_mat(trial, markers[:, :100])
        return trial, "holds 100"
    if kind == "missing physical marker":
        write_mocap_mat(trial, markers, _renamed("RPSI", "XXXX"))
        return trial, "RPSI"
    if kind == "not a MAT file":
        trial.write_bytes(b"MATLAB 5.0 MAT-file, but not really\n" * 5)
        return trial, "cannot read the MAT file"
    if kind == "mp missing key":
        write_mp(mp, drop=("LElbowWidth",))
        return mp, "$LElbowWidth"
    if kind == "mp bad line":
        mp.write_text("$LKneeWidth = 104\nRKneeWidth 102\n")
        return mp, "line 2"
    if kind == "mp not a number":
        mp.write_text("$LKneeWidth = wide\n")
        return mp, "'wide' is not a number"
    if kind == "mp missing":
        mp.unlink()
        return mp, "not found"
    if kind == "static without LSHO":
        write_mocap_mat(static, standing_markers(3), _renamed("LSHO", "XSHX"))
        return static, "'LSHO'"
    if kind == "static with too few markers":
        write_mocap_mat(static, standing_markers(3)[:, :9])
        return static, "holds 9"
    if kind == "static missing":
        static.unlink()
        return static, "static trial not found"
    raise AssertionError(kind)


KINDS = ["no Markers", "Markers not N×M×3", "no ParameterGroup", "no POINT group",
         "no LABELS parameter", "missing segment marker", "ambiguous segment marker",
         "labels past the markers", "missing physical marker", "not a MAT file", "mp missing key",
         "mp bad line", "mp not a number", "mp missing", "static without LSHO",
         "static with too few markers", "static missing"]


@pytest.fixture(scope="module")
def tree(tmp_path_factory) -> Path:
    root = make_tiny_dataset(tmp_path_factory.mktemp("tree") / "data", cameras=("C1",),
                             leads=(0,), n_frames=3, with_gt=False, backgrounds=False)
    write_subject_mocap(root / "S1", "S1", "Walking_1", standing_markers(6))
    return root


@pytest.fixture
def broken(tree, tmp_path, request):
    import shutil

    root = tmp_path / "data"
    shutil.copytree(tree, root)
    path, text = _break(request.param, root / "S1" / "Mocap_Data")
    return root, path, text


@pytest.mark.parametrize("broken", KINDS, indirect=True)
def test_bad_raw_mocap_is_one_input_error_naming_the_file(broken):
    root, path, text = broken
    mocap = root / "S1" / "Mocap_Data"
    with pytest.raises(InputError) as info:
        MocapStream.open(mocap / "Walking_1.mat", mocap / "Static.mat", mocap / "S1.mp")
    message = str(info.value)
    assert message.startswith(str(path)), message
    assert text in message and "\n" not in message, message


@pytest.mark.parametrize("broken", KINDS, indirect=True)
def test_bad_raw_mocap_exits_2_in_groundtruth_and_evaluate(broken, tmp_path, capsys):
    root, path, text = broken
    code = main(["groundtruth", str(root), "--subject", "S1", "--sequence", "Walking_1",
                 "--out", str(tmp_path / "gt.xml")])
    captured = capsys.readouterr()
    assert code == 2
    assert "Traceback" not in captured.err and len(captured.err.splitlines()) == 1
    assert captured.err.startswith(f"voxelmocap groundtruth: error: {path}"), captured.err
    assert text in captured.err
    assert not (tmp_path / "gt.xml").exists()

    write_body_pose_xml(tmp_path / "run" / "S1" / "Walking_1.xml", [1], np.zeros((1, 20, 3)))
    assert main(["evaluate", str(tmp_path / "run"), "--dataset", str(root)]) == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1 and text in err, err


def test_groundtruth_without_raw_mocap_exits_2(tmp_path, capsys):
    root = make_tiny_dataset(tmp_path / "data", cameras=("C1",), leads=(0,), n_frames=3,
                             with_gt=False, backgrounds=False)
    assert main(["groundtruth", str(root), "--subject", "S1", "--sequence", "Walking_1",
                 "--out", str(tmp_path / "gt.xml")]) == 2
    assert "no raw mocap for Walking_1" in capsys.readouterr().err


# ---------------------------------------------------------------------- fuzzing


def _seed(compress: bool) -> bytes:
    import tempfile

    with tempfile.TemporaryDirectory() as folder:
        path = write_mocap_mat(Path(folder) / "seed.mat", standing_markers(2), compress=compress)
        return path.read_bytes()


MAT_SEEDS = [_seed(False), _seed(True)]
MP_SEED = "".join(f"${k} = {v}\n" for k, v in
                  {"Bodymass": 71.8, "LKneeWidth": 104, "HeadOffset": 12.5}.items()).encode()
FUZZ = settings(max_examples=120, deadline=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture,
                                       HealthCheck.too_slow, HealthCheck.data_too_large])




def test_seeds_are_valid(tmp_path):
    for i, seed in enumerate(MAT_SEEDS):
        (tmp_path / f"{i}.mat").write_bytes(seed)
        trial = read_mocap_mat(tmp_path / f"{i}.mat")
        assert trial.markers.shape == (2, len(LABELS), 3)
        marker_index(trial)
    (tmp_path / "x.mp").write_bytes(MP_SEED)
    assert read_mp(tmp_path / "x.mp").value("HeadOffset") == 12.5


@FUZZ
@given(raw=st.one_of(st.binary(max_size=400), mutated(MAT_SEEDS[0]), mutated(MAT_SEEDS[1])))
def test_mat_reader_parses_or_raises_input_error(tmp_path_factory, raw):
    path = tmp_path_factory.mktemp("mat") / "x.mat"
    path.write_bytes(raw)

    def call():
        marker_index(read_mocap_mat(path))

    message = refusal(call)

    assert is_one_line_about(message, path), message


@FUZZ
@given(raw=st.one_of(st.binary(max_size=300), mutated(MP_SEED)))
def test_mp_reader_parses_or_raises_input_error(tmp_path_factory, raw):
    path = tmp_path_factory.mktemp("mp") / "x.mp"
    path.write_bytes(raw)

    def call():
        mp = read_mp(path)
        for key in ("LKneeWidth", "HeadOffset", "Bodymass"):
            mp.value(key)

    message = refusal(call)

    assert is_one_line_about(message, path), message
