"""A sequence seen at a working resolution: every image at most so many pixels on a side.

The measurement's cost grows with the pixels (background subtraction, GrabCut on never-seen
pixels, the plate's medians), and its pixel-sized settings (clean-up radii, smallest blob) mean
more or less of the person at another resolution. :class:`AtMostSide` shrinks every image of a
sequence whose longer side exceeds ``max_side`` once, where it is decoded, with
``cv2.INTER_AREA``, and gives its cameras to match: the same recording at 4K, 1080p or 960 px
is then measured at one resolution. Smaller images are left as they are.

A camera imaged at ``(W', H')`` instead of ``(W, H)`` keeps its pixel centres: OpenCV's resize
maps the image's edges onto each other, so ``u' = (u + ½)·W'/W − ½`` per axis
(:meth:`voxelmocap.camera.Camera.resized`).
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator

import cv2
import numpy as np

from ..camera import Rig, shrunk_size
from .synchronised import FrameViews

__all__ = ["AtMostSide", "at_most_side", "shrunk_size"]


def at_most_side(seq, max_side: int | None):
    """``seq`` itself when ``max_side`` is unset (0 / None) or no camera is larger, else
    :class:`AtMostSide` of it."""
    if not max_side or all(max(cam.size) <= max_side for cam in seq.rig):
        return seq
    return AtMostSide(seq, int(max_side))


class AtMostSide(FrameViews):
    """A sequence whose images (and cameras) are shrunk to at most ``max_side`` pixels a side.

    Everything but the images and the cameras is the wrapped sequence's (its name, frames,
    ground truth, notes …); ``by_camera``, ``read_frame`` and ``camera`` come from
    :class:`~voxelmocap.io.synchronised.FrameViews` over the shrunk ``frames`` and ``rig``.

    Parameters
    ----------
    sequence : SynchronisedVideos
        A HumanEva sequence or a project's trial (``voxelmocap.io.sequence.open_sequence``).
    max_side : int
        Pixels on the longer side, at most.
    """

    def __init__(self, sequence, max_side: int):
        self.native = sequence
        self.max_side = int(max_side)
        self.sizes = {cam.name: shrunk_size(cam.size, self.max_side) for cam in sequence.rig}
        self.rig = Rig(cam.resized(self.sizes[cam.name]) for cam in sequence.rig)

    def __getattr__(self, name):
        # only reached for what this class does not define: the sequence's own attributes
        return getattr(self.native, name)

    def shrink(self, camera: str, image: np.ndarray) -> np.ndarray:
        """One image of ``camera`` at its working size, ``(H', W'[, C])`` uint8."""
        size = self.sizes[camera]
        if (image.shape[1], image.shape[0]) == size:
            return image
        return cv2.resize(image, size, interpolation=cv2.INTER_AREA)

    def shrink_mask(self, camera: str, mask: np.ndarray) -> np.ndarray:
        """A person mask of ``camera`` (native size, bool) at its working size: a working pixel
        is the person's when most of the native pixels it covers are."""
        size = self.sizes[camera]
        if (mask.shape[1], mask.shape[0]) == size:
            return mask
        share = cv2.resize(mask.astype(np.float32), size, interpolation=cv2.INTER_AREA)
        return share > 0.5

    def frames(self, frames: Iterable[int] | None = None
               ) -> Iterator[tuple[int, dict[str, np.ndarray]]]:
        """As :meth:`SynchronisedVideos.frames`, every image at its working size."""
        for f, images in self.native.frames(frames):
            yield f, {cam: self.shrink(cam, image) for cam, image in images.items()}

    def camera_frames(self, camera: str, frames: Iterable[int] | None = None
                      ) -> Iterator[tuple[int, np.ndarray]]:
        """As :meth:`SynchronisedVideos.camera_frames`, at the working size."""
        for f, image in self.native.camera_frames(camera, frames):
            yield f, self.shrink(camera, image)

    def background_sets(self, camera: str, *, max_frames: int | None = None
                        ) -> list[list[np.ndarray]]:
        """Per background video of ``camera``, its first ``max_frames`` frames at the working
        size (a list each)."""
        return [[self.shrink(camera, image) for image in frames]
                for frames in self.native.background_sets(camera, max_frames=max_frames)]

    def background_frames(self, camera: str, *, max_frames: int | None = None
                          ) -> Iterator[np.ndarray]:
        """Frames of all background videos of ``camera``, one after the other, at the working
        size."""
        for image in self.native.background_frames(camera, max_frames=max_frames):
            yield self.shrink(camera, image)

    @property
    def summary(self) -> str:
        """One line: the working size and the cameras it shrinks."""
        native = {cam.name: tuple(cam.size) for cam in self.native.rig}
        shrunk = ", ".join(f"{c} {native[c][0]}x{native[c][1]} → {w}x{h}"
                           for c, (w, h) in self.sizes.items() if native[c] != (w, h))
        return (f"images measured at most {self.max_side} px a side "
                f"([measurement] max_image_side): {shrunk}")

    def describe(self) -> list[str]:
        """The wrapped sequence's description, and the working size."""
        return [*self.native.describe(), self.summary]

    def __repr__(self) -> str:
        return f"AtMostSide({self.native!r}, {self.max_side})"
