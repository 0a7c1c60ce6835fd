"""A sequence measured at a working size: images shrunk where decoded, cameras to match.

Truth from outside the code under test: the pixel-centre mapping of a resize in closed form, the
intensity centroid of a disk drawn at a projected point and shrunk by OpenCV, OpenCV's own
``resize`` of the decoded frames, and the same person carved at the native size.
"""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from voxelmocap.camera import Camera
from voxelmocap.cli import main
from voxelmocap.config import TrackConfig, with_overrides
from voxelmocap.io.humaneva import Dataset
from voxelmocap.io.voxels import VoxelDump
from voxelmocap.io.working_size import AtMostSide, at_most_side, shrunk_size
from voxelmocap.run.measurement import MeasurementRunner


def _camera(size=(640, 480)):
    return Camera("C1", fc=(610.0, 604.0), cc=(331.2, 236.7), R=np.eye(3), T=(40.0, -30.0, 4000.0),
                  alpha_c=0.002, kc=(-0.2, 0.05, 1e-3, -5e-4, 0.01), size=size)


@pytest.fixture(scope="module")
def walk(walk_dataset):
    return Dataset(walk_dataset).sequence("S1", "Walking_1")


@pytest.mark.parametrize("size", [(320, 240), (333, 250), (1280, 960)])
def test_a_resized_camera_projects_to_the_resized_pixel_centres(size):
    rng = np.random.default_rng(0)
    points = rng.uniform([-800, -600, -500], [800, 600, 900], (200, 3))
    cam = _camera()
    u = cam.project(points)
    s = np.array([size[0] / 640, size[1] / 480])
    np.testing.assert_allclose(cam.resized(size).project(points), (u + 0.5) * s - 0.5,
                               rtol=0, atol=1e-9)
    assert cam.resized(size).size == size


def test_a_disk_drawn_at_a_projection_stays_centred_on_it_when_shrunk():
    # OpenCV's area resize preserves a blob's intensity centroid under the pixel-centre mapping
    # the shrunk camera uses; half a pixel off (a camera scaled about the corner) fails this
    cam = _camera()
    small = cam.resized(shrunk_size(cam.size, 256))
    point = np.array([[120.0, -80.0, 300.0]])
    u, v = cam.project(point)[0]
    yy, xx = np.mgrid[0:480, 0:640]
    image = (((xx - u) ** 2 + (yy - v) ** 2) <= 30.0 ** 2).astype(np.float32)
    shrunk = cv2.resize(image, small.size, interpolation=cv2.INTER_AREA)
    ys, xs = np.mgrid[0:shrunk.shape[0], 0:shrunk.shape[1]]
    centroid = np.array([(xs * shrunk).sum(), (ys * shrunk).sum()]) / shrunk.sum()
    np.testing.assert_allclose(centroid, small.project(point)[0], atol=0.02)


def test_sequences_no_larger_than_the_working_size_are_left_alone(walk):
    assert at_most_side(walk, 0) is walk
    assert at_most_side(walk, None) is walk
    assert at_most_side(walk, 640) is walk        # 640 × 480: nothing to shrink
    assert shrunk_size((640, 480), 1000) == (640, 480)
    assert shrunk_size((1080, 1920), 960) == (540, 960)
    assert shrunk_size((1088, 1920), 960) == (544, 960)


def test_images_cameras_and_backgrounds_come_at_the_working_size(walk):
    small = at_most_side(walk, 320)
    assert isinstance(small, AtMostSide)
    assert small.name == walk.name and small.subject == walk.subject
    assert list(small.frame_numbers) == list(walk.frame_numbers)
    assert [c.size for c in small.rig] == [(320, 240)] * len(walk.rig)
    for (f, native), (g, images) in zip(walk.frames([2, 5]), small.frames([2, 5]), strict=True):
        assert f == g
        for cam, image in images.items():
            expected = cv2.resize(native[cam], (320, 240), interpolation=cv2.INTER_AREA)
            np.testing.assert_array_equal(image, expected)
    cam = walk.camera_names[0]
    by_camera = small.by_camera([2, 5])[cam]
    assert by_camera.shape[:3] == (2, 240, 320)
    np.testing.assert_array_equal(by_camera[1], small.read_frame(5)[cam])
    native_sets = walk.background_sets(cam, max_frames=3)
    small_sets = small.background_sets(cam, max_frames=3)
    assert [len(s) for s in small_sets] == [len(s) for s in native_sets]
    np.testing.assert_array_equal(
        small_sets[0][2], cv2.resize(native_sets[0][2], (320, 240), interpolation=cv2.INTER_AREA))
    assert next(iter(small.background_frames(cam, max_frames=1))).shape[:2] == (240, 320)
    assert "320x240" in small.summary and "640x480" in small.summary


def test_the_person_carved_at_half_size_is_the_person_carved_at_full_size(walk):
    config = with_overrides(TrackConfig(), **{"measurement.grid_placement": "rig",
                                              "measurement.voxel_size": 40.0})
    full = MeasurementRunner(walk, config)
    half = MeasurementRunner(at_most_side(walk, 320), config)
    assert half.grid == full.grid
    images = walk.read_frame(4)
    a = full.measure(images).occupancy
    b = half.measure(at_most_side(walk, 320).read_frame(4)).occupancy
    iou = np.count_nonzero(a & b) / np.count_nonzero(a | b)
    assert a.sum() > 100 and iou > 0.8


def test_dump_measures_at_the_configured_size(walk_dataset, tmp_path):
    config = tmp_path / "c.toml"
    config.write_text("[measurement]\nmax_image_side = 320\nvoxel_size = 50.0\n"
                      "grid_placement = \"rig\"\n")
    out = tmp_path / "vox.h5"
    rc = main(["dump", str(walk_dataset), "--subject", "S1", "--sequence", "Walking_1",
               "--frames", "1:2", "--masks", "--config", str(config), "--out", str(out),
               "--no-progress", "-q"])
    assert rc == 0
    with VoxelDump(out) as dump:
        assert dump.masks(1).shape[1:] == (240, 320)
        assert all(c.size == (320, 240) for c in dump.cameras())


@pytest.mark.parametrize("value", [-1, 1, 63])
def test_a_working_size_too_small_to_hold_a_person_is_refused_in_one_line(value, tmp_path):
    from voxelmocap.config import config_from_toml
    from voxelmocap.errors import InputError

    with pytest.raises(InputError) as info:
        config_from_toml(f"[measurement]\nmax_image_side = {value}\n")
    assert str(info.value).endswith(f"must be 0 (as filmed) or at least 64 pixels, got {value}")
    assert "\n" not in str(info.value)
    for ok in (0, 64, 960):
        assert config_from_toml(f"[measurement]\nmax_image_side = {ok}\n") \
            .measurement.max_image_side == ok
