"""Writing videos that play anywhere (H.264 through PyAV), atomically, one line for every refusal.

``.mp4``, ``.mov`` and ``.mkv`` are written as **H.264** (``libx264``, 4:2:0 chroma, the
``yuv420p`` pixel format every browser and presentation program decodes; ``.mp4``/``.mov`` with
their index at the front, ``+faststart``, so that a browser can start playing before the whole
file is loaded); ``.avi`` as Motion-JPEG (:data:`VIDEO_CODECS`). The encoder is FFmpeg's, through
PyAV (the ``av`` package), whose wheels ship ``libx264``: OpenCV's own writer only offers MPEG-4
Part 2 (``mp4v``), which browsers and slide software do not play. Image names (``.png``, ``.gif``,
…) are refused.

The frame rate is kept as given (a rational close to it: 59.94 Hz is written as 2997/50, not
rounded to 60). 4:2:0 chroma needs an even width and height: an odd frame is padded by one black
column or row on the right or at the bottom (:attr:`VideoWriter.padded`).

The video is written to a hidden temporary beside the target (:mod:`voxelmocap.io._atomic`), which
is created first — an output that cannot be written is reported before any frame is rendered — and
renamed when :meth:`VideoWriter.close` succeeds, or deleted on any failure. Before the rename the
temporary is read back: a file that does not hold every frame written (a full disk that went
unreported) is refused in one line, like a write that FFmpeg reports failed.

>>> with VideoWriter("overlay.mp4", fps=60.0, size=(640, 480)) as video:   # doctest: +SKIP
...     video.write(image)                                                 # (480, 640, 3) uint8 BGR
"""

from __future__ import annotations

import contextlib
import math
import os
from fractions import Fraction
from pathlib import Path

import numpy as np

from ..errors import InputError
from ._atomic import create_temporary

__all__ = ["VIDEO_CODECS", "VideoWriter", "check_video_path", "frame_rate_fraction"]

#: Video file suffix → the codec written into it (tested round trips in tests/io).
VIDEO_CODECS: dict[str, str] = {".mp4": "h264", ".mov": "h264", ".mkv": "h264", ".avi": "mjpeg"}
#: Suffix → (FFmpeg container format, encoder, pixel format).
_FORMATS = {".mp4": ("mp4", "libx264", "yuv420p"), ".mov": ("mov", "libx264", "yuv420p"),
            ".mkv": ("matroska", "libx264", "yuv420p"), ".avi": ("avi", "mjpeg", "yuvj420p")}
#: libx264's quality: constant rate factor 18 keeps the one-pixel cone outlines of the overlays
#: sharp (FFmpeg's default of 23 smears them) at a few hundred kB per second of 640x480 video.
_X264_OPTIONS = {"crf": "18", "preset": "medium"}
#: FFmpeg's colour tags (libavutil/pixfmt.h): AVCOL_SPC_SMPTE170M (the BT.601 matrix),
#: AVCOL_RANGE_MPEG, AVCOL_PRI_BT709 and AVCOL_TRC_IEC61966_2_1 (sRGB's primaries and curve: the
#: frames are screen images).
_SMPTE170M, _MPEG_RANGE, _BT709_PRIMARIES, _SRGB_TRANSFER = 6, 1, 1, 13


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


def frame_rate_fraction(fps: float) -> Fraction:
    """The frame rate as a fraction with a denominator of at most 1001 (NTSC's 30000/1001)."""
    return Fraction(float(fps)).limit_denominator(1001)


def _packets_on_disk(path) -> int:
    """How many whole video frames a written file holds: its complete video packets, demuxed
    without decoding (one packet per frame for H.264 and Motion-JPEG once the encoder is
    flushed). A packet cut short by the file's end is flagged corrupt by FFmpeg and not
    counted; a file that cannot be opened holds 0."""
    import av

    count = 0
    try:
        with av.open(str(path)) as container:
            for packet in container.demux(video=0):
                if packet.size and not packet.is_corrupt:  # not the final empty one, nor cut
                    count += 1
    except (av.FFmpegError, OSError, IndexError):
        pass
    return count


