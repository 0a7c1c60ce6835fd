"""Frame access over synchronised camera videos, shared by every sequence layout.

:class:`SynchronisedVideos` is the mix-in of :class:`voxelmocap.io.humaneva.Sequence` and
:class:`voxelmocap.io.project_sequence.ProjectSequence`: per camera a
:class:`~voxelmocap.io.video.VideoStream` and the 1-based video frame (``starts``) that shows
synchronised frame 1.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping

import numpy as np

from ..errors import InputError

__all__ = ["FrameViews", "FramesByCamera", "SynchronisedVideos"]


class FrameViews:
    """What a sequence offers on top of its ``frames()`` and ``rig`` (a mix-in, shared by
    :class:`SynchronisedVideos` and :class:`voxelmocap.io.working_size.AtMostSide`)."""

    def by_camera(self, frames: Iterable[int]) -> FramesByCamera:
        """Sampled frames as a mapping camera → (F, H, W[, C]) decoded when a camera is asked for."""
        return FramesByCamera(self, frames)

    def read_frame(self, frame: int) -> dict[str, np.ndarray]:
        """The images of one synchronised frame ``{camera: image}``."""
        return next(self.frames([frame]))[1]

    def camera(self, name: str):
        """One camera of the rig."""
        return self.rig[name]


class SynchronisedVideos(FrameViews):
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
        readers = {cam: self._camera_reader(cam, wanted) for cam in self.camera_names}
        for f in wanted:
            yield f, {cam: next(reader)[1] for cam, reader in readers.items()}

    def camera_frames(self, camera: str, frames: Iterable[int] | None = None
                      ) -> Iterator[tuple[int, np.ndarray]]:
        """Iterate one camera's images of synchronised frames.

        The images are those :meth:`frames` yields for ``camera`` (the same decoding steps), so
        a caller that needs one camera at a time need not hold the others.

        Parameters
        ----------
        camera : str
            One of ``camera_names``.
        frames : iterable of int, optional
            1-based synchronised frame numbers (all by default).

        Yields
        ------
        F : int
            The synchronised frame number.
        image : (H, W, 3) or (H, W) uint8 ndarray
        """
        wanted = self.check_frames(self.frame_numbers if frames is None else frames)
        yield from self._camera_reader(camera, wanted)

    def _camera_reader(self, cam: str, wanted: list[int]) -> Iterator[tuple[int, np.ndarray]]:
        """``(F, image)`` of camera ``cam`` for sorted valid frames, each checked for size."""
        size = tuple(self.rig[cam].size)
        for f, (_, image) in zip(wanted, self._streams[cam].read(
                [self.starts[cam] + f - 2 for f in wanted]), strict=True):
            if (image.shape[1], image.shape[0]) != size:
                raise InputError(self._streams[cam].path,
                                 f"frame size {image.shape[1]}x{image.shape[0]} differs from "
                                 f"the calibration's {size[0]}x{size[1]}")
            yield f, image


class FramesByCamera(Mapping):
    """Frames of a sequence per camera, decoded each time a camera's are asked for.

    ``frames[camera]`` is the (F, H, W, C) (or (F, H, W) for a grey camera) uint8 stack of the
    images :meth:`SynchronisedVideos.frames` would yield for that camera. Nothing is kept: a
    consumer that takes one camera at a time (:func:`voxelmocap.measure.background.learn_plates`)
    holds one camera's frames, not the rig's, at the price of decoding again.

    Parameters
    ----------
    sequence : SynchronisedVideos
    frames : iterable of int
        1-based synchronised frame numbers (sorted on the way in).
    """

    def __init__(self, sequence: SynchronisedVideos, frames: Iterable[int]):
        self.sequence = sequence
        #: the frame numbers, sorted
        self.numbers = sequence.check_frames(frames)

    def __getitem__(self, camera: str) -> np.ndarray:
        if camera not in self.sequence.camera_names:
            raise KeyError(camera)
        out = None
        for i, (_, image) in enumerate(self.sequence.camera_frames(camera, self.numbers)):
            if out is None:
                out = np.empty((len(self.numbers), *image.shape), image.dtype)
            out[i] = image
        return out if out is not None else np.empty((0, 0, 0, 3), np.uint8)

    def __contains__(self, camera) -> bool:
        # Mapping's own test would decode the camera's frames to answer
        return camera in self.sequence.camera_names

    def __iter__(self) -> Iterator[str]:
        return iter(self.sequence.camera_names)

    def __len__(self) -> int:
        return len(self.sequence.camera_names)

    def frames(self, indices: Iterable[int] | None = None) -> Iterator[dict[str, np.ndarray]]:
        """The images of every camera, one sampled frame at a time (``indices`` into
        :attr:`numbers`; all by default)."""
        numbers = self.numbers if indices is None else [self.numbers[i] for i in indices]
        return (images for _, images in self.sequence.frames(numbers))
