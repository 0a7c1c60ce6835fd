"""``io.synchronised.SynchronisedVideos``: synchronised frame numbers over cameras whose videos
start at different frames.

Two cameras of numbered PNG folders (lossless) whose every image holds its own video frame
number, so that which video frame a synchronised frame reads is seen in the pixels:
synchronised frame ``F`` of a camera starting at video frame ``s`` is its video frame
``s + F − 1``.
"""

import types

import cv2
import numpy as np
import pytest

from voxelmocap.errors import InputError
from voxelmocap.io.synchronised import SynchronisedVideos
from voxelmocap.io.video import VideoStream

SIZE = (24, 16)   # width, height


def _frames(folder, n, colour):
    """``n`` numbered images; video frame ``k`` (1-based) is filled with the value ``k``."""
    folder.mkdir()
    for k in range(1, n + 1):
        shape = (SIZE[1], SIZE[0], 3) if colour else (SIZE[1], SIZE[0])
        cv2.imwrite(str(folder / f"img_{k:04d}.png"), np.full(shape, k, np.uint8))
    return folder


class Pair(SynchronisedVideos):
    """Camera ``A`` (colour, ``n_a`` video frames, synchronised frame 1 at video frame
    ``start_a``) and ``B`` (grey, ``n_b`` frames, from its first frame)."""

    def __init__(self, root, *, n_a=10, start_a=3, n_b=12, size_b=SIZE):
        self.subject, self.name = "S1", "Walking_1"
        self.camera_names = ["A", "B"]
        self.starts = {"A": start_a, "B": 1}
        self._streams = {"A": VideoStream(_frames(root / "A", n_a, True), gray=False),
                         "B": VideoStream(_frames(root / "B", n_b, False), gray=True)}
        self.rig = {"A": types.SimpleNamespace(size=SIZE), "B": types.SimpleNamespace(size=size_b)}


def test_the_synchronised_frames_are_those_every_camera_holds(tmp_path):
    seq = Pair(tmp_path)
    assert seq.video_frame_counts() == {"A": 10, "B": 12}
    assert seq.n_frames == min(10 - 3 + 1, 12 - 1 + 1) == 8       # A's last frame counts
    np.testing.assert_array_equal(seq.frame_numbers, np.arange(1, 9))
    late = tmp_path / "late"
    late.mkdir()
    assert Pair(late, start_a=11).n_frames == 0                     # A starts past its end


def test_each_synchronised_frame_reads_its_video_frame_of_each_camera(tmp_path):
    seq = Pair(tmp_path)
    seen = []
    for frame, images in seq.frames():
        assert set(images) == {"A", "B"}
        assert images["A"].shape == (16, 24, 3) and images["B"].shape == (16, 24)
        assert images["A"].dtype == images["B"].dtype == np.uint8
        seen.append((frame, int(images["A"][0, 0, 0]), int(images["B"][0, 0])))
    assert seen == [(f, f + 2, f) for f in range(1, 9)]
    # any order asked, sorted; one frame alone
    assert [(f, int(im["A"][5, 5, 1])) for f, im in seq.frames([7, 2, 5])] == \
        [(2, 4), (5, 7), (7, 9)]
    assert int(seq.read_frame(8)["A"].max()) == 10 and int(seq.read_frame(8)["B"].min()) == 8
    assert seq.camera("B").size == SIZE


@pytest.mark.parametrize("frames, bad", [([0, 3], 0), ([3, 9], 9), ([-2], -2)])
def test_frames_outside_the_range_are_refused_naming_the_sequence(tmp_path, frames, bad):
    seq = Pair(tmp_path)
    with pytest.raises(InputError) as info:
        seq.check_frames(frames)
    assert str(info.value) == f"S1/Walking_1: frame {bad} is outside the synchronised range 1..8"
    with pytest.raises(InputError, match="outside the synchronised range"):
        next(seq.frames(frames))
    assert seq.check_frames([5, 1, 8]) == [1, 5, 8]


def test_an_image_of_another_size_than_the_calibration_is_refused_naming_the_video(tmp_path):
    seq = Pair(tmp_path, size_b=(32, 16))
    with pytest.raises(InputError) as info:
        seq.read_frame(2)
    assert str(info.value) == (f"{tmp_path / 'B'}: frame size 24x16 differs from the "
                               "calibration's 32x16")


def test_one_camera_reads_the_images_the_synchronised_frames_hold(tmp_path):
    seq = Pair(tmp_path)
    wanted = [7, 2, 5, 5]
    together = [(f, im) for f, im in seq.frames(wanted)]
    for cam in ("A", "B"):
        alone = list(seq.camera_frames(cam, wanted))
        assert [f for f, _ in alone] == [f for f, _ in together] == [2, 5, 5, 7]
        for (_, a), (_, t) in zip(alone, together, strict=True):
            np.testing.assert_array_equal(a, t[cam])
    assert [int(im[0, 0]) for _, im in seq.camera_frames("B")] == list(range(1, 9))
    with pytest.raises(InputError, match="outside the synchronised range"):
        next(seq.camera_frames("A", [9]))
    other = tmp_path / "other"
    other.mkdir()
    with pytest.raises(InputError, match="frame size 24x16 differs"):
        next(Pair(other, size_b=(32, 16)).camera_frames("B", [1]))


def test_frames_by_camera_stack_each_camera_when_asked_and_keep_nothing(tmp_path):
    seq = Pair(tmp_path)
    by_camera = seq.by_camera([6, 1, 3])
    assert by_camera.numbers == [1, 3, 6]
    assert list(by_camera) == ["A", "B"] and len(by_camera) == 2
    assert "B" in by_camera and "C" not in by_camera
    a, b = by_camera["A"], by_camera["B"]
    assert a.shape == (3, 16, 24, 3) and b.shape == (3, 16, 24) and a.dtype == np.uint8
    np.testing.assert_array_equal(a, np.stack([im["A"] for _, im in seq.frames([1, 3, 6])]))
    assert [int(v) for v in b[:, 0, 0]] == [1, 3, 6]
    assert by_camera["A"] is not a                        # decoded again, not kept
    with pytest.raises(KeyError):
        by_camera["C"]
    # a subset of the sampled frames, every camera per frame
    picked = list(by_camera.frames([0, 2]))
    assert [int(im["B"][0, 0]) for im in picked] == [1, 6]
    assert [int(im["A"][0, 0, 0]) for im in picked] == [3, 8]   # A starts at video frame 3
