"""The support column of a plate's cover against a ray-cylinder intersection computed per pixel."""

import numpy as np
from scipy import ndimage

from voxelmocap.camera import Camera
from voxelmocap.pose.body_cover import support_column


def look_at(eye, target, *, size=(320, 240), f=300.0, name="C"):
    """A distortion-free camera at ``eye`` looking at ``target`` (world Z up, image y down)."""
    eye, target = np.asarray(eye, float), np.asarray(target, float)
    z = target - eye
    z /= np.linalg.norm(z)
    x = np.cross(z, [0.0, 0.0, 1.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    R = np.stack([x, y, z])
    return Camera(name, fc=(f, f), cc=((size[0] - 1) / 2, (size[1] - 1) / 2), R=R, T=-R @ eye,
                  size=size)


def cylinder_by_rays(cam, centre, radius, top):
    """Pixels whose ray (through the pixel's centre) meets the solid cylinder: closed form."""
    w, h = cam.size
    u, v = np.meshgrid(np.arange(w, dtype=float), np.arange(h, dtype=float))
    d_cam = np.stack([(u - cam.cc[0]) / cam.fc[0], (v - cam.cc[1]) / cam.fc[1], np.ones_like(u)],
                     axis=-1)
    d = d_cam @ cam.R                        # world directions (R is world → camera)
    o = -cam.R.T @ cam.T                     # the camera's centre in the world
    ox, oy = o[0] - centre[0], o[1] - centre[1]
    a = d[..., 0] ** 2 + d[..., 1] ** 2
    b = 2 * (ox * d[..., 0] + oy * d[..., 1])
    c = ox ** 2 + oy ** 2 - radius ** 2
    disc = b * b - 4 * a * c
    hit = disc >= 0
    root = np.sqrt(np.where(hit, disc, 0))
    with np.errstate(divide="ignore", invalid="ignore"):
        t0, t1 = (-b - root) / (2 * a), (-b + root) / (2 * a)
        # the slab 0 ≤ z ≤ top along the ray
        s0, s1 = (0 - o[2]) / d[..., 2], (top - o[2]) / d[..., 2]
    lo = np.maximum(np.maximum(t0, np.minimum(s0, s1)), 0)
    hi = np.minimum(t1, np.maximum(s0, s1))
    return hit & (hi >= lo)


def test_the_column_is_the_image_of_the_cylinder_under_the_pelvis():
    rng = np.random.default_rng(7)
    for _ in range(6):
        azimuth = rng.uniform(0, 2 * np.pi)
        eye = (4000 * np.cos(azimuth), 4000 * np.sin(azimuth), rng.uniform(800, 2500))
        cam = look_at(eye, (0, 0, 600))
        pelvis = (rng.uniform(-300, 300), rng.uniform(-300, 300), rng.uniform(700, 1000))
        radius = rng.uniform(150, 400)
        mine = support_column(cam, pelvis, radius)
        truth = cylinder_by_rays(cam, pelvis[:2], radius, pelvis[2])
        assert truth.sum() > 1000
        # the inscribed 48-gon holds 99.7 % of a circle's area; the filled polygon takes the
        # pixels its edges touch, so the misses are few and the extra pixels are on the rim
        assert (truth & ~mine).sum() < 0.01 * truth.sum()
        rim = ndimage.binary_dilation(truth, np.ones((3, 3), bool)) & ~truth
        assert not (mine & ~truth & ~rim).any()


def test_no_column_behind_the_camera_or_under_the_floor():
    cam = look_at((0, -3000, 1000), (0, 0, 1000))
    # a pelvis beside the camera: part of the column is behind it
    assert not support_column(cam, (0, -3000, 900), 300).any()
    assert not support_column(cam, (0, 0, -10), 300).any()
    assert support_column(cam, (0, 0, 900), 300).any()


def test_the_cover_with_support_is_the_body_and_the_column_under_its_pelvis():
    from voxelmocap.body import BodyModel
    from voxelmocap.body.shapes import BodyDimensions
    from voxelmocap.measure.plate import camera_at_most
    from voxelmocap.pose.body_cover import plate_covers_of

    model = BodyModel(BodyDimensions.average())
    states = np.zeros((2, 27))
    states[:, 2] = 950.0
    states[1, :2] = (400.0, -200.0)
    rig = [look_at((3500, 500, 1600), (0, 0, 900), size=(960, 640), f=700.0, name="A"),
           look_at((-600, -3800, 2400), (0, 0, 900), size=(960, 640), f=700.0, name="B")]
    body = plate_covers_of(rig, model, states, 20.0)
    both = plate_covers_of(rig, model, states, 20.0, support=300.0)
    for cam in rig:
        small = camera_at_most(cam, 480)
        for f, state in enumerate(states):
            column = support_column(small, state[:3], 300.0)
            assert np.array_equal(both[cam.name][f], body[cam.name][f] | column)
            assert (column & ~body[cam.name][f]).sum() > 100     # the column adds pixels
