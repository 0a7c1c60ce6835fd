"""Camera videos on disk: one decoder for video files (any format OpenCV reads) and image folders.

:class:`VideoStream` reads the frames of one camera, from a video file (``.avi``, ``.mp4``,
``.mov`` … whatever the OpenCV build decodes) or from a folder of numbered images (``.png``,
``.jpg``, ``.bmp``, ``.tif``). :func:`find_videos` lists the camera videos of a folder. The HumanEva
layout (:mod:`voxelmocap.io.humaneva`) and the project layouts (:mod:`voxelmocap.io.project`) both
read through it.

>>> stream = VideoStream(Path("videos/cam01.mp4"), gray=False)        # doctest: +SKIP
>>> for index, image in stream.read(range(10)): ...                  # doctest: +SKIP
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Iterator
from pathlib import Path

import cv2
import numpy as np

from ..errors import InputError
from ._image_headers import check_image

__all__ = ["IMAGE_SUFFIXES", "VIDEO_SUFFIXES", "VideoStream", "find_videos", "is_image_folder"]

#: Image files a numbered-image folder may hold.
IMAGE_SUFFIXES = frozenset({".png", ".bmp", ".tif", ".tiff", ".jpg", ".jpeg"})
#: Video file suffixes taken as camera videos when a folder is searched (any is opened by OpenCV;
#: a file it cannot decode is refused when opened, naming the file).
VIDEO_SUFFIXES = frozenset({".avi", ".mp4", ".mov", ".mkv", ".m4v", ".mpg", ".mpeg", ".wmv",
                            ".webm", ".mts", ".m2ts"})


def _utf8_name(path: Path) -> Path:
    """``path``, or :class:`InputError` naming its folder when its name is not valid UTF-8
    (OpenCV cannot be handed such a name: it crashed on one)."""
    from ..errors import printable

    if printable(path.name) != path.name:
        raise InputError(path.parent, f"file name '{printable(path.name)}' is not valid UTF-8: "
                                      "rename it")
    return path


def _numbered_images(folder: Path) -> dict[int, Path]:
    """``{counter: file}`` of the numbered image files of ``folder`` (last digit run of the stem).

    An entry named like a frame that is not a file (a folder ``frame_000002.png/``) counts as
    that frame, so that it is refused as one rather than skipped.
    """
    numbered = {}
    for p in folder.iterdir():
        if p.suffix.lower() in IMAGE_SUFFIXES and not p.name.startswith("."):
            digits = re.findall(r"\d+", p.stem)
            if digits:
                counter = int(digits[-1])
                if counter in numbered:
                    raise InputError(folder, f"two image files with counter {counter}: "
                                             f"{numbered[counter].name}, {p.name}")
                numbered[counter] = _utf8_name(p)
    return numbered


def is_image_folder(path: Path) -> bool:
    """Whether ``path`` is a folder holding at least one numbered image file."""
    return path.is_dir() and bool(_numbered_images(path))


def find_videos(folder) -> dict[str, Path]:
    """The camera videos of a folder: ``{name: path}`` in natural name order.

    A video is a file with a :data:`VIDEO_SUFFIXES` suffix (named by its stem) or a sub-folder of
    numbered images (named by the folder's name). Hidden files are skipped.
    """
    folder = Path(folder)
    out = {}
    for p in sorted(folder.iterdir(), key=lambda q: natural_key(q.name)):
        if p.name.startswith("."):
            continue
        if p.is_file() and p.suffix.lower() in VIDEO_SUFFIXES:
            name = p.stem
        elif is_image_folder(p):
            name = p.name
        else:
            continue
        _utf8_name(p)
        if name in out:  # cam01.mp4 and cam01.avi: which one is the camera's?
            raise InputError(folder, f"two videos named {name!r} ({out[name].name}, {p.name}): "
                                     "keep one")
        out[name] = p
    return out


def natural_key(text: str) -> tuple:
    """Sort key that orders embedded numbers numerically (``cam2`` before ``cam10``)."""
    return tuple((0, int(t), "") if t.isdigit() else (1, 0, t.lower())
                 for t in re.findall(r"\d+|\D+", text))


class VideoStream:
    """Frames of one camera: a video file (OpenCV) or a folder of numbered images.

    Parameters
    ----------
    path : pathlib.Path
        The video file or the image folder.
    gray : bool
        Deliver ``(H, W)`` grey images instead of ``(H, W, 3)`` BGR ones.

    Attributes
    ----------
    n_frames : int
        Frames in the video (the container's count; for a folder, last − first counter + 1).
    fps : float or None
        The container's frame rate (Hz); None for image folders or a video that states none.

    Raises
    ------
    InputError
        A video OpenCV cannot open, one without frames, a folder without numbered images.
    """

    def __init__(self, path: Path, gray: bool):
        path = Path(path)
        self.path = path
        self.gray = gray
        if path.is_dir():
            numbered = _numbered_images(path)
            if not numbered:
                raise InputError(path, "image folder holds no numbered image files")
            # Video frame k (1-based) is the file with counter first + k − 1 (toolkit
            # cur_image); a gap is an error, never a silent shift of later frames, and it is
            # refused now: a stray frame_999999999.png would otherwise declare 1e9 frames.
            self._first = min(numbered)
            self._files = numbered
            self.n_frames = max(numbered) - self._first + 1
            self.fps = None  # numbered images carry no frame rate
            if self.n_frames != len(numbered):
                missing = next(c for c in range(self._first, max(numbered) + 1)
                               if c not in numbered)
                raise InputError(path, f"no image file with counter {missing} (the files are "
                                       f"numbered {self._first}–{max(numbered)}, "
                                       f"{len(numbered)} of them)")
            self._checked = False
        else:
            self._files = None
            if not path.is_file():
                raise InputError(path, "video not found")
            _utf8_name(path)
            cap = cv2.VideoCapture(str(path))
            try:
                if not cap.isOpened():
                    raise InputError(path, "cannot open video (not a video, or a codec this "
                                           "OpenCV build cannot decode)")
                self.n_frames = int(cap.get(cv2.CAP_PROP_FRAME_COUNT))
                fps = float(cap.get(cv2.CAP_PROP_FPS))
                self.fps = fps if math.isfinite(fps) and fps > 0 else None
            finally:
                cap.release()
            if self.n_frames <= 0:
                raise InputError(path, "video has no frames")

    def _convert(self, image: np.ndarray, index: int) -> np.ndarray:
        if image is None:
            raise InputError(self.path, f"cannot decode frame {index + 1}")
        if image.dtype != np.uint8:
            raise InputError(self.path, f"frame {index + 1} is {image.dtype}, 8-bit images expected")
        if image.ndim == 3 and image.shape[2] == 4:  # PNG with alpha: the alpha is not a mask here
            image = cv2.cvtColor(image, cv2.COLOR_BGRA2BGR)
        if self.gray and image.ndim == 3:
            image = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
        elif not self.gray and image.ndim == 2:
            image = cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)
        return image

    def read(self, indices: Iterable[int]) -> Iterator[tuple[int, np.ndarray]]:
        """Yield ``(index, image)`` for sorted 0-based ``indices``; seeks only when needed."""
        indices = list(indices)
        if self._files is not None:
            for i in indices:
                if not 0 <= i < self.n_frames:
                    raise InputError(self.path, f"frame {i + 1} is outside 1..{self.n_frames}")
                file = self._files.get(self._first + i)
                if file is None:
                    raise InputError(self.path, f"no image file with counter {self._first + i} "
                                                f"(video frame {i + 1})")
                if not self._checked:
                    check_image(file)  # a declared 60000x60000 never reaches the decoder
                try:
                    image = cv2.imread(str(file), cv2.IMREAD_UNCHANGED)
                except cv2.error as exc:
                    raise InputError(file, f"cannot decode the image ({_cv_message(exc)})"
                                     ) from None
                if image is None:
                    raise InputError(file, f"cannot decode the image (video frame {i + 1})")
                yield i, self._convert(image, i)
            return
        cap = cv2.VideoCapture(str(self.path))
        try:
            if not cap.isOpened():
                raise InputError(self.path, "cannot open video")
            pos = 0
            for i in indices:
                if not 0 <= i < self.n_frames:
                    raise InputError(self.path, f"frame {i + 1} is outside 1..{self.n_frames}")
                if i != pos:
                    if i > pos and i - pos < 30:
                        while pos < i:  # decoding forward is exact; seeking may not be
                            if not cap.grab():
                                raise InputError(self.path, f"cannot decode frame {pos + 1}")
                            pos += 1
                    else:
                        cap.set(cv2.CAP_PROP_POS_FRAMES, i)
                        pos = i
                ok, image = cap.read()
                pos += 1
                if not ok:
                    raise InputError(self.path, f"cannot decode frame {i + 1} of {self.n_frames}")
                yield i, self._convert(image, i)
        finally:
            cap.release()

    def missing_frames(self, count: int) -> list[int]:
        """1-based video frames among the first ``count`` without an image file (a numbered
        folder with gaps; always empty for a video file)."""
        if self._files is None:
            return []
        return [k + 1 for k in range(count) if self._first + k not in self._files]

    def check_frames(self) -> None:
        """Check every frame file of an image folder from its bytes (whole, of the first frame's
        size; :func:`~voxelmocap.io._image_headers.check_image`) without decoding one; a no-op
        for a video file, whose frames are checked as they are decoded."""
        if self._files is None or self._checked:
            return
        first = None
        for counter in sorted(self._files):
            file = self._files[counter]
            size = check_image(file)
            if first is None:
                first = size
            elif size is not None and first is not None and size != first:
                raise InputError(file, f"image is {size[0]}x{size[1]}, the folder's first "
                                       f"frame {first[0]}x{first[1]}")
        self._checked = True

    def first_frame(self) -> np.ndarray:
        """The first frame, decoded (checks that the video really decodes)."""
        return next(iter(self.read([0])))[1]

    def frame_size(self) -> tuple[int, int]:
        """``(W, H)`` of the first decoded frame (an image folder's every frame checked first:
        :meth:`check_frames`)."""
        self.check_frames()
        image = self.first_frame()
        return int(image.shape[1]), int(image.shape[0])


def _cv_message(exc: Exception) -> str:
    lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
    return (lines[-1] if lines else type(exc).__name__)[:120]
