"""BVH reader: real clips, hand-computed forward kinematics, bad input."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from voxelmocap.errors import InputError
from voxelmocap.io.bvh import UNITS, read_bvh, write_bvh

MOCAP = Path(__file__).resolve().parents[2] / ".." / "shared" / "mocap"

# file → (frames, fps, unit) from ../shared/mocap/README.md
CLIPS = {
    "05_01.bvh": (599, 25, "cm"),
    "02_03.bvh": (174, 25, "cm"),
    "dataset-1_punch_normal_002.bvh": (284, 30, "cm"),
    "dataset-2_wave-right-hand_normal_001.bvh": (187, 30, "cm"),
    "01_01.bvh": (2752, 120, "cmu"),
}


@pytest.mark.parametrize("name", sorted(CLIPS))
def test_shared_clips_parse_with_readme_counts(name):
    path = MOCAP / name
    if not path.exists():
        pytest.skip("real motion-capture clips not available (the CMU / Bandai Namco BVH files the "
                    "project develops with, expected in ../shared/mocap beside the checkout; "
                    "not shipped)")
    frames, fps, unit = CLIPS[name]
    clip = read_bvh(path)
    assert clip.n_frames == frames
    assert clip.fps == pytest.approx(fps, rel=1e-4)
    assert clip.scale == UNITS[unit]  # the automatic unit guess picks the README's unit
    pos = clip.positions([0, frames // 2, frames - 1])
    assert pos.shape == (3, len(clip.names), 3)
    # Z up in mm: a standing human spans 1.2-2.2 m vertically in the middle frame
    height = np.ptp(pos[1, :, 2])
    assert 1200 < height < 2200


def _rz(a):
    c, s = np.cos(np.radians(a)), np.sin(np.radians(a))
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def _rx(a):
    c, s = np.cos(np.radians(a)), np.sin(np.radians(a))
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def _ry(a):
    c, s = np.cos(np.radians(a)), np.sin(np.radians(a))
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


CHAIN = """HIERARCHY
ROOT root
{{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT a
  {{
    OFFSET 0 10 0
    CHANNELS 3 {order_a}
    JOINT b
    {{
      OFFSET 5 0 0
      CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation
      End Site
      {{
        OFFSET 0 0 3
      }}
    }}
  }}
}}
MOTION
Frames: {n}
Frame Time: 0.0166667
{rows}
"""


def _write_chain(tmp_path, rows, order_a="Zrotation Xrotation Yrotation", name="chain.bvh"):
    text = CHAIN.format(order_a=order_a, n=len(rows),
                        rows="\n".join(" ".join(f"{v:.15g}" for v in r) for r in rows))
    path = tmp_path / name
    path.write_text(text)
    return path


def test_known_angles_give_hand_computed_positions(tmp_path):
    rng = np.random.default_rng(3)
    rows = []
    for _ in range(4):
        root = np.concatenate([rng.uniform(-50, 50, 3), rng.uniform(-90, 90, 3)])
        a = rng.uniform(-90, 90, 3)
        b = np.concatenate([rng.uniform(-9, 9, 3), rng.uniform(-90, 90, 3)])
        rows.append(np.concatenate([root, a, b]))
    path = _write_chain(tmp_path, rows)
    clip = read_bvh(path, unit="cm")
    assert clip.names == ["root", "a", "b", "b_End"]
    pos = clip.positions()
    M = np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]])  # Y up → Z up
    for f, r in enumerate(rows):
        R0 = _rz(r[3]) @ _rx(r[4]) @ _ry(r[5])
        Ra = _rz(r[6]) @ _rx(r[7]) @ _ry(r[8])
        Rb = _rz(r[12]) @ _ry(r[13]) @ _rx(r[14])
        p0 = r[0:3]
        pa = p0 + R0 @ [0, 10, 0]
        pb = pa + R0 @ Ra @ r[9:12]  # position channels replace b's OFFSET
        pe = pb + R0 @ Ra @ Rb @ [0, 0, 3]
        expect = np.array([p0, pa, pb, pe]) @ M.T * 10.0
        np.testing.assert_allclose(pos[f], expect, atol=1e-9)


def test_rotation_order_is_taken_from_the_file(tmp_path):
    row = [0, 0, 0, 0, 0, 0, 30, 40, 50, 5, 0, 0, 0, 0, 0]
    p1 = read_bvh(_write_chain(tmp_path, [row], "Zrotation Xrotation Yrotation", "o1.bvh"), unit=1)
    p2 = read_bvh(_write_chain(tmp_path, [row], "Xrotation Yrotation Zrotation", "o2.bvh"), unit=1)
    # Same numbers under another order: the values now mean X=30, Y=40, Z=50.
    Ra = _rx(30) @ _ry(40) @ _rz(50)
    M = np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]])
    expect = M @ (np.array([0, 10, 0]) + Ra @ [5, 0, 0] + Ra @ [0, 0, 3])
    np.testing.assert_allclose(p2.positions()[0, 3], expect, atol=1e-9)
    assert not np.allclose(p1.positions()[0, 3], p2.positions()[0, 3])


def test_write_then_read_round_trip(tmp_path):
    rng = np.random.default_rng(0)
    rows = [rng.uniform(-40, 40, 15) for _ in range(3)]
    clip = read_bvh(_write_chain(tmp_path, rows), unit="cm")
    out = tmp_path / "again.bvh"
    write_bvh(out, clip)
    back = read_bvh(out, unit="cm")
    assert back.names == clip.names and back.channels == clip.channels
    np.testing.assert_allclose(back.positions(), clip.positions(), atol=1e-4)


@pytest.mark.parametrize("mutate, message", [
    (lambda t: t.replace("0 0 0 0 0 0 1 2 3", "0 0 0 0 0 0 1 2"), "values, the hierarchy declares"),
    (lambda t: t.replace("0 0 0 0 0 0 1 2 3", "0 0 0 0 0 0 1 x 3"), "is not a number"),
    (lambda t: t.replace("Frames: 1", "Frames: 2"), "declared but 1 motion rows"),
    (lambda t: t.replace("Zrotation Xrotation Yrotation\n", "Zrotation Xrot Yrotation\n"),
     "unknown channel"),
    (lambda t: t.replace("MOTION", "MOTON"), "no MOTION section"),
    (lambda t: t.replace("OFFSET 5 0 0", "OFFSET 5 zero 0"), "expected a number"),
    (lambda t: t.replace("Frame Time: 0.0166667", "Frame Time: 0"), "frame time"),
    (lambda t: t.replace("  }\n}\nMOTION", "  }\nMOTION"), "unbalanced"),
])
def test_malformed_bvh_is_an_input_error(tmp_path, mutate, message):
    good = _write_chain(tmp_path, [[0, 0, 0, 0, 0, 0, 1, 2, 3, 5, 0, 0, 0, 0, 0]])
    text = good.read_text()
    bad = tmp_path / "bad.bvh"
    bad.write_text(mutate(text))
    assert bad.read_text() != text
    with pytest.raises(InputError, match=message) as info:
        read_bvh(bad)
    assert str(bad) in str(info.value)


def test_missing_file_and_bad_unit(tmp_path):
    with pytest.raises(InputError, match="not found"):
        read_bvh(tmp_path / "nope.bvh")
    good = _write_chain(tmp_path, [[0] * 15])
    with pytest.raises(InputError, match="unknown unit"):
        read_bvh(good, unit="furlong")
    with pytest.raises(InputError, match="positive"):
        read_bvh(good, unit=-1.0)
