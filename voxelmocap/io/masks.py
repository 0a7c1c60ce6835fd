"""Person masks given with a recording (``voxelmocap track --masks DIR``).

Silhouettes made by another tool (a segmentation network, a green screen, hand-corrected masks)
replace the background subtraction: the measurement carves them as they are. ``DIR`` holds one
mask video or one folder of numbered mask images per camera, named like the camera or like its
video (:func:`~voxelmocap.io.video.find_videos`' rule: ``cam01.mp4``, ``cam01/000001.png``), frame
for frame with that camera's video (mask frame ``k`` is video frame ``k``), at the video's size.
A pixel whose grey level is above 127 is the person (black and white masks, or an 8-bit
probability map thresholded at one half; a colour image is read as grey, an alpha channel is not
read). Masks are numbered by *video* frame: on the HumanEva layout, whose cameras start at
different video frames (``.ofs``), mask ``k`` still goes with video frame ``k`` (``synth
--masks``' ``Mask_Data`` is numbered by synchronised frame instead: it is the renderer's truth,
not an input for ``--masks``).

>>> masks = PersonMasks("masks", seq)           # doctest: +SKIP
>>> masks.of(1)                                  # doctest: +SKIP
[array(...), ...]                                # (H_c, W_c) bool per camera, in rig order
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from pathlib import Path

import numpy as np

from ..errors import InputError
from .video import VideoStream, find_videos

__all__ = ["MASK_LEVEL", "PersonMasks"]

#: A mask pixel above this grey level is the person.
MASK_LEVEL = 127


class PersonMasks:
    """The person masks of one sequence's cameras, read frame for frame with its videos.

    Parameters
    ----------
    folder : path-like
        The masks folder (see the module's docstring).
    seq : sequence
        The opened sequence (``camera_names``, ``starts``, ``n_frames``, ``rig`` and, for a
        project, ``video_path``). Of a sequence measured at a working size
        (:class:`~voxelmocap.io.working_size.AtMostSide`) the masks are checked against its
        videos' size and shrunk with its images.

    Attributes
    ----------
    paths : dict of str to pathlib.Path
        The mask video or image folder of each camera.

    Raises
    ------
    InputError
        The folder is missing; a camera has no masks; a camera's masks are fewer than the frames
        its video contributes, or of another size than its video.
    """

    def __init__(self, folder, seq):
        folder = Path(folder)
        if not folder.is_dir():
            raise InputError(folder, "masks folder not found")
        listed = find_videos(folder)
        found = {name.lower(): path for name, path in listed.items()}
        # masks come at the videos' size; a working size shrinks them as it does the images
        self._shrink = getattr(seq, "shrink_mask", None)
        seq = getattr(seq, "native", seq)
        self.camera_names = list(seq.camera_names)
        self.rig = seq.rig
        self.starts = {c: int(seq.starts[c]) for c in self.camera_names}
        self.n_frames = int(seq.n_frames)
        self.paths: dict[str, Path] = {}
        self._streams: dict[str, VideoStream] = {}
        for cam in self.camera_names:
            names = [cam]
            video_path = getattr(seq, "video_path", None)
            if video_path is not None:
                video = Path(video_path(cam))
                names += [video.stem, video.name]
            path = next((found[n.lower()] for n in names if n.lower() in found), None)
            if path is None:
                raise InputError(folder, f"no masks for camera {cam} (a video or a folder of "
                                         f"numbered images named {cam}); masks here: "
                                         f"{', '.join(listed) or 'none'}")
            stream = VideoStream(path, gray=True)
            need = self.starts[cam] + self.n_frames - 1
            if stream.n_frames < need:
                raise InputError(path, f"{stream.n_frames} mask frames, the camera's video needs "
                                       f"{need}")
            gaps = stream.missing_frames(need)
            if gaps:
                raise InputError(path, f"no mask image for video frame {gaps[0]} ({len(gaps)} "
                                       "missing): every frame needs one (an empty mask where "
                                       "there is no person)")
            w, h = self.rig[cam].size
            if stream.frame_size() != (w, h):
                raise InputError(path, f"masks are {stream.frame_size()[0]}x"
                                       f"{stream.frame_size()[1]}, camera {cam}'s video is {w}x{h}")
            self.paths[cam] = path
            self._streams[cam] = stream
        self._readers: Iterator | None = None
        self._next: int | None = None

    def read(self, frames: Iterable[int]) -> Iterator[tuple[int, list[np.ndarray]]]:
        """``(frame, masks)`` for sorted 1-based synchronised ``frames``; masks in rig order,
        each ``(H_c, W_c)`` bool."""
        frames = [int(f) for f in frames]
        bad = [f for f in frames if not 1 <= f <= self.n_frames]
        if bad:
            raise InputError("masks", f"frame {bad[0]} is outside 1..{self.n_frames}")
        readers = {c: self._streams[c].read([self.starts[c] + f - 2 for f in frames])
                   for c in self.camera_names}
        for f in frames:
            masks = [next(readers[c])[1] > MASK_LEVEL for c in self.camera_names]
            if self._shrink is not None:
                masks = [self._shrink(c, m) for c, m in zip(self.camera_names, masks, strict=True)]
            yield f, masks

    def of(self, frame: int) -> list[np.ndarray]:
        """The masks of one synchronised frame (rig order). Frames asked for in increasing
        order, with gaps or not, are decoded forward from the open videos (as the sequence's
        own frames are: seeking a compressed video may land a frame off); going back reopens
        them."""
        frame = int(frame)
        if not 1 <= frame <= self.n_frames:
            raise InputError("masks", f"frame {frame} is outside 1..{self.n_frames}")
        if self._readers is None or frame < self._next:
            self._readers, self._next = self.read(range(frame, self.n_frames + 1)), frame
        while self._next < frame:                # decode forward over the frames skipped
            next(self._readers)
            self._next += 1
        self._next = frame + 1
        return next(self._readers)[1]
