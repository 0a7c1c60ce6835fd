"""ASF/AMC: the BVH-like rewrite agrees with the Acclaim forward kinematics written out directly."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from voxelmocap.errors import InputError
from voxelmocap.io.asf import read_asf_amc

MOCAP = Path(__file__).resolve().parents[2] / ".." / "shared" / "mocap"

ASF = """:version 1.10
:name test
:units
  mass 1.0
  length 0.5
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
     direction 0.6 -0.8 0
     length 4
     axis 10 20 30  XYZ
    dof rx ry rz
  end
  begin
     id 2
     name b
     direction 0 -1 0
     length 5
     axis -40 15 5  XYZ
    dof rx rz
  end
  begin
     id 3
     name c
     direction 0 1 0
     length 3
     axis 0 0 0  XYZ
  end
:hierarchy
  begin
    root a c
    a b
  end
"""


def _xyz(deg):
    return Rotation.from_euler("xyz", deg, degrees=True).as_matrix()  # Rz·Ry·Rx


def test_rewrite_matches_direct_acclaim_kinematics(tmp_path):
    rng = np.random.default_rng(4)
    frames = []
    lines = [":FULLY-SPECIFIED", ":DEGREES"]
    for f in range(3):
        root = np.concatenate([rng.uniform(-5, 5, 3), rng.uniform(-60, 60, 3)])
        a = rng.uniform(-60, 60, 3)
        b = rng.uniform(-60, 60, 2)
        frames.append((root, a, b))
        lines += [str(f + 1), "root " + " ".join(f"{v:.12g}" for v in root),
                  "a " + " ".join(f"{v:.12g}" for v in a), "b " + " ".join(f"{v:.12g}" for v in b)]
    (tmp_path / "t.asf").write_text(ASF)
    (tmp_path / "t_01.amc").write_text("\n".join(lines) + "\n")
    clip = read_asf_amc(tmp_path / "t.asf", tmp_path / "t_01.amc", fps=100)
    assert clip.scale == pytest.approx(25.4 / 0.5) and clip.n_frames == 3 and clip.fps == 100
    pos = clip.positions()
    M = np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]])
    Ca, Cb = _xyz([10, 20, 30]), _xyz([-40, 15, 5])
    for k, (root, a, b) in enumerate(frames):
        # Acclaim: W_b = W_parent · C_b · M_b · C_b⁻¹; tip_b = tip_parent + L_b · W_b · d_b
        W_root = _xyz(root[3:])
        Wa = W_root @ Ca @ _xyz(a) @ Ca.T
        Wb = Wa @ Cb @ _xyz([b[0], 0, b[1]]) @ Cb.T
        Wc = W_root  # no dof, axis 0
        p_root = root[:3]
        tip_a = p_root + 4 * Wa @ [0.6, -0.8, 0]
        tip_b = tip_a + 5 * Wb @ [0, -1, 0]
        tip_c = p_root + 3 * Wc @ [0, 1, 0]
        expect = {"root": p_root, "a": p_root, "b": tip_a, "b_End": tip_b, "c": p_root,
                  "c_End": tip_c}
        for name, p in expect.items():
            np.testing.assert_allclose(pos[k, clip.index(name)], M @ p * 50.8, atol=1e-8)


def test_shared_cmu_clip():
    asf, amc = MOCAP / "11.asf", MOCAP / "11_01.amc"
    if not asf.exists():
        pytest.skip("real motion-capture clips not available (the CMU / Bandai Namco BVH files the "
                    "project develops with, expected in ../shared/mocap beside the checkout; "
                    "not shipped)")
    clip = read_asf_amc(asf, amc)
    assert clip.n_frames == 597 and clip.fps == 120
    assert clip.scale == pytest.approx(56.444, abs=0.01)
    pos = clip.positions([0, 300])
    hip, knee, ankle = (pos[:, clip.index(n)] for n in ("lfemur", "ltibia", "lfoot"))
    # thigh = lfemur length 7.33161 units; upright subject, feet near the floor
    np.testing.assert_allclose(np.linalg.norm(knee - hip, axis=1), 7.33161 * 25.4 / 0.45, rtol=1e-6)
    assert np.all(pos[:, clip.index("head"), 2] > hip[:, 2] + 400)
    assert np.all(ankle[:, 2] < 200)


def test_bad_amc(tmp_path):
    (tmp_path / "t.asf").write_text(ASF)
    (tmp_path / "bad.amc").write_text("1\nroot 0 0 0 0 0 0\na 1 2\n")
    with pytest.raises(InputError, match="a has 2 values, the ASF declares 3 dof"):
        read_asf_amc(tmp_path / "t.asf", tmp_path / "bad.amc")
    (tmp_path / "bad2.amc").write_text("1\nroot 0 0 0 0 0 0\nzz 1\n")
    with pytest.raises(InputError, match="unknown bone"):
        read_asf_amc(tmp_path / "t.asf", tmp_path / "bad2.amc")
