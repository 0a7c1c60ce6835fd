"""Opening a sequence whatever its layout, and the frame access every layout shares.

:func:`open_sequence` is the one door the runners and the commands use: it recognises

* the HumanEva-I layout (:mod:`voxelmocap.io.humaneva`: ``<root>/S1/Image_Data`` …), opened with
  ``subject`` and ``sequence`` as before;
* a Pose2Sim, anipose or EasyMocap project (:mod:`voxelmocap.io.project`), where ``trial`` (or
  ``sequence``, or ``subject``) names one trial and may be left out when there is only one.

Both give an object with the interface the pipeline uses: ``rig``, ``camera_names``,
``all_camera_names``, ``frames()`` / ``read_frame()``, ``frame_numbers``, ``n_frames``,
``frame_rate``, ``background_paths()`` / ``background_sets()``, ``ground_truth()``, ``body_file``,
``subject`` and ``name`` (results go to ``RUN/<subject>/<name>.*``), ``problems`` and ``notes``.

:class:`SynchronisedVideos` holds the frame access both share: per camera a
:class:`~voxelmocap.io.video.VideoStream` and the 1-based video frame (``starts``) that shows
synchronised frame 1.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from pathlib import Path

import numpy as np

from ..errors import InputError

__all__ = ["SynchronisedVideos", "detect_layout", "open_sequence"]


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


def detect_layout(path) -> str:
    """``"humaneva"``, ``"pose2sim"``, ``"anipose"`` or ``"easymocap"``: what ``path`` holds.

    Raises
    ------
    InputError
        ``path`` is not a folder, or none of the layouts is recognised (the message says what was
        looked for).
    """
    from .project import project_kind

    path = Path(path)
    if not path.is_dir():
        raise InputError(path, "data set or project folder not found")
    from .humaneva import _find_dir

    for child in path.iterdir():
        if child.is_dir() and (_find_dir(child, "Image_Data") or _find_dir(child, "Sync_Data")):
            return "humaneva"
    kind = project_kind(path)
    if kind is None:
        raise InputError(path, "no subject folders of the HumanEva-I layout (<root>/S1/"
                               "Image_Data/…) and not a Pose2Sim (calibration/ + videos/), anipose "
                               "(calibration.toml + videos-raw/) or EasyMocap (intri.yml + "
                               "extri.yml + videos/) project")
    return kind


def open_sequence(path, subject: str | None = None, sequence: str | None = None,
                  trial: str | None = None, cameras: Iterable[str] | None = None,
                  calibration=None):
    """Open one sequence of a HumanEva-layout data set or one trial of a project.

    Parameters
    ----------
    path : str or os.PathLike
        The data set root or the project folder.
    subject, sequence : str, optional
        HumanEva: both required (e.g. ``"S1"``, ``"Walking_1"``). Project: optional; either names
        the trial when ``trial`` is not given (a result's ``RUN/<trial>/<trial>.h5`` names it).
    trial : str, optional
        Project trial (default: the only one; a project with several needs it).
    cameras : iterable of str, optional
        Cameras to use (default: all).
    calibration : str or os.PathLike, optional
        Project only: the calibration file to use instead of the one found in the project.

    Returns
    -------
    voxelmocap.io.humaneva.Sequence or voxelmocap.io.project.ProjectSequence
    """
    kind = detect_layout(path)
    if kind == "humaneva":
        from .humaneva import Dataset

        if trial is not None:
            raise InputError("--trial", "a HumanEva-layout data set has subjects and sequences: "
                                        "use --subject and --sequence")
        if calibration is not None:
            raise InputError("--calibration", "a HumanEva-layout data set reads "
                                              "<Subject>/Calibration_Data")
        if not subject or not sequence:
            raise InputError(path, "a HumanEva-layout data set needs --subject and --sequence")
        return Dataset(path).sequence(subject, sequence, cameras=cameras)
    from .project import Project

    project = Project(path, calibration=calibration)
    return project.sequence(trial or sequence or subject, cameras=cameras)
