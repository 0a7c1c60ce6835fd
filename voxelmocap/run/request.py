"""What a ``track`` is asked to do, and what it did: :class:`TrackRequest`, :class:`TrackOutcome`.

A run needs many settings (the data, the output folder, the config, frames, cameras, seed, resume
rules, the silhouettes' source, a recorder…). They travel as one frozen value instead of a
nineteen-keyword signature: :func:`voxelmocap.run.pipeline.track_sequence` builds it from its
keywords, the pass loop and the frame loop read it.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..config import TrackConfig

__all__ = ["TrackOutcome", "TrackRequest"]


@dataclass(frozen=True)
class TrackRequest:
    """One sequence to track and how (see :func:`voxelmocap.run.pipeline.track_sequence`).

    Attributes
    ----------
    dataset_root : str or os.PathLike
        HumanEva-layout data set, or a Pose2Sim / anipose / EasyMocap project.
    subject, sequence : str or None
        E.g. ``"S1"``, ``"Walking_1"`` (for a project either may name the trial).
    out_dir : str or os.PathLike
        The run folder ``RUN``.
    config : TrackConfig
        Pipeline settings.
    frames : str or None
        ``"a:b"`` synchronised frames (default: every frame with ground truth, or every frame).
    cameras : list of str or None
        Cameras to use (default: all with sync files).
    seed : int
        Seed of the filter's random generator.
    resume, overwrite : bool
        Continue an interrupted run / replace an existing result.
    progress : bool
        Show a progress bar.
    log : callable or None
        Also receives every one-line message.
    fps : float or None
        Frame rate (Hz) of the exports; default the sequence's own.
    recorder : object or None
        Sees the last pass as it goes (``start``, ``observe``, ``__call__``).
    trial, calibration : optional
        A project's trial and a calibration file instead of its own.
    masks : path or None
        A folder of person masks per camera (the silhouettes).
    plate_from : path or None
        A previous run whose tracked body finds the background behind the person.
    cues_given : bool
        The cues were chosen (``--cues``): masks or a plate from a body do not select the
        silhouette cue.
    """

    dataset_root: object
    subject: str | None
    sequence: str | None
    out_dir: object
    config: TrackConfig = field(default_factory=TrackConfig)
    frames: str | None = None
    cameras: list | None = None
    seed: int = 0
    resume: bool = False
    overwrite: bool = False
    progress: bool = True
    log: object = None
    fps: float | None = None
    recorder: object = None
    trial: str | None = None
    calibration: object = None
    masks: object = None
    plate_from: object = None
    cues_given: bool = False

    def __post_init__(self):
        if self.config is None:
            object.__setattr__(self, "config", TrackConfig())

    def result_paths(self, seq, folder: str = "") -> tuple[Path, Path, Path]:
        """``(h5, xml, bvh)`` of ``seq`` under ``RUN/<subject>/<folder>/``."""
        # appended, not Path.with_suffix: a project's trial named "walk.2" is not "walk"
        folder = Path(self.out_dir) / seq.subject / folder
        return tuple(folder / f"{seq.name}{ext}" for ext in (".h5", ".xml", ".bvh"))


@dataclass
class TrackOutcome:
    """What :func:`voxelmocap.run.pipeline.track_sequence` produced (its last pass)."""

    result_path: Path
    xml_path: Path
    bvh_path: Path
    frames: np.ndarray
    init_method: str
    resumed_from: int  #: frames already done when the run started (0 for a fresh run)
    seconds_per_frame: float
    export_paths: list = dataclasses.field(default_factory=list)  #: TRC / C3D / CSV written
    #: frames flagged without a person (not tracked; ``config.recovery``), in this run
    absent_frames: list = dataclasses.field(default_factory=list)
    #: ``(frame, note)`` of every re-initialisation in this run
    reinitialisations: list = dataclasses.field(default_factory=list)
    #: the body this pass tracked where it saw the person, for a next pass (None when fewer
    #: than two frames saw the person); :class:`voxelmocap.pose.body_cover.TrackedBody`
    tracked: object = None
    #: frames of this pass that saw the person
    frames_with_person: int = 0
