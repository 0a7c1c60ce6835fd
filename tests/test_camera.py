import cv2
import numpy as np

from voxelmocap.camera import Camera
from voxelmocap.io.calibration import read_rig

RIG_DIR = __import__("pathlib").Path(__file__).resolve().parents[1] / "calib" / "humaneva_i_like"


def random_rotation(rng):
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q *= np.sign(np.diag(r))
    if np.linalg.det(q) < 0:
        q[:, 0] *= -1
    return q


def skewed_camera(rng, alpha=0.013):
    return Camera("X", fc=(812.3, 790.1), cc=(322.4, 236.9), alpha_c=alpha,
                  kc=(-0.21, 0.093, 1.3e-3, -8.0e-4, -0.027), R=random_rotation(rng),
                  T=(120.0, -80.0, 4200.0))


def project_by_hand(X, fc, cc, alpha, kc, R, T):
    """HUMANEVA.md §2.2 written out point by point, independently of the package."""
    out = []
    for p in X:
        x, y, z = R @ p + T
        a, b = x / z, y / z
        r2 = a * a + b * b
        d = 1 + kc[0] * r2 + kc[1] * r2**2 + kc[4] * r2**3
        xd = a * d + 2 * kc[2] * a * b + kc[3] * (r2 + 2 * a * a)
        yd = b * d + kc[2] * (r2 + 2 * b * b) + 2 * kc[3] * a * b
        out.append((fc[0] * (xd + alpha * yd) + cc[0], fc[1] * yd + cc[1]))
    return np.array(out)


def points_in_front(rng, cam, n=200):
    # points within ±0.6 rad of the optical axis, 2–6 m away
    dirs = np.column_stack([rng.uniform(-0.5, 0.5, n), rng.uniform(-0.4, 0.4, n), np.ones(n)])
    depth = rng.uniform(2000, 6000, n)
    cam_pts = dirs * depth[:, None]
    return (cam_pts - cam.T) @ cam.R  # Rᵀ (Xc − T)


def test_projection_matches_hand_formula_with_skew_and_all_distortion_terms():
    rng = np.random.default_rng(1)
    cam = skewed_camera(rng)
    X = points_in_front(rng, cam)
    expected = project_by_hand(X, cam.fc, cam.cc, cam.alpha_c, cam.kc, cam.R, cam.T)
    np.testing.assert_allclose(cam.project(X), expected, rtol=0, atol=1e-9)


def test_projection_matches_opencv_without_skew():
    rng = np.random.default_rng(2)
    cam = skewed_camera(rng, alpha=0.0)
    X = points_in_front(rng, cam)
    K, dist, rvec, tvec = cam.to_opencv()
    ocv, _ = cv2.projectPoints(X.reshape(-1, 1, 3), rvec, tvec, K, dist)
    np.testing.assert_allclose(cam.project(X), ocv.reshape(-1, 2), atol=1e-6)


def test_depth_and_centre():
    rng = np.random.default_rng(3)
    cam = skewed_camera(rng)
    X = points_in_front(rng, cam, 10)
    _, depth = cam.project(X, return_depth=True)
    np.testing.assert_allclose(depth, cam.world_to_camera(X)[:, 2])
    np.testing.assert_allclose(cam.world_to_camera(cam.center), 0, atol=1e-9)


def test_rays_back_project_onto_their_pixels():
    rng = np.random.default_rng(4)
    cam = skewed_camera(rng)
    pixels = np.column_stack([rng.uniform(20, 620, 50), rng.uniform(20, 460, 50)])
    origins, dirs = cam.rays(pixels)
    np.testing.assert_allclose(np.linalg.norm(dirs, axis=1), 1.0)
    for t in (1500.0, 5000.0):
        np.testing.assert_allclose(cam.project(origins + t * dirs), pixels, atol=1e-6)


def test_opencv_round_trip_keeps_skew():
    rng = np.random.default_rng(5)
    cam = skewed_camera(rng)
    back = Camera.from_opencv("X", *cam.to_opencv(), size=cam.size)
    X = points_in_front(rng, cam, 20)
    np.testing.assert_allclose(back.project(X), cam.project(X), atol=1e-9)


def test_rig_matches_published_s1_extrinsics():
    # HUMANEVA.md §2.3: S1 C1 T ≈ (−88.1, 804.8, 4315.3) mm, centre (4062.2, 663.2, 1528.4)
    c1 = read_rig(RIG_DIR)["C1"]
    np.testing.assert_allclose(c1.T, (-88.1, 804.8, 4315.3), atol=0.1)
    np.testing.assert_allclose(c1.center, (4062.227, 663.2477, 1528.397), atol=0.01)


def test_rig_sees_a_person_at_the_centre_150_to_300_px_tall():
    for cam in read_rig(RIG_DIR):
        top, foot = cam.project(np.array([[0.0, 0.0, 1800.0], [0.0, 0.0, 0.0]]))
        assert 150 < np.linalg.norm(top - foot) < 300, cam.name
        dist = np.linalg.norm(cam.center[:2])
        assert 3000 <= dist <= 5000 and 1400 <= cam.center[2] <= 2500, cam.name
