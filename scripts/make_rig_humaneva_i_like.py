"""Regenerate ``calib/humaneva_i_like/``: a 7-camera rig named and placed like HumanEva-I.

C1–C3 extrinsics are HumanEva-I subject S1's, as published by VideoPose3D
(``common/humaneva_dataset.py``: camera→world quaternion (w, x, y, z) and camera centre in mm;
quoted in ``../shared/HUMANEVA.md`` §2.3). Everything else (intrinsics, distortion, BW1–BW4 poses)
is invented but plausible. Run: ``python scripts/make_rig_humaneva_i_like.py``.

Not a benchmark: the rig every rendered-clip benchmark uses; the package ships a copy in
``voxelmocap/data/rigs/humaneva_i_like/``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from voxelmocap.camera import Camera, Rig
from voxelmocap.io.calibration import write_rig

OUT = Path(__file__).resolve().parents[1] / "calib" / "humaneva_i_like"
SIZE = (640, 480)
# BW cameras aim a little below pelvis height (mm) so that the floor corners stay in view.
TARGET = np.array([0.0, 0.0, 750.0])

# VideoPose3D, HumanEva-I S1: orientation (w, x, y, z) camera→world; centre (mm).
S1_EXTRINSICS = {
    "C1": ((0.424207, -0.4983646, -0.5802981, 0.4847012), (4062.227, 663.2477, 1528.397)),
    "C2": ((0.6503354, -0.7481602, -0.0919284, 0.0941766), (844.8131, -3805.2092, 1504.9929)),
    "C3": ((0.0664734, -0.0690535, 0.7416416, -0.6639132), (-797.67377, 3916.3174, 1433.6602)),
}

# Invented intrinsics: (fx, fy, cx, cy, skew, k1, k2, p1, p2, k3).
INTRINSICS = {
    "C1": (555.0, 557.0, 321.5, 243.2, 0.0, -0.112, 0.081, 4.0e-4, -3.0e-4, -0.012),
    "C2": (548.0, 549.5, 318.4, 239.1, 0.0, -0.105, 0.072, -2.5e-4, 5.0e-4, -0.010),
    "C3": (561.0, 562.0, 322.7, 236.8, 0.0, -0.118, 0.090, 3.0e-4, 2.0e-4, -0.015),
    "BW1": (505.0, 505.0, 319.0, 241.0, 0.0, -0.095, 0.060, 1.0e-4, -1.0e-4, -0.008),
    "BW2": (498.0, 499.0, 320.5, 238.5, 0.0, -0.092, 0.055, -2.0e-4, 1.5e-4, -0.007),
    "BW3": (512.0, 512.5, 317.8, 242.6, 0.0, -0.099, 0.064, 2.0e-4, 2.0e-4, -0.009),
    "BW4": (520.0, 519.0, 321.2, 240.3, 0.0, -0.101, 0.066, -1.0e-4, -2.0e-4, -0.009),
}

# Invented BW placements: (azimuth deg, horizontal distance mm, height mm).
BW_PLACEMENT = {
    "BW1": (45.0, 4100.0, 2300.0),
    "BW2": (135.0, 4300.0, 1900.0),
    "BW3": (225.0, 4000.0, 2450.0),
    "BW4": (315.0, 4600.0, 1650.0),
}


def quaternion_to_matrix(q):
    """Rotation matrix of a unit quaternion (w, x, y, z)."""
    w, x, y, z = np.asarray(q, dtype=float) / np.linalg.norm(q)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def look_at(centre, target):
    """World→camera R, T for a camera at ``centre`` looking at ``target``, image y pointing down."""
    z = target - centre
    z /= np.linalg.norm(z)
    down = np.array([0.0, 0.0, -1.0])
    x = np.cross(down, z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    R = np.stack([x, y, z])
    return R, -R @ centre


def build_rig() -> Rig:
    cameras = []
    for name, intr in INTRINSICS.items():
        fx, fy, cx, cy, skew, *kc = intr
        if name in S1_EXTRINSICS:
            q, centre = S1_EXTRINSICS[name]
            R = quaternion_to_matrix(q).T  # camera→world transposed = world→camera
            T = -R @ np.asarray(centre)
        else:
            az, dist, height = BW_PLACEMENT[name]
            a = np.deg2rad(az)
            centre = np.array([dist * np.cos(a), dist * np.sin(a), height])
            R, T = look_at(centre, TARGET)
        cameras.append(Camera(name, fc=(fx, fy), cc=(cx, cy), alpha_c=skew, kc=kc, R=R, T=T,
                              size=SIZE))
    return Rig(cameras)


if __name__ == "__main__":
    rig = build_rig()
    write_rig(rig, OUT)
    for cam in rig:
        top, foot = cam.project(np.array([[0, 0, 1800.0], [0, 0, 0.0]]))
        print(f"{cam.name:4s} centre {np.round(cam.center).astype(int)}  "
              f"1.8 m person at origin: {np.linalg.norm(top - foot):.0f} px tall, "
              f"feet at ({foot[0]:.0f}, {foot[1]:.0f})")
