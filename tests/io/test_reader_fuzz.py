"""Every reader answers arbitrary bytes and mutated valid files with a parse or one InputError.

For each reader, hypothesis feeds (a) arbitrary bytes and (b) valid files with random byte
flips, insertions, deletions and truncations. The reader must either return or raise
:class:`~voxelmocap.errors.InputError` whose message starts with the file's path and is one line;
any other exception escaping is a bug (it would reach the user as a traceback).
"""

from __future__ import annotations

import numpy as np
import pytest
from fuzzing import is_one_line_about, mutated, refusal
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from voxelmocap.errors import InputError
from voxelmocap.io.asf import read_asf_amc
from voxelmocap.io.body_pose_xml import read_body_pose_xml, write_body_pose_xml
from voxelmocap.io.bvh import read_bvh

BVH = b"""HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT Spine
  {
    OFFSET 0 10 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    End Site
    {
      OFFSET 0 10 0
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.0333333
0 90 0 0 0 0 10 0 0
1 90 0 5 0 0 12 0 0
"""

ASF = b""":version 1.10
:name t
:units
  mass 1.0
  length 0.45
  angle deg
:root
   order TX TY TZ RX RY RZ
   axis XYZ
   position 0 0 0
   orientation 0 0 0
:bonedata
  begin
     id 1
     name a
     direction 0 1 0
     length 4
     axis 0 0 0  XYZ
    dof rx ry rz
  end
:hierarchy
  begin
    root a
  end
"""

AMC = b""":FULLY-SPECIFIED
:DEGREES
1
root 0 20 0 0 0 0
a 10 0 0
2
root 1 20 0 0 5 0
a 12 0 0
"""


def _xml_seed(tmp_path_factory) -> bytes:
    path = tmp_path_factory.mktemp("seed") / "seed.xml"
    pts = np.random.default_rng(0).normal(size=(2, 20, 3)) * 100
    write_body_pose_xml(path, [1, 2], pts, attributes={"SubjectName": "S1"})
    return path.read_bytes()






FUZZ = settings(max_examples=120, deadline=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture])


@FUZZ
@given(data=st.data())
def test_body_pose_xml(tmp_path_factory, data):
    seed = _xml_seed(tmp_path_factory)
    raw = data.draw(st.one_of(st.binary(max_size=300), mutated(seed)))
    path = tmp_path_factory.mktemp("xml") / "x.xml"
    path.write_bytes(raw)
    message = refusal(lambda: read_body_pose_xml(path))
    assert is_one_line_about(message, path), message


@FUZZ
@given(raw=st.one_of(st.binary(max_size=300), mutated(BVH)))
def test_bvh(tmp_path_factory, raw):
    path = tmp_path_factory.mktemp("bvh") / "x.bvh"
    path.write_bytes(raw)
    message = refusal(lambda: read_bvh(path))
    assert is_one_line_about(message, path), message


@FUZZ
@given(asf=st.one_of(st.just(ASF), st.binary(max_size=200), mutated(ASF)),
       amc=st.one_of(st.just(AMC), st.binary(max_size=200), mutated(AMC)))
def test_asf_amc(tmp_path_factory, asf, amc):
    if asf == ASF and amc == AMC:
        return
    folder = tmp_path_factory.mktemp("asf")
    (folder / "x.asf").write_bytes(asf)
    (folder / "x.amc").write_bytes(amc)
    try:
        read_asf_amc(folder / "x.asf", folder / "x.amc")
    except InputError as exc:
        message = str(exc)
        assert message.startswith((str(folder / "x.asf"), str(folder / "x.amc"))), message
        assert "\n" not in message


@pytest.mark.parametrize(("reader", "seed"), [("bvh", BVH), ("asf", None)])
def test_seeds_are_valid(tmp_path, reader, seed):
    # The mutations start from files that parse: otherwise the fuzzing would test nothing.
    if reader == "bvh":
        (tmp_path / "x.bvh").write_bytes(BVH)
        assert read_bvh(tmp_path / "x.bvh").n_frames == 2
    else:
        (tmp_path / "x.asf").write_bytes(ASF)
        (tmp_path / "x.amc").write_bytes(AMC)
        assert read_asf_amc(tmp_path / "x.asf", tmp_path / "x.amc").n_frames == 2


@settings(max_examples=60, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_result_hdf5(tmp_path_factory, data):
    # A valid streamed result file, then arbitrary bytes or byte-level damage to it: HDF5's own
    # checks, h5py's and the reader's must together turn every damage into one InputError.
    from test_results import make_result

    from voxelmocap.io.results import read_result, write_result

    folder = tmp_path_factory.mktemp("h5")
    seed_path = folder / "seed.h5"
    write_result(seed_path, make_result())
    raw = data.draw(st.one_of(st.binary(max_size=400), mutated(seed_path.read_bytes())))
    path = folder / "x.h5"
    path.write_bytes(raw)
    message = refusal(lambda: read_result(path))
    assert is_one_line_about(message, path), message


def _calibration_seeds(folder):
    """Valid ``.cal``, ``sizes.toml``, anipose/Pose2Sim TOML and ``.ofs`` files, as bytes."""
    from humaneva_fixture import RIG_DIR

    from voxelmocap.io.calibration import read_rig, write_calibration_toml, write_rig
    from voxelmocap.io.humaneva import write_ofs

    rig = read_rig(RIG_DIR, names=["C1", "BW1"])
    write_rig(rig, folder / "rig")
    write_calibration_toml(rig, folder / "calib.toml")
    write_ofs(folder / "x.ofs", 6, 1, 2.0)
    return {"cal": (folder / "rig" / "C1.cal").read_bytes(),
            "sizes": (folder / "rig" / "sizes.toml").read_bytes(),
            "toml": (folder / "calib.toml").read_bytes(),
            "ofs": (folder / "x.ofs").read_bytes()}


@FUZZ
@given(data=st.data(), kind=st.sampled_from(["cal", "sizes", "toml", "ofs"]))
def test_calibration_and_sync_files(tmp_path_factory, data, kind):
    from voxelmocap.io.calibration import read_cal, read_calibration_toml, read_sizes
    from voxelmocap.io.humaneva import read_ofs

    folder = tmp_path_factory.mktemp("calib")
    seeds = _calibration_seeds(folder)
    raw = data.draw(st.one_of(st.binary(max_size=300), mutated(seeds[kind])))
    path = folder / {"cal": "x.cal", "sizes": "sizes.toml", "toml": "c.toml", "ofs": "y.ofs"}[kind]
    path.write_bytes(raw)
    reader = {"cal": read_cal, "sizes": read_sizes, "toml": read_calibration_toml,
              "ofs": read_ofs}[kind]
    message = refusal(lambda: reader(path))
    assert is_one_line_about(message, path), message


def test_calibration_seeds_are_valid(tmp_path):
    from voxelmocap.io.calibration import read_cal, read_calibration_toml, read_sizes
    from voxelmocap.io.humaneva import read_ofs

    seeds = _calibration_seeds(tmp_path)
    for kind, name, reader in (("cal", "a.cal", read_cal), ("sizes", "sizes.toml", read_sizes),
                               ("toml", "b.toml", read_calibration_toml), ("ofs", "c.ofs", read_ofs)):
        (tmp_path / name).write_bytes(seeds[kind])
        assert reader(tmp_path / name) is not None
