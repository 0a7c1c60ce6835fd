"""Frame access over synchronised camera videos, shared by every sequence layout.

:class:`SynchronisedVideos` is the mix-in of :class:`voxelmocap.io.humaneva.Sequence` and
:class:`voxelmocap.io.project_sequence.ProjectSequence`: per camera a
:class:`~voxelmocap.io.video.VideoStream` and the 1-based video frame (``starts``) that shows
synchronised frame 1.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator

import numpy as np

from ..errors import InputError

__all__ = ["SynchronisedVideos"]


class SynchronisedVideos:
    """Frame access over synchronised camera videos (a mix-in).

    A subclass provides ``camera_names`` (list of str), ``starts`` (dict camera → 1-based video
    frame of synchronised frame 1), ``_streams`` (dict camera → VideoStream), ``rig``,
    ``subject`` and ``name``.
    """

    camera_names: list[str]
    starts: dict[str, int]
    subject: str
    name: str

    def video_frame_counts(self) -> dict[str, int]:
        """Number of video frames per camera."""
        return {cam: s.n_frames for cam, s in self._streams.items()}

    @property
    def n_frames(self) -> int:
        """Synchronised frames available in every camera: ``min_I(N_I − starts[I] + 1)``.

        (The HumanEva toolkit's ``n_frames`` returns ``N_I − starts[I]``, one less, which drops
        the last frame a video does hold; here every decodable frame counts.)
        """
        counts = self.video_frame_counts()
        return max(0, min(counts[c] - self.starts[c] + 1 for c in self.camera_names))

    @property
    def frame_numbers(self) -> np.ndarray:
        """(n_frames,) 1-based synchronised frame numbers."""
        return np.arange(1, self.n_frames + 1)

    def check_frames(self, frames: Iterable[int]) -> list[int]:
        """Validate 1-based synchronised frame numbers; returns them sorted."""
        frames = sorted(int(f) for f in frames)
        bad = [f for f in frames if not 1 <= f <= self.n_frames]
        if bad:
            raise InputError(f"{self.subject}/{self.name}",
                             f"frame {bad[0]} is outside the synchronised range 1..{self.n_frames}")
        return frames

    def frames(self, frames: Iterable[int] | None = None
               ) -> Iterator[tuple[int, dict[str, np.ndarray]]]:
        """Iterate synchronised frames.

        Parameters
        ----------
        frames : iterable of int, optional
            1-based synchronised frame numbers (all by default).

        Yields
        ------
        F : int
            The synchronised frame number.
        images : dict of str to ndarray
            Per camera: ``(H, W, 3)`` uint8 BGR for colour cameras, ``(H, W)`` uint8 for grey ones.
        """
        wanted = self.check_frames(self.frame_numbers if frames is None else frames)
        readers = {cam: self._streams[cam].read([self.starts[cam] + f - 2 for f in wanted])
                   for cam in self.camera_names}
        sizes = {cam: tuple(self.rig[cam].size) for cam in self.camera_names}
        for f in wanted:
            images = {}
            for cam, reader in readers.items():
                _, image = next(reader)
                if (image.shape[1], image.shape[0]) != sizes[cam]:
                    raise InputError(self._streams[cam].path,
                                     f"frame size {image.shape[1]}x{image.shape[0]} differs from "
                                     f"the calibration's {sizes[cam][0]}x{sizes[cam][1]}")
                images[cam] = image
            yield f, images

    def read_frame(self, frame: int) -> dict[str, np.ndarray]:
        """The images of one synchronised frame ``{camera: image}``."""
        return next(self.frames([frame]))[1]

    def camera(self, name: str):
        """One camera of the rig."""
        return self.rig[name]
