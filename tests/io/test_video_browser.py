"""The videos ``overlay`` writes play in a browser: a headless Chromium ``<video>`` element loads
them, reports their duration and decodes the frames it is asked for (scripts/play_in_browser.py).

Skipped without Chromium (Debian: ``apt-get install -y chromium``).
"""

import importlib.util
from pathlib import Path

import cv2
import numpy as np
import pytest

from voxelmocap.io.video_writer import VideoWriter

SCRIPT = Path(__file__).resolve().parents[2] / "scripts" / "play_in_browser.py"


def _browser():
    spec = importlib.util.spec_from_file_location("play_in_browser", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    if module.find_chromium() is None:
        pytest.skip("no Chromium to play the video in (apt-get install -y chromium)")
    return module


def _frames(n, size):
    """Frame k: dark grey with a bright bar at columns 4k … 4k + 3."""
    w, h = size
    out = []
    for k in range(n):
        img = np.full((h, w, 3), 30, np.uint8)
        img[:, 4 * k:4 * k + 4] = 230
        out.append(img)
    return out


def test_an_h264_video_plays_in_chromium(tmp_path):
    browser = _browser()
    path = tmp_path / "clip.mp4"
    with VideoWriter(path, 15.0, (161, 121)) as video:  # odd sides: padded to 162 x 122
        for img in _frames(30, (161, 121)):
            video.write(img)
    shown = browser.play(path, seeks=[0.0, 1.0, 1.9])
    assert "error" not in shown, shown
    assert shown["duration"] == pytest.approx(2.0) and (shown["width"], shown["height"]) == (
        162, 122)
    # the frames at 0 s, 1 s and 1.9 s are frames 0, 15 and 28: their bar is where it was drawn
    for seek, k in zip(shown["seeks"], (0, 15, 28), strict=True):
        assert seek["current_time"] == pytest.approx(seek["time"])
        assert 4 * k <= seek["brightest_column"] <= 4 * k + 3, seek
        assert 28 < seek["mean"] < 45


def test_the_check_can_fail_mpeg4_part2_does_not_play(tmp_path):
    browser = _browser()
    path = tmp_path / "mp4v.mp4"  # what overlay wrote before: OpenCV's MPEG-4 Part 2
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), 15.0, (160, 120))
    for img in _frames(10, (160, 120)):
        writer.write(img)
    writer.release()
    shown = browser.play(path, seeks=[0.0])
    assert "no supported streams" in shown.get("error", ""), shown