class VideoWriter:
    """A video file written frame by frame (a context manager; complete or absent).

    Parameters
    ----------
    path : str or os.PathLike
        ``.mp4``, ``.mov``, ``.mkv`` (H.264) or ``.avi`` (Motion-JPEG) file, replaced once
        complete.
    fps : float
        Frame rate (> 0).
    size : (2,) sequence of int
        Frame width and height in pixels.

    Attributes
    ----------
    padded : bool
        The frames are padded to an even width or height (4:2:0 chroma).
    n_frames : int
        Frames written so far.

    Raises
    ------
    InputError
        Not a video name, a bad frame rate, a place that cannot be written, or a format the
        installed FFmpeg (PyAV) cannot write.
    """

    def __init__(self, path, fps: float, size):
        import av

        self.path = check_video_path(path, fps)
        self.size = (int(size[0]), int(size[1]))
        if min(self.size) <= 0:
            raise InputError(self.path, f"frame size must be positive, got {size!r}")
        container_format, encoder, pix_fmt = _FORMATS[self.path.suffix.lower()]
        w, h = self.size
        self._coded = (w + w % 2, h + h % 2)
        self.padded = self._coded != self.size
        self.rate = frame_rate_fraction(fps)
        self._tmp = create_temporary(self.path)
        self._container = None
        try:
            options = {"movflags": "+faststart"} if container_format in ("mp4", "mov") else {}
            self._container = av.open(str(self._tmp), mode="w", format=container_format,
                                      options=options)
            stream = self._container.add_stream(encoder, rate=self.rate,
                                                options=_X264_OPTIONS if encoder == "libx264"
                                                else {})
            stream.width, stream.height = self._coded
            stream.pix_fmt = pix_fmt
            if encoder == "libx264":
                # Say how the colours were encoded: FFmpeg's RGB → YUV conversion uses the
                # BT.601 matrix and the limited (16–235) range; a player guessing BT.709 for
                # an untagged stream would shift the hues.
                context = stream.codec_context
                context.colorspace = _SMPTE170M
                context.color_range = _MPEG_RANGE
                context.color_primaries = _BT709_PRIMARIES  # sRGB's primaries
                context.color_trc = _SRGB_TRANSFER
            if encoder == "mjpeg":
                stream.codec_context.qmax = 4  # near-lossless frames, as OpenCV's MJPG wrote
            self._stream = stream
        except (av.FFmpegError, ValueError, OSError) as exc:
            self.abort()
            raise InputError(self.path, f"cannot write {self.path.suffix} video with "
                                        f"{encoder} ({exc})") from None
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
        import av

        image = np.ascontiguousarray(image)
        w, h = self.size
        if image.shape != (h, w, 3) or image.dtype != np.uint8:
            raise InputError(self.path, f"frame {self.n_frames + 1} is {image.dtype} "
                                        f"{image.shape}, expected uint8 {(h, w, 3)}")
        if self.padded:
            image = np.pad(image, ((0, self._coded[1] - h), (0, self._coded[0] - w), (0, 0)))
        frame = av.VideoFrame.from_ndarray(image, format="bgr24")
        frame.pts = self.n_frames  # in 1/rate: the stream's time base follows the frame rate
        self._encode(frame)
        self.n_frames += 1

    def _encode(self, frame) -> None:
        import av

        try:
            for packet in self._stream.encode(frame):
                self._container.mux(packet)
        except (av.FFmpegError, OSError) as exc:
            raise InputError(self.path, f"cannot write the video ({exc})") from None

    def close(self) -> None:
        """Finish the video and move it to its name."""
        import av

        if self._container is None:
            return
        try:
            self._encode(None)  # flush the encoder's delayed frames
            self._container.close()
            self._container = None
            if self._tmp.stat().st_size == 0:
                raise InputError(self.path, "FFmpeg wrote nothing (disk full?)")
            # A write lost on the way to the disk (a full disk that a layer below FFmpeg did
            # not report) must not pass for a video: it is read back, and one that does not
            # hold every frame is not moved to its name.
            written = _packets_on_disk(self._tmp)
            if written < self.n_frames:
                raise InputError(self.path, f"cannot write the video ({written} of "
                                            f"{self.n_frames} frames reached the disk: is it "
                                            "full?)")
            os.replace(self._tmp, self.path)
        except (av.FFmpegError, OSError) as exc:
            raise InputError(self.path, f"cannot write the video "
                                        f"({getattr(exc, 'strerror', None) or exc})") from None
        finally:
            self.abort()

    def abort(self) -> None:
        """Discard the video (nothing is left, under its name or a temporary one)."""
        if self._container is not None:
            with contextlib.suppress(Exception):
                self._container.close()
            self._container = None
        with contextlib.suppress(FileNotFoundError):
            self._tmp.unlink()
