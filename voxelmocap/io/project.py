"""Pose2Sim, anipose and EasyMocap projects opened as they are (no conversion).

Layouts recognised (``docs/projects.md`` says more)::

    Pose2Sim   <project>/calibration/<file>.toml | <file>.qca.txt | intri.yml + extri.yml
               <project>/videos/<cam>.mp4 … (or image folders)            one trial: <project>
               <project>/<trial>/videos/…  (calibration/ in the trial or the project)  several
    anipose    <session>/calibration/calibration.toml (or <session>/calibration.toml)
               <session>/videos-raw/<trial>-cam<A>.mp4 …  (trials by the config's cam_regex)
               or <project>/<session>/… for several sessions
               (``nesting`` in the root's config.toml: how deep the sessions lie)
    EasyMocap  <project>/intri.yml, extri.yml, videos/<cam>.mp4 (or images/<cam>/ folders)
    FreeMoCap  <recording>/synchronized_videos/<cam>.mp4 …,
               <recording>/<recording>_camera_calibration.toml (mm)     one trial per recording

Every trial is one :class:`ProjectSequence`: its videos are assumed synchronised frame by frame
(frame k of every video is the same instant, as in Pose2Sim once synchronised), frame rate from
the videos, no ground truth and no body file. Results of a trial go to ``RUN/<trial>/<trial>.*``.
A trial's settings come from its configuration files merged from the session down
(:mod:`voxelmocap.io.project_config`: Pose2Sim's frame range and frame rate are honoured).

What is assumed is said in the sequence's ``notes`` (``voxelmocap info`` prints them):

* camera names: a video belongs to the calibration camera of the same name (case, separators and
  leading zeros ignored: ``cam01.mp4`` ↔ ``cam_1``), or whose name it contains as a whole word
  (``cam01_img/`` ↔ ``cam01``); when no name matches at all and there are as many videos as
  cameras, they are paired in natural order (what Pose2Sim does);
* image size: a video a few columns or rows (≤ 16, ``project_checks.SIZE_TOLERANCE``) narrower
  or wider than the calibration is taken as the calibrated image cropped or padded on the right /
  bottom (the principal point is kept); a larger difference is refused;
* calibration units: see :mod:`voxelmocap.io.calibration_files`;
* world frame: the tracker assumes +Z up with the floor at Z = 0 (mm); when the cameras' mean up
  direction is far from +Z, or the cameras stand near Z = 0, a note says so
  (:func:`~voxelmocap.io.project_checks.world_frame_notes`); nothing is re-expressed.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path

from ..camera import Rig
from ..errors import InputError
from ._regex import bounded_search, user_regex
from .calibration_files import calibration_format, find_calibration, read_calibration_file
from .freemocap import SYNCHRONIZED_VIDEOS, find_recording_calibration
from .project_config import (
    TrialConfig,
    excluded_from_batch,
    frame_rate_setting,
    nesting_setting,
    trial_config,
)
from .project_sequence import ProjectSequence
from .video import find_videos, natural_key

__all__ = ["Project", "ProjectSequence", "Trial", "project_kind"]

#: anipose's default ``[triangulation] cam_regex``.
ANIPOSE_CAM_REGEX = r"-cam([A-Z])"
_MAX_DEPTH = 2


def _child_dir(parent: Path, *names: str) -> Path | None:
    """A child folder named like one of ``names`` (case-insensitive), or None."""
    if not parent.is_dir():
        return None
    wanted = [n.lower() for n in names]
    for name in names:
        if (parent / name).is_dir():
            return parent / name
    for child in sorted(parent.iterdir()):
        if child.is_dir() and child.name.lower() in wanted:
            return child
    return None


def _child_file(parent: Path, *names: str) -> Path | None:
    if not parent.is_dir():
        return None
    wanted = [n.lower() for n in names]
    for child in sorted(parent.iterdir()):
        if child.is_file() and child.name.lower() in wanted:
            return child
    return None


def _folders_with(root: Path, name: str, depth: int = _MAX_DEPTH) -> list[Path]:
    """``root`` if it has a child folder ``name``, else its descendants (≤ depth) that have one."""
    if _child_dir(root, name):
        return [root]
    out = []
    if depth <= 0:
        return out
    for child in sorted(root.iterdir(), key=lambda p: natural_key(p.name)):
        if child.is_dir() and not child.name.startswith(".") and child.name.lower() not in (
                _DATA_FOLDERS):
            out.extend(_folders_with(child, name, depth - 1))
    return out


#: Folders of a trial's data, never searched for trials.
_DATA_FOLDERS = ("calibration", "videos", "videos-raw", SYNCHRONIZED_VIDEOS)


def _anipose_sessions(root: Path) -> list[Path]:
    """anipose's sessions: folders with ``videos-raw/``, ``nesting`` levels below ``root``.

    anipose processes every folder exactly ``nesting`` levels down (``nesting = 0``: the root;
    negative: every folder at any depth); without a ``nesting`` setting, the root or its
    descendants up to two levels down.
    """
    nesting = nesting_setting(root)
    if nesting is None:
        return _folders_with(root, "videos-raw")
    level, found = [root], []
    depth = 0
    while level:
        if nesting < 0 or depth == nesting:
            found.extend(f for f in level if _child_dir(f, "videos-raw"))
        if 0 <= nesting <= depth:
            break
        level = [child for folder in level
                 for child in sorted(folder.iterdir(), key=lambda p: natural_key(p.name))
                 if child.is_dir() and not child.name.startswith(".")
                 and child.name.lower() not in _DATA_FOLDERS]
        depth += 1
    return found


def project_kind(path) -> str | None:
    """``"easymocap"``, ``"anipose"``, ``"freemocap"``, ``"pose2sim"`` or None for a folder."""
    path = Path(path)
    if _child_file(path, "intri.yml", "intri.yaml") and _child_file(path, "extri.yml",
                                                                     "extri.yaml"):
        return "easymocap"
    if _anipose_sessions(path):
        return "anipose"
    if _folders_with(path, SYNCHRONIZED_VIDEOS):
        return "freemocap"
    if _folders_with(path, "videos"):
        return "pose2sim"
    return None


# ---------------------------------------------------------------------- trials
@dataclass
class Trial:
    """One trial of a project: its videos and the calibration file that applies."""

    name: str
    folder: Path
    video_dir: Path
    videos: dict[str, Path]  #: camera label → video file or image folder
    calibration: Path | None
    background_dir: Path | None = None
    notes: list[str] = field(default_factory=list)
    #: why ``calibration`` is None, when the layout says (FreeMoCap: none, or several)
    calibration_problem: str | None = None


def _nearest_calibration(folder: Path, top: Path, kind: str) -> Path | None:
    """The calibration file nearest to ``folder``, looking up to ``top``'s parent.

    At each level: anipose's ``calibration.toml``, then a ``calibration/`` folder (whose file is
    :func:`find_calibration`'s; a ``calibration/`` folder without one is an error naming it).
    """
    stop = top.parent
    current = folder
    while True:
        if kind == "anipose" and _child_file(current, "calibration.toml"):
            return _child_file(current, "calibration.toml")
        cal = _child_dir(current, "calibration")
        if cal is not None:
            if kind == "anipose" and _child_file(cal, "calibration.toml"):
                return _child_file(cal, "calibration.toml")
            return find_calibration(cal)
        if current == stop or current.parent == current:
            return None
        current = current.parent


def _output_name(name: str, where, what: str) -> str:
    """``name`` as it names the output files ``RUN/<name>/<name>.*``, or :class:`InputError`
    naming ``where`` when it cannot (empty, dots only, a path separator, hidden, not UTF-8)."""
    from ..errors import printable

    if (not name.strip(".") or any(c in name for c in "/\\\0") or name.startswith(".")
            or printable(name) != name):
        raise InputError(where, f"{what} '{printable(name)}' cannot name the output files "
                                "(RUN/<trial>/<trial>.h5): rename it")
    return name


def _video_map(folder: Path) -> dict[str, Path]:
    videos = find_videos(folder)
    if not videos:
        raise InputError(folder, "no video files (mp4, avi, mov …) or numbered-image folders here")
    return videos


class Project:
    """A Pose2Sim, anipose or EasyMocap project folder.

    Parameters
    ----------
    root : str or os.PathLike
        The project (or session, or trial) folder.
    calibration : str or os.PathLike, optional
        A calibration file to use for every trial instead of the one found in the project.

    Attributes
    ----------
    kind : str
        ``"pose2sim"``, ``"anipose"``, ``"easymocap"`` or ``"freemocap"``.
    trials : dict of str to Trial
        The trials, in natural order.
    """

    def __init__(self, root, calibration=None):
        # Absolute and without "." or "..": trials are named after folders, and "." or ".."
        # would name output files outside the run folder.
        self.root = Path(os.path.normpath(Path(root).absolute()))
        kind = project_kind(self.root)
        if kind is None:
            raise InputError(self.root, "not a Pose2Sim, anipose, EasyMocap or FreeMoCap project "
                                        "(no videos/, videos-raw/, synchronized_videos/ or "
                                        "intri.yml + extri.yml)")
        self.kind = kind
        self.calibration_override = None if calibration is None else Path(calibration)
        if self.calibration_override is not None:
            if not self.calibration_override.is_file():
                raise InputError(self.calibration_override, "calibration file not found")
            if calibration_format(self.calibration_override) is None:
                raise InputError(self.calibration_override, "unknown calibration format "
                                 "(expected a Pose2Sim/anipose .toml, a Qualisys .qca.txt or "
                                 "EasyMocap intri.yml + extri.yml)")
        self._configs: dict[Path, TrialConfig] = {}
        self.trials = self._discover()
        if not self.trials:
            raise InputError(self.root, f"no trial found in this {kind} project")
        self._rigs: dict[tuple, tuple[Rig, set[str], list[str]]] = {}

    # ------------------------------------------------------------------ discovery
    def _discover(self) -> dict[str, Trial]:
        trials: list[Trial] = []
        if self.kind == "easymocap":
            vdir = _child_dir(self.root, "videos") or _child_dir(self.root, "images")
            if vdir is None:
                raise InputError(self.root, "EasyMocap project without a videos/ or images/ folder")
            trials.append(Trial(self.root.name, self.root, vdir, _video_map(vdir),
                                _child_file(self.root, "intri.yml", "intri.yaml"),
                                _child_dir(self.root, "background", "backgrounds")))
        elif self.kind == "pose2sim":
            for folder in _folders_with(self.root, "videos"):
                vdir = _child_dir(folder, "videos")
                trials.append(Trial(folder.name, folder, vdir, _video_map(vdir),
                                    self._calibration_for(folder),
                                    _child_dir(folder, "background", "backgrounds")
                                    or _child_dir(self.root, "background", "backgrounds")))
        elif self.kind == "freemocap":
            for folder in _folders_with(self.root, SYNCHRONIZED_VIDEOS):
                vdir = _child_dir(folder, SYNCHRONIZED_VIDEOS)
                calibration, problem = self.calibration_override, None
                if calibration is None:
                    calibration, problem = find_recording_calibration(folder)
                trials.append(Trial(folder.name, folder, vdir, _video_map(vdir), calibration,
                                    _child_dir(folder, "background", "backgrounds"),
                                    calibration_problem=problem))
        else:
            for session in _anipose_sessions(self.root):
                trials.extend(self._anipose_trials(session))
        names = [t.name for t in trials]
        for t in trials:
            if names.count(t.name) > 1:  # the same name in two folders: prefix the folder's path
                prefix = "_".join(t.folder.relative_to(self.root).parts)
                if prefix:
                    t.name = prefix if t.name == t.folder.name else f"{prefix}_{t.name}"
        for t in trials:
            _output_name(t.name, t.video_dir if self.kind == "anipose" else t.folder,
                         "trial name")
        return {t.name: t for t in trials}

    def _calibration_for(self, folder: Path) -> Path | None:
        if self.calibration_override is not None:
            return self.calibration_override
        return _nearest_calibration(folder, self.root, self.kind)

    def config(self, folder: Path) -> TrialConfig:
        """The configuration files of a trial's (or session's) folder, merged from the top.

        A Pose2Sim trial opened on its own also inherits its parent folder's ``Config.toml``,
        as in Pose2Sim (:mod:`voxelmocap.io.project_config`).
        """
        folder = Path(os.path.normpath(Path(folder).absolute()))  # as the root is
        if folder not in self._configs:
            parent = self.kind == "pose2sim" and _child_dir(self.root, "videos") is not None
            self._configs[folder] = trial_config(folder, self.root, include_parent=parent)
        return self._configs[folder]

    def _anipose_trials(self, session: Path) -> list[Trial]:
        vdir = _child_dir(session, "videos-raw")
        videos = _video_map(vdir)
        config = self.config(session)
        regex_text = config.get("triangulation", "cam_regex", default=ANIPOSE_CAM_REGEX)
        source = config.source("triangulation", "cam_regex") if config.files else "config.toml"
        regex = user_regex(regex_text, source)
        groups: dict[str, dict[str, Path]] = {}
        for stem, path in videos.items():
            m = bounded_search(regex, stem, source)
            if m is None or not m.groups():
                continue
            trial = (stem[:m.start()] + stem[m.end():]).strip("-_ ") or session.name
            groups.setdefault(trial, {})[m.group(1)] = path
        background = _child_dir(session, "background", "backgrounds")
        calibration = self._calibration_for(session)
        if not groups:  # no name follows cam_regex: the folder is one trial, a video per camera
            return [Trial(session.name, session, vdir, videos, calibration, background)]
        return [Trial(name, session, vdir, dict(sorted(cams.items())), calibration, background)
                for name, cams in sorted(groups.items(), key=lambda kv: natural_key(kv[0]))]

    # ------------------------------------------------------------------ access
    def trial(self, name: str | None = None) -> Trial:
        """The trial called ``name`` (case-insensitive), or the only one."""
        if name is None:
            if len(self.trials) > 1:
                raise InputError(self.root, f"{len(self.trials)} trials ({', '.join(self.trials)}): "
                                            "choose one with --trial")
            return next(iter(self.trials.values()))
        for key, trial in self.trials.items():
            if key.lower() == name.lower():
                return trial
        raise InputError(self.root, f"unknown trial {name!r} (have {', '.join(self.trials)})")

    def units(self) -> str:
        """Unit of TOML translations: Pose2Sim writes metres, FreeMoCap millimetres
        (:data:`voxelmocap.io.freemocap.TRANSLATION_UNITS`); anipose's is its board's (auto)."""
        return {"pose2sim": "m", "freemocap": "mm"}.get(self.kind, "auto")

    def calibration(self, trial: Trial) -> tuple[Rig, set[str], list[str]]:
        """The rig (mm), its unsized cameras and the notes of reading a trial's calibration."""
        if trial.calibration is None:
            raise InputError(trial.folder, trial.calibration_problem or
                             "no calibration found (a calibration/ folder with a .toml, "
                             ".qca.txt or intri.yml + extri.yml)")
        binning = 1.0
        if calibration_format(trial.calibration) == "qualisys":
            config = self.config(trial.folder)
            binning = config.get("calibration", "convert", "qualisys", "binning_factor",
                                 default=1)
            if not isinstance(binning, (int, float)) or isinstance(binning, bool) \
                    or not (math.isfinite(binning) and 0 < binning <= 64):
                raise InputError(config.source("calibration", "convert", "qualisys",
                                               "binning_factor"),
                                 "[calibration.convert.qualisys] binning_factor must be a "
                                 f"number in (0, 64], got {binning!r:.40}")
        key = (trial.calibration, binning)
        if key not in self._rigs:
            notes: list[str] = []
            rig, unsized = read_calibration_file(trial.calibration, units=self.units(),
                                                 binning_factor=binning, notes=notes)
            if self.kind == "freemocap":
                notes.append(f"{trial.calibration.name}: FreeMoCap calibration, translations "
                             "read as millimetres")
            self._rigs[key] = (rig, unsized, notes)
        return self._rigs[key]

    def frame_rate_setting(self, trial: Trial | None = None) -> float | None:
        """Pose2Sim's ``[project] frame_rate`` of a trial (default: the project folder's) when it
        is a number."""
        return frame_rate_setting(self.config(self.root if trial is None else trial.folder))

    def batch_trials(self) -> tuple[list[Trial], list[str]]:
        """The trials ``track --all`` tracks, and the names of those it leaves out.

        Left out: the trials Pose2Sim's ``[project] exclude_from_batch`` names. A trial whose
        configuration cannot be read is kept: tracking it reports why.
        """
        kept, left_out = [], []
        for trial in self.trials.values():
            try:
                excluded = excluded_from_batch(self.config(trial.folder), trial.folder,
                                               self.root)
            except InputError:
                excluded = False
            if excluded:
                left_out.append(trial.name)
            else:
                kept.append(trial)
        return kept, left_out

    def sequence(self, trial: str | None = None, cameras=None) -> ProjectSequence:
        """Open one trial (see :class:`ProjectSequence`)."""
        return ProjectSequence(self, self.trial(trial), cameras)
