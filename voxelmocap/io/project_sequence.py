"""One trial of a project as a sequence: its cameras, videos, frame numbers and frame rate.

:class:`ProjectSequence` is what :meth:`voxelmocap.io.project.Project.sequence` opens: the
interface the pipeline uses (:mod:`.sequence`), over videos assumed synchronised frame by frame.
How a project is laid out and where a trial's files are is :mod:`.project`'s.
"""

from __future__ import annotations

from functools import cached_property
from pathlib import Path

import numpy as np

from ..camera import Rig
from ..errors import InputError
from .project_checks import match_cameras, reconcile_size, world_frame_notes
from .project_config import frame_range_setting, frame_rate_setting
from .synchronised import SynchronisedVideos
from .video import VideoStream, find_videos, natural_key

__all__ = ["DEFAULT_FRAME_RATE", "ProjectSequence"]

#: Frame rate assumed for image folders when nothing states one (Hz).
DEFAULT_FRAME_RATE = 30.0


class ProjectSequence(SynchronisedVideos):
    """One trial of a project, with the interface the pipeline uses (see :mod:`.sequence`).

    Parameters
    ----------
    project : voxelmocap.io.project.Project
    trial : voxelmocap.io.project.Trial
    cameras : iterable of str, optional
        Calibration camera names to use (case-insensitive); default every camera.
    """

    def __init__(self, project, trial, cameras=None):
        self.project = project
        self.trial_info = trial
        self.dataset = project
        self.subject = trial.name
        self.name = trial.name
        self.action, self.trial = trial.name, ""
        self.problems: list[str] = []
        # read first: a bad setting is reported before the calibration is
        self.config = project.config(trial.folder)
        self._frame_range = frame_range_setting(self.config)
        self._rate_setting = frame_rate_setting(self.config)
        rig, unsized, cal_notes = project.calibration(trial)
        self.notes: list[str] = [*cal_notes, *trial.notes]
        if self.config.get("project", "multi_person") is True:
            self.notes.append(f"{self.config.source('project', 'multi_person')} sets "
                              "multi_person = true: voxelmocap tracks one person (everyone in "
                              "view is carved into the same voxels)")
        self._full_rig, self._unsized = rig, unsized
        pairs, cams_left, vids_left = match_cameras(rig.names, list(trial.videos),
                                                    notes=self.notes)
        if cameras is not None:
            wanted = [c.strip() for c in cameras if c.strip()]
            if not wanted:
                raise InputError("--cameras", "no camera names given")
            selected = []
            for c in wanted:
                try:
                    cam = rig[c].name
                except KeyError:
                    raise InputError("--cameras", f"unknown camera {c!r} (the calibration has "
                                                  f"{', '.join(rig.names)})") from None
                if cam not in pairs:
                    raise InputError(trial.video_dir, f"no video of camera {cam} here (videos: "
                                                      f"{', '.join(trial.videos)})")
                selected.append(cam)
            names = [n for n in rig.names if n in selected]
        else:
            if cams_left:
                raise InputError(trial.video_dir, f"calibration camera {cams_left[0]} "
                                 f"({trial.calibration.name}) has no video here (videos: "
                                 f"{', '.join(trial.videos)}); use --cameras to leave it out")
            if vids_left:
                raise InputError(trial.videos[vids_left[0]], "no camera of the calibration "
                                 f"{trial.calibration} matches this video (cameras: "
                                 f"{', '.join(rig.names)})")
            names = list(rig.names)
        self.camera_names: list[str] = names
        self.all_camera_names: list[str] = [n for n in rig.names if n in pairs]
        self._video_paths = {n: trial.videos[pairs[n]] for n in names}
        self.starts = {n: 1 for n in names}

    # ------------------------------------------------------------------ videos and calibration
    def video_path(self, camera: str) -> Path:
        """The camera's video file or image folder."""
        return self._video_paths[self.rig[camera].name]

    @cached_property
    def _streams(self) -> dict[str, VideoStream]:
        return {cam: VideoStream(self._video_paths[cam], gray=False) for cam in self.camera_names}

    @cached_property
    def rig(self) -> Rig:
        """The cameras used, each with its video's image size (``project_checks.reconcile_size``)."""
        cameras = []
        for name in self.camera_names:
            stream = self._streams[name]
            cameras.append(reconcile_size(self._full_rig[name], stream.frame_size(), stream.path,
                                          unsized=name in self._unsized, notes=self.notes))
        self.notes.extend(world_frame_notes(cameras))
        counts = self.video_frame_counts()
        if len(set(counts.values())) > 1:
            self.notes.append("the videos have different lengths ("
                              + ", ".join(f"{c} {n}" for c, n in counts.items())
                              + f"): taken as starting together, the first {min(counts.values())} "
                                "frames are used")
        _ = self.frame_rate  # its assumptions are notes too: all of them exist once the rig does
        _ = self.frame_numbers
        return Rig(cameras)

    @cached_property
    def frame_numbers(self) -> np.ndarray:
        """(F,) 1-based synchronised frame numbers: every frame, or Pose2Sim's ``frame_range``.

        ``[project] frame_range = [start, end]`` counts video frames from 0 and leaves ``end``
        out (Pose2Sim's ``range(start, end)``): frames ``start + 1 … end`` here. An ``end``
        beyond the videos stops at their last frame, as Pose2Sim's reading does (noted).

        Raises
        ------
        InputError
            The range starts after the videos' last frame (naming the file that sets it).
        """
        n = self.n_frames
        if self._frame_range is None:
            return np.arange(1, n + 1)
        start, end = self._frame_range
        source = self.config.source("project", "frame_range")
        if start >= n:
            raise InputError(source, f"[project] frame_range [{start}, {end}] starts after the "
                                     f"{n} synchronised frames of {self.name}")
        last = min(end, n)
        self.notes.append(f"frames {start + 1}..{last} of {n} from {source} [project] frame_range "
                          f"[{start}, {end}] (video frames counted from 0, end excluded)"
                          + (f"; the videos end at frame {n}" if end > n else ""))
        return np.arange(start + 1, last + 1)

    def check_video_sizes(self) -> None:
        """Decode each camera's first frame and reconcile its size with the calibration's."""
        _ = self.rig

    #: True when nothing stated the frame rate and :data:`DEFAULT_FRAME_RATE` was assumed (set
    #: by :attr:`frame_rate`): the tracker then keeps its per-frame noise as configured
    frame_rate_assumed = False

    @cached_property
    def frame_rate(self) -> float:
        """Frames per second: Pose2Sim's ``[project] frame_rate`` when it is a number (as in
        Pose2Sim, whatever the videos state), else the videos' (they must agree), else 30 Hz
        (:attr:`frame_rate_assumed`)."""
        rates = {cam: s.fps for cam, s in self._streams.items() if s.fps is not None}
        video_rate = None
        if rates:
            # The rate most videos share; the odd one out is the one named.
            video_rate = max(rates.values(), key=lambda r: sum(abs(r - o) <= 1e-3 * r
                                                               for o in rates.values()))
            for cam, fps in rates.items():
                if abs(fps - video_rate) > 1e-3 * video_rate:
                    others = [c for c, r in rates.items()
                              if abs(r - video_rate) <= 1e-3 * video_rate]
                    raise InputError(self._streams[cam].path,
                                     f"frame rate {fps:g} Hz differs from the {video_rate:g} Hz "
                                     f"of {', '.join(others)}: the videos must be synchronised "
                                     "frame by frame")
        setting = self._rate_setting
        if setting is not None:
            if video_rate is None or abs(setting - video_rate) > 1e-3 * video_rate:
                self.notes.append(f"frame rate {setting:g} Hz from "
                                  f"{self.config.source('project', 'frame_rate')}"
                                  + ("" if video_rate is None
                                     else f" (the videos state {video_rate:g} Hz)"))
            return setting
        if video_rate is not None:
            return video_rate
        self.notes.append(f"no video states a frame rate: {DEFAULT_FRAME_RATE:g} Hz assumed")
        self.frame_rate_assumed = True
        return DEFAULT_FRAME_RATE

    # ------------------------------------------------------------------ backgrounds
    def background_paths(self, camera: str) -> list[Path]:
        """Empty-scene videos of a camera from the trial's ``background/`` folder (may be empty)."""
        folder = self.trial_info.background_dir
        if folder is None:
            return []
        videos = find_videos(folder)
        pairs, _, _ = match_cameras([self.rig[camera].name], list(videos), notes=[])
        if not pairs and len(videos) == len(self._full_rig.names):  # natural order, as videos
            order = sorted(self._full_rig.names, key=natural_key)
            return [list(videos.values())[order.index(self.rig[camera].name)]]
        return [videos[v] for v in pairs.values()]

    def check_backgrounds(self) -> None:
        """Open every background video and check its frame size against the camera's."""
        for cam in self.camera_names:
            for path in self.background_paths(cam):
                w, h = VideoStream(path, gray=False).frame_size()
                if (w, h) != tuple(self.rig[cam].size):
                    raise InputError(path, f"frame size {w}x{h} differs from the video's "
                                           f"{self.rig[cam].size[0]}x{self.rig[cam].size[1]}")

    def background_sets(self, camera: str, *, max_frames: int | None = None
                        ) -> list[list[np.ndarray]]:
        """Per background video of a camera, its first ``max_frames`` frames (a list each)."""
        out = []
        for path in self.background_paths(camera):
            stream = VideoStream(path, gray=False)
            n = stream.n_frames if max_frames is None else min(max_frames, stream.n_frames)
            out.append([image for _, image in stream.read(range(n))])
        return out

    def background_frames(self, camera: str, *, max_frames: int | None = None):
        """Frames of all background videos of a camera, one after the other."""
        for frames in self.background_sets(camera, max_frames=max_frames):
            yield from frames

    # ------------------------------------------------------------------ no ground truth
    ground_truth_path = None
    ground_truth_source = None
    body_file = None

    def ground_truth(self):
        """None: a project holds no ground truth."""
        return None

    def describe(self) -> list[str]:
        """Lines for ``voxelmocap info`` (reads the calibration and decodes a frame per camera)."""
        rig = self.rig
        fps = self.frame_rate
        counts = self.video_frame_counts()
        frames = self.frame_numbers
        shown = (f"{self.n_frames} frames" if len(frames) == self.n_frames else
                 f"frames {frames[0]}..{frames[-1]} of {self.n_frames}")
        lines = [f"    {self.name}: {shown} at {fps:g} Hz, cameras "
                 f"{', '.join(self.camera_names)}",
                 f"      calibration {self.trial_info.calibration}"]
        for cam in self.camera_names:
            w, h = rig[cam].size
            c = rig[cam].center
            lines.append(f"      {cam:<6s} {w}x{h}  frames {counts[cam]:>6d}  "
                         f"video {self._video_paths[cam].name}  centre ({c[0]:.0f}, {c[1]:.0f}, "
                         f"{c[2]:.0f}) mm  backgrounds {len(self.background_paths(cam))}")
        lines.extend(f"      note: {note}" for note in self.notes)
        return lines

    def __repr__(self) -> str:
        return (f"ProjectSequence({self.project.kind}: {self.name}, "
                f"cameras={','.join(self.camera_names)})")
