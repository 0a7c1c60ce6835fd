import numpy as np

from voxelmocap.camera import Camera
from voxelmocap.viz.overlay import cone_outline_points, draw_landmarks


def front_camera():
    # camera 4 m in front of the origin (at −Y), looking along +Y, image y down = world −Z
    R = np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]])
    return Camera("T", fc=(500, 500), cc=(320, 240), R=R, T=-R @ np.array([0, -4000.0, 1000.0]))


def test_cone_outline_lies_on_the_cone():
    base, axis = np.array([10.0, 20.0, 30.0]), np.array([0, 0, 1.0])
    u1, u2 = np.array([1.0, 0, 0]), np.array([0, 1.0, 0])
    lines = cone_outline_points(base, axis, u1, u2, H=50, W=30, L=200, R=0.5)
    base_ring, top_ring = lines[0], lines[1]
    d = base_ring - base
    np.testing.assert_allclose((d[:, 0] / 50) ** 2 + (d[:, 1] / 30) ** 2, 1.0)
    d = top_ring - (base + 200 * axis)
    np.testing.assert_allclose((d[:, 0] / 25) ** 2 + (d[:, 1] / 15) ** 2, 1.0)
    assert len(lines) == 6


def test_landmarks_land_on_their_projection():
    cam = front_camera()
    rng = np.random.default_rng(0)
    lm = rng.uniform([-400, -200, 200], [400, 200, 1700], size=(15, 3))
    image = np.zeros((480, 640, 3), np.uint8)
    draw_landmarks(image, cam, lm, (0, 0, 255), skeleton=False)
    pix = np.round(cam.project(lm)).astype(int)
    assert np.all(image[pix[:, 1], pix[:, 0], 2] == 255)
    assert image[..., 2].astype(bool).sum() < 15 * 80  # only small (anti-aliased) dots
