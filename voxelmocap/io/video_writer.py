"""Writing videos (OpenCV's FFmpeg back end), atomically, with one clear line for every refusal.

Only container formats are accepted (:data:`VIDEO_CODECS`: ``.mp4``, ``.mov``, ``.mkv`` with MPEG-4
part 2, ``.avi`` with Motion-JPEG — what this OpenCV build writes without falling back to another
codec). Image names (``.png``, ``.gif``, …) are refused: OpenCV would pick an image-sequence
writer and keep one frame, or one file per frame. The FFmpeg back end is requested explicitly so
that no other back end is tried.

The video is written to a hidden temporary beside the target (:mod:`voxelmocap.io._atomic`), which
is created first — an output that cannot be written is reported before any frame is rendered — and
renamed when :meth:`VideoWriter.close` succeeds, or deleted on any failure.

>>> with VideoWriter("overlay.mp4", fps=30.0, size=(640, 480)) as video:   # doctest: +SKIP
...     video.write(image)                                                 # (480, 640, 3) uint8 BGR
"""

from __future__ import annotations

import contextlib
import math
import os
from pathlib import Path

import numpy as np

from ..errors import InputError
from ._atomic import create_temporary

__all__ = ["VIDEO_CODECS", "VideoWriter", "check_video_path"]

#: Video file suffix → FourCC of the codec written into it (tested round trips in tests/io).
VIDEO_CODECS: dict[str, str] = {".mp4": "mp4v", ".mov": "mp4v", ".mkv": "mp4v", ".avi": "MJPG"}


def check_video_path(path, fps: float) -> Path:
    """Refuse a name that is not a video file or a frame rate that is not positive, in one line.

    Parameters
    ----------
    path : str or os.PathLike
        The video to write.
    fps : float
        Its frame rate (frames per second).

    Returns
    -------
    Path
    """
    path = Path(path)
    if path.suffix.lower() not in VIDEO_CODECS:
        raise InputError(path, "not a video file name; use "
                               f"{', '.join(VIDEO_CODECS)} (got {path.suffix or 'no suffix'!r})")
    try:
        ok = math.isfinite(float(fps)) and float(fps) > 0
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise InputError(path, f"the frame rate must be a positive number, got {fps!r}")
    return path


class VideoWriter:
    """A video file written frame by frame (a context manager; complete or absent).

    Parameters
    ----------
    path : str or os.PathLike
        ``.mp4``, ``.mov``, ``.mkv`` or ``.avi`` file (replaced once complete).
    fps : float
        Frame rate (> 0).
    size : (2,) sequence of int
        Frame width and height in pixels.

    Raises
    ------
    InputError
        Not a video name, a bad frame rate, a place that cannot be written, or a format OpenCV
        cannot write.
    """

    def __init__(self, path, fps: float, size):
        import cv2

        self.path = check_video_path(path, fps)
        self.size = (int(size[0]), int(size[1]))
        if min(self.size) <= 0:
            raise InputError(self.path, f"frame size must be positive, got {size!r}")
        fourcc = VIDEO_CODECS[self.path.suffix.lower()]
        self._tmp = create_temporary(self.path)
        self._writer = cv2.VideoWriter(str(self._tmp), cv2.CAP_FFMPEG,
                                       cv2.VideoWriter_fourcc(*fourcc), float(fps), self.size)
        if not self._writer.isOpened():
            self.abort()
            raise InputError(self.path, f"OpenCV cannot write {self.path.suffix} video with the "
                                        f"{fourcc} codec on this machine")
        self.n_frames = 0

    def __enter__(self) -> VideoWriter:
        return self

    def __exit__(self, exc_type, exc, tb):
        if exc_type is None:
            self.close()
        else:
            self.abort()
        return False

    def write(self, image) -> None:
        """Append one ``(H, W, 3)`` uint8 BGR frame of the writer's size."""
        image = np.ascontiguousarray(image)
        w, h = self.size
        if image.shape != (h, w, 3) or image.dtype != np.uint8:
            raise InputError(self.path, f"frame {self.n_frames + 1} is {image.dtype} "
                                        f"{image.shape}, expected uint8 {(h, w, 3)}")
        self._writer.write(image)
        self.n_frames += 1

    def close(self) -> None:
        """Finish the video and move it to its name."""
        if self._writer is None:
            return
        import cv2

        self._writer.release()
        self._writer = None
        try:
            if self._tmp.stat().st_size == 0:
                raise InputError(self.path, "OpenCV wrote nothing (disk full?)")
            # OpenCV does not report a failed write (a full disk): the video is read back, and
            # one that does not hold every frame is not moved to its name.
            cap = cv2.VideoCapture(str(self._tmp))
            written = int(cap.get(cv2.CAP_PROP_FRAME_COUNT)) if cap.isOpened() else 0
            cap.release()
            if written < self.n_frames:
                raise InputError(self.path, f"cannot write the video ({written} of "
                                            f"{self.n_frames} frames reached the disk: is it "
                                            "full?)")
            os.replace(self._tmp, self.path)
        except OSError as exc:
            raise InputError(self.path, f"cannot write the video ({exc.strerror or exc})") \
                from None
        finally:
            with contextlib.suppress(FileNotFoundError):
                self._tmp.unlink()

    def abort(self) -> None:
        """Discard the video (nothing is left, under its name or a temporary one)."""
        if self._writer is not None:
            with contextlib.suppress(Exception):
                self._writer.release()
            self._writer = None
        with contextlib.suppress(FileNotFoundError):
            self._tmp.unlink()
