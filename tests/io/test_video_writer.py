"""Video writing: the accepted formats round-trip, everything else is one line and no file."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from voxelmocap.errors import InputError
from voxelmocap.io.video_writer import VIDEO_CODECS, VideoWriter


def _frames(n=6, size=(64, 48)):
    w, h = size
    out = []
    for k in range(n):
        img = np.full((h, w, 3), 30, np.uint8)
        img[:, 8 * k:8 * k + 8] = 220  # a bar whose column encodes the frame
        out.append(img)
    return out


@pytest.mark.parametrize("suffix", sorted(VIDEO_CODECS))
def test_every_accepted_format_round_trips(tmp_path, suffix):
    path = tmp_path / f"clip 1{suffix}"
    with VideoWriter(path, 12.0, (64, 48)) as video:
        for img in _frames():
            video.write(img)
    assert [p.name for p in tmp_path.iterdir()] == [path.name]
    cap = cv2.VideoCapture(str(path))
    decoded = []
    while True:
        ok, img = cap.read()
        if not ok:
            break
        decoded.append(img)
    assert abs(cap.get(cv2.CAP_PROP_FPS) - 12.0) < 1e-6
    cap.release()
    assert len(decoded) == 6
    for k, img in enumerate(decoded):
        assert int(np.argmax(img.mean(axis=(0, 2)) > 125)) == 8 * k


@pytest.mark.parametrize("name", ["x.gif", "x.png", "x.jpg", "x", "x.webm"])
def test_image_and_unknown_names_are_refused(tmp_path, name):
    with pytest.raises(InputError, match="not a video file name"):
        VideoWriter(tmp_path / name, 30.0, (64, 48))
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("fps", [0, -5, float("nan"), float("inf"), "fast"])
def test_frame_rate_must_be_positive(tmp_path, fps):
    with pytest.raises(InputError, match="frame rate must be a positive number"):
        VideoWriter(tmp_path / "x.mp4", fps, (64, 48))
    assert list(tmp_path.iterdir()) == []


def test_unwritable_place_says_so_not_the_format(tmp_path):
    (tmp_path / "plain").write_text("x")
    with pytest.raises(InputError, match="not a folder"):
        VideoWriter(tmp_path / "plain" / "x.mp4", 30.0, (64, 48))
    with pytest.raises(InputError, match="cannot write here"):
        VideoWriter(tmp_path / ("n" * 300 + ".mp4"), 30.0, (64, 48))
    assert [p.name for p in tmp_path.iterdir()] == ["plain"]


def test_failure_while_writing_leaves_nothing(tmp_path):
    with pytest.raises(InputError, match="expected uint8"), \
            VideoWriter(tmp_path / "x.avi", 30.0, (64, 48)) as video:
        video.write(_frames()[0])
        video.write(np.zeros((10, 10, 3), np.uint8))
    assert list(tmp_path.iterdir()) == []
