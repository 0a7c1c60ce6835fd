"""FreeMoCap recording folders: where the videos and the calibration are, and in which unit.

A FreeMoCap recording is a folder holding ``synchronized_videos/`` (one video per camera, frame
by frame synchronised: ``Camera_000_synchronized.mp4`` …; a ``timestamps/`` folder beside them
holds no video) and the calibration it was processed with, ``<recording>_camera_calibration.toml``:
an aniposelib calibration TOML (``[cam_0]`` tables with ``name``, ``size``, ``matrix``,
``distortions``, ``rotation`` as a Rodrigues vector and ``translation``; ``[metadata]``) whose
camera names are the calibration recording's video stems.

Units: FreeMoCap calibrates with its ChArUco board's square size given **in millimetres**
(``charuco_square_size``), so the translations are millimetres; they are read as such
(:data:`TRANSLATION_UNITS`), never guessed from the camera spacing.

:class:`voxelmocap.io.project.Project` opens such a folder (or a folder of several recordings) as
the ``"freemocap"`` layout, one trial per recording.
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["CALIBRATION_SUFFIX", "SYNCHRONIZED_VIDEOS", "TRANSLATION_UNITS",
           "find_recording_calibration"]

#: The folder of a recording's synchronised camera videos.
SYNCHRONIZED_VIDEOS = "synchronized_videos"
#: The end of the calibration file's name that FreeMoCap writes: ``<recording>`` + this.
CALIBRATION_SUFFIX = "_camera_calibration.toml"
#: Unit of the calibration TOML's translations (the ChArUco square size is given in mm).
TRANSLATION_UNITS = "mm"


def find_recording_calibration(folder) -> tuple[Path | None, str | None]:
    """The calibration TOML of a recording folder, or why there is none.

    FreeMoCap's own rule: ``<recording>_camera_calibration.toml`` named after the folder, else the
    one ``*.toml`` whose name contains ``calibration``; several of those are ambiguous.

    Returns
    -------
    path : Path or None
        The calibration file.
    problem : str or None
        When ``path`` is None: what is missing or ambiguous (one line, for an error message).
    """
    folder = Path(folder)
    named = folder / f"{folder.name}{CALIBRATION_SUFFIX}"
    if named.is_file():
        return named, None
    candidates = sorted(p for p in folder.iterdir()
                        if p.is_file() and p.suffix.lower() == ".toml"
                        and "calibration" in p.stem.lower())
    if len(candidates) == 1:
        return candidates[0], None
    if candidates:
        return None, (f"several calibration TOMLs ({', '.join(p.name for p in candidates)}): "
                      "choose one with --calibration")
    return None, (f"no FreeMoCap calibration ({folder.name}{CALIBRATION_SUFFIX}, or a *.toml "
                  "whose name contains 'calibration') in this recording folder; give one with "
                  "--calibration")
