import numpy as np
import pytest

from voxelmocap.errors import InputError
from voxelmocap.io.body_pose_xml import read_body_pose_xml, write_body_pose_xml
from voxelmocap.joints import ENDPOINT_NAMES


def test_round_trip_3d_with_attributes_flags_and_errors(tmp_path):
    rng = np.random.default_rng(0)
    pts = rng.normal(0, 400, size=(4, 20, 3))
    enabled = np.ones((4, 20), bool)
    enabled[2, 5] = False
    attrs = {"DatasetName": "HumanEvaI", "SubjectName": "S1", "ActionType": "Walking",
             "Trial": "1", "FrameStart": "6", "FrameEnd": "9", "Partition": "Validate"}
    write_body_pose_xml(tmp_path / "out", [6, 7, 8, 9], pts, enabled, attributes=attrs,
                        errors=[1.5, None, np.nan, 3.0])
    seq = read_body_pose_xml(tmp_path / "out.xml")  # .xml appended like the toolkit
    np.testing.assert_array_equal(seq.frames, [6, 7, 8, 9])
    np.testing.assert_allclose(seq.endpoints, pts, atol=1e-6)  # %f has 6 decimals
    np.testing.assert_array_equal(seq.enabled, enabled)
    assert seq.attributes == attrs
    assert seq.camera is None
    np.testing.assert_allclose(seq.errors, [1.5, -1, -1, 3.0])
    np.testing.assert_array_equal(seq.index_of([7, 100]), [1, -1])


def test_2d_file_without_z_and_camera(tmp_path):
    pts = np.arange(2 * 20 * 2, dtype=float).reshape(2, 20, 2)
    write_body_pose_xml(tmp_path / "p.xml", [1, 2], pts, camera="BW2")
    seq = read_body_pose_xml(tmp_path / "p.xml")
    assert seq.endpoints.shape == (2, 20, 2)
    assert seq.camera == "BW2"
    np.testing.assert_allclose(seq.endpoints, pts)


def _one_frame(joints_xml):
    return f"<SEQUENCE><Camera>N/A</Camera><Frame><Number>6</Number><Pose>{joints_xml}</Pose>" \
           "<Error>N/A</Error></Frame></SEQUENCE>"


def _joint(name, x="1", y="2", z="3"):
    return f"<Joint><Name>{name}</Name><Enabled>1</Enabled><X>{x}</X><Y>{y}</Y><Z>{z}</Z></Joint>"


@pytest.mark.parametrize(
    ("body", "message"),
    [
        (_one_frame("".join(_joint(n) for n in ENDPOINT_NAMES[:19])), "expected 20 joints"),
        (_one_frame("".join(_joint(n, x="abc") if i == 3 else _joint(n)
                            for i, n in enumerate(ENDPOINT_NAMES))), "not a number"),
        (_one_frame("".join(_joint(n, z="nan") if i == 0 else _joint(n)
                            for i, n in enumerate(ENDPOINT_NAMES))), "not finite"),
        (_one_frame("".join(_joint(n) for n in reversed(ENDPOINT_NAMES))), "expected 'torso"),
        ("<SEQUENCE><Frame>", "malformed XML"),
        ("<POSES/>", "expected <SEQUENCE>"),
        ('<?xml version="1.0"?><!DOCTYPE l [<!ENTITY a "aaaa"><!ENTITY b "&a;&a;">]>'
         "<SEQUENCE>&b;</SEQUENCE>", "entity"),
    ],
)
def test_bad_xml(tmp_path, body, message):
    path = tmp_path / "bad.xml"
    path.write_text(body)
    with pytest.raises(InputError, match=message) as info:
        read_body_pose_xml(path)
    assert str(info.value).startswith(str(path))


def test_missing_file(tmp_path):
    with pytest.raises(InputError, match="not found"):
        read_body_pose_xml(tmp_path / "none.xml")


_DTD_BODIES = [
    # A declaration after 8 KB of comment: a sniff of the first bytes would miss it.
    '<?xml version="1.0"?>' + "<!--" + "x" * 8192 + "-->"
    + '<!DOCTYPE l [<!ENTITY a "aaaa">]><SEQUENCE>&a;</SEQUENCE>',
    # External entity (XXE).
    '<?xml version="1.0"?><!DOCTYPE l [<!ENTITY e SYSTEM "file:///etc/passwd">]>'
    "<SEQUENCE>&e;</SEQUENCE>",
    # A DTD without entities is refused too: nothing in the format needs one.
    '<?xml version="1.0"?><!DOCTYPE SEQUENCE SYSTEM "http://example.invalid/x.dtd"><SEQUENCE/>',
]


@pytest.mark.parametrize("encoding", ["utf-8", "utf-16"])
@pytest.mark.parametrize("body", _DTD_BODIES)
def test_dtd_refused_in_any_encoding_and_position(tmp_path, body, encoding):
    path = tmp_path / "dtd.xml"
    text = body if encoding == "utf-8" else body.replace('version="1.0"?>',
                                                         'version="1.0" encoding="UTF-16"?>')
    path.write_bytes(text.encode(encoding))
    with pytest.raises(InputError, match="DTDs and entity declarations") as info:
        read_body_pose_xml(path)
    assert str(info.value).startswith(str(path))


def test_writer_escapes_attributes_and_camera(tmp_path):
    attrs = {"SubjectName": 'S1 "quoted" <&> \u00e9', "Trial": 2}
    pts = np.arange(20 * 3, dtype=float).reshape(1, 20, 3)
    write_body_pose_xml(tmp_path / "e.xml", [1], pts, attributes=attrs, camera="C<1>&")
    seq = read_body_pose_xml(tmp_path / "e.xml")
    assert seq.attributes == {"SubjectName": 'S1 "quoted" <&> \u00e9', "Trial": "2"}
    assert seq.camera == "C<1>&"
    np.testing.assert_allclose(seq.endpoints, pts, atol=1e-6)
