"""Opening a sequence whatever its layout, and the frame access every layout shares.

:func:`open_sequence` is the one door the runners and the commands use: it recognises

* the HumanEva-I layout (:mod:`voxelmocap.io.humaneva`: ``<root>/S1/Image_Data`` …), opened with
  ``subject`` and ``sequence`` as before;
* a Pose2Sim, anipose, EasyMocap or FreeMoCap project (:mod:`voxelmocap.io.project`), where
  ``trial`` (or ``sequence``, or ``subject``) names one trial and may be left out when there is
  only one.

Both give an object with the interface the pipeline uses: ``rig``, ``camera_names``,
``all_camera_names``, ``frames()`` / ``read_frame()``, ``frame_numbers``, ``n_frames``,
``frame_rate``, ``background_paths()`` / ``background_sets()``, ``ground_truth()``, ``body_file``,
``subject`` and ``name`` (results go to ``RUN/<subject>/<name>.*``), ``problems`` and ``notes``.

:class:`voxelmocap.io.synchronised.SynchronisedVideos` holds the frame access both share.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

from ..errors import InputError

__all__ = ["detect_layout", "open_sequence"]


def detect_layout(path) -> str:
    """``"humaneva"``, ``"pose2sim"``, ``"anipose"``, ``"easymocap"`` or ``"freemocap"``: what
    ``path`` holds.

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
                               "(calibration.toml + videos-raw/), EasyMocap (intri.yml + "
                               "extri.yml + videos/) or FreeMoCap (synchronized_videos/ + "
                               "<recording>_camera_calibration.toml) project")
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
    voxelmocap.io.humaneva.Sequence or voxelmocap.io.project_sequence.ProjectSequence
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
