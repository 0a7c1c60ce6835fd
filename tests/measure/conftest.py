"""Fixtures shared by the measurement tests."""

import cv2
import pytest


@pytest.fixture
def opencv_threads():
    """Set OpenCV's thread count for one test (the width of the measurement's thread pool),
    then restore it."""
    before = cv2.getNumThreads()
    yield cv2.setNumThreads
    cv2.setNumThreads(before)
