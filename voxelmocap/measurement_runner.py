"""Measurement runners: the measurement stage of a sequence on disk, and ``voxelmocap dump``.

:class:`MeasurementRunner` is the :class:`~voxelmocap.measurement.MeasurementStage` of one
HumanEva-layout sequence: it reads the background videos once (the only file access), learns the
background models, derives the grid, and then measures frames like any stage, saying through its
``log`` what it notices (a frame with no person in view, a camera with no picture).
:func:`dump_sequence` runs it over a sequence and writes every volume to an HDF5 voxel dump
(:mod:`voxelmocap.io.voxels`) and optionally PLY files, for inspection.

Only this module, :mod:`voxelmocap.pipeline`, :mod:`voxelmocap.io` and the command line touch files.

>>> seq = Dataset("data").sequence("S1", "Walking_1")                  # doctest: +SKIP
>>> runner = MeasurementRunner(seq, TrackConfig())                      # doctest: +SKIP
>>> for number, obs in runner.observations(seq.frame_numbers[:5]): ... # doctest: +SKIP
"""

from __future__ import annotations

import dataclasses
import logging
import time
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .config import TrackConfig
from .errors import InputError
from .logs import emit
from .measurement import MeasurementStage
from .observation import VoxelObservation

__all__ = ["DumpOutcome", "MeasurementRunner", "dump_sequence"]

logger = logging.getLogger(__name__)


class MeasurementRunner(MeasurementStage):
    """The measurement stage of one sequence: its grid and background models, read once.

    Parameters
    ----------
    seq : voxelmocap.io.humaneva.Sequence
        The sequence (its cameras, calibration and background videos).
    config : TrackConfig
        ``config.measurement`` is used.
    log : callable or None
        Also receives every one-line message (they go to the ``voxelmocap.measurement_runner``
        logger in any case).

    Attributes
    ----------
    grid : VoxelGrid
        The grid (``measurement.grid_origin``/``grid_shape``, or the box the cameras see).
    adaptive : bool
        The background model keeps learning from the frames it segments (MOG2): a resumed run
        must replay the frames already done through :meth:`masks` to rebuild its state.
    empty_frames : list of int
        Frames measured with ``frame=`` whose silhouettes were all empty.
    excluded_frames : dict of str to list of int
        Per camera, the frames it was left out of the carving.
    """

    def __init__(self, seq, config: TrackConfig, log=None):
        from .grid import VoxelGrid
        from .silhouette import build_backgrounds

        mc = config.measurement
        self.measurement_config = mc
        self.log = log
        self.empty_frames: list[int] = []
        self.excluded_frames: dict[str, list[int]] = {}
        silhouette = mc.silhouette
        rig = seq.rig
        for key in ("camera_risk", "camera_var_threshold"):
            unknown = sorted(set(getattr(silhouette, key)) - set(seq.all_camera_names))
            if unknown:
                raise InputError(f"measurement.silhouette.{key}",
                                 f"unknown camera {unknown[0]!r} (this sequence has "
                                 f"{', '.join(seq.all_camera_names)})")
        if mc.grid_origin is not None:
            grid = VoxelGrid(mc.grid_origin, mc.voxel_size, mc.grid_shape)
            grid.check_memory(8.0, what="the measurement volumes")
        else:
            grid = VoxelGrid.from_rig(rig, mc.voxel_size, bytes_per_voxel=8.0)
        frames = {}
        for cam in seq.camera_names:
            paths = seq.background_paths(cam)
            if paths:
                per_video = max(1, mc.background_frames // len(paths))
                frames[cam] = seq.background_sets(cam, max_frames=per_video)
        missing = [c for c in seq.camera_names if c not in frames]
        if missing and silhouette.method == "gaussian":
            # The toolkit's Gaussian model is the default only where background videos exist.
            silhouette = dataclasses.replace(silhouette, method="mog2")
            # Train on frames spread over the whole sequence: a moving person averages out.
            n = seq.n_frames
            sample = np.unique(np.linspace(1, n, min(n, mc.background_frames)).round().astype(int))
            for cam in missing:
                frames[cam] = [[]]
            for _, images in seq.frames(sample):
                for cam in missing:
                    frames[cam][0].append(images[cam])
            self._say(f"no background video for {', '.join(missing)}: using MOG2 learnt from "
                      f"{len(sample)} frames spread over the sequence")
        self.adaptive = silhouette.method == "mog2" and silhouette.mog2_learning_rate != 0
        backgrounds = build_backgrounds(silhouette, seq.camera_names, frames, sets=True)
        super().__init__(rig, grid, backgrounds, silhouette, min_views=mc.min_views,
                         sigma=mc.surface_sigma)
        self.sequence = seq

    @property
    def stage(self) -> MeasurementRunner:
        """The runner itself (it *is* the stage; kept for code written when it held one)."""
        return self

    def _say(self, message: str) -> None:
        emit(logger, self.log, message)

    def measure(self, images: Mapping, *, frame: int | None = None) -> VoxelObservation:
        """The observation of one frame (:meth:`MeasurementStage.measure`), with its messages.

        Parameters
        ----------
        images : mapping of str to (H, W) or (H, W, 3) uint8 ndarray
            One decoded image per camera name.
        frame : int, optional
            The synchronised frame number, named in the messages and kept in
            :attr:`empty_frames` / :attr:`excluded_frames`.

        Returns
        -------
        VoxelObservation

        Notes
        -----
        The first frame with no person in view is logged, later ones only counted (see
        :meth:`summary`); a camera left out of the carving is logged once, at its first such frame.
        """
        obs = super().measure(images)
        where = "a frame" if frame is None else f"frame {int(frame)}"
        for cam, reason in obs.excluded.items():
            seen = self.excluded_frames.setdefault(cam, [])
            if not seen:
                self._say(f"camera {cam}, {where}: {reason}; it is left out of the carving of "
                          "this and any later such frame")
            if frame is not None:
                seen.append(int(frame))
        if obs.empty:
            if not self.empty_frames:
                self._say(f"{where}: every silhouette is empty (no person in view), the "
                          "occupancy is empty")
            if frame is not None:
                self.empty_frames.append(int(frame))
        return obs

    def observations(self, frames: Iterable[int]) -> Iterator[tuple[int, VoxelObservation]]:
        """Decode and measure synchronised ``frames`` in order: ``(frame number, observation)``."""
        for number, images in self.sequence.frames(frames):
            yield int(number), self.measure(images, frame=number)

    def summary(self) -> str | None:
        """One line on the frames with no person and the cameras left out, or None if none."""
        parts = []
        if self.empty_frames:
            parts.append(f"{len(self.empty_frames)} frame(s) with every silhouette empty (no "
                         f"person in view): {_list(self.empty_frames)}")
        for cam, frames in sorted(self.excluded_frames.items()):
            if frames:
                parts.append(f"camera {cam} left out of {len(frames)} frame(s): {_list(frames)}")
        return "; ".join(parts) or None


def _list(frames: list[int], n: int = 10) -> str:
    return ", ".join(str(f) for f in frames[:n]) + (" …" if len(frames) > n else "")


@dataclass
class DumpOutcome:
    """What :func:`dump_sequence` wrote."""

    path: Path  #: the HDF5 voxel dump
    frames: np.ndarray  #: (F,) synchronised frame numbers dumped
    ply_dir: Path | None  #: the folder of PLY files, when asked for
    seconds_per_frame: dict  #: mean seconds per frame of ``decode``, ``subtract``, ``carve``, …
    summary: str | None  #: :meth:`MeasurementRunner.summary` of the run


def dump_sequence(dataset_root, subject: str, sequence: str, out, *,
                  config: TrackConfig | None = None, frames: str | None = None, cameras=None,
                  masks: bool = False, ply_dir=None, ply_points: bool = False,
                  progress: bool = True, log=None, trial: str | None = None) -> DumpOutcome:
    """Measure the frames of one sequence and write every volume to a voxel dump.

    Parameters
    ----------
    dataset_root : str or os.PathLike
        HumanEva-layout data set.
    subject, sequence : str
        E.g. ``"S1"``, ``"Walking_1"``.
    out : str or os.PathLike
        The ``.h5`` file to write (atomically: complete, or not at all).
    config : TrackConfig, optional
        ``config.measurement`` is used, as ``track`` uses it.
    frames : str, optional
        ``"a:b"`` or ``"a,b,c"`` synchronised frames (default: all).
    cameras : list of str, optional
        Cameras to use (default: all with sync files).
    masks : bool
        Also store the silhouettes.
    ply_dir : str or os.PathLike, optional
        Also write ``ply_dir/frame_<F>.ply`` per frame.
    ply_points : bool
        PLY as a point cloud of voxel centres instead of an Open3D voxel grid.
    progress : bool
        Show a progress bar.
    log : callable, optional
        Also receives every one-line message (they go to the logger in any case).
    trial : str, optional
        Project trial (a Pose2Sim / anipose / EasyMocap project, :func:`~voxelmocap.io.sequence.
        open_sequence`; default its only trial).

    Returns
    -------
    DumpOutcome

    Raises
    ------
    InputError
        Unreadable data, bad frames, an output that is not an ``.h5`` file name or names a folder,
        a PLY folder that is a file.
    """
    from .config import config_to_toml
    from .frames import parse_frame_range
    from .io.sequence import open_sequence
    from .io.voxels import VoxelDumpWriter, write_ply

    config = config or TrackConfig()
    out = Path(out)
    if out.suffix.lower() not in (".h5", ".hdf5"):
        raise InputError(out, "expected an .h5 file name")
    if out.is_dir():
        raise InputError(out, "is a folder; give an .h5 file name")
    ply_dir = Path(ply_dir) if ply_dir is not None else None
    if ply_dir is not None and ply_dir.exists() and not ply_dir.is_dir():
        raise InputError(ply_dir, "exists and is not a folder")
    seq = open_sequence(dataset_root, subject, sequence, trial=trial, cameras=cameras)
    for problem in seq.problems:  # cameras the data set has but this run cannot use
        emit(logger, log, problem, logging.WARNING)
    selected = parse_frame_range(frames, seq.frame_numbers) if frames else seq.frame_numbers
    if len(selected) == 0:
        raise InputError(f"{seq.subject}/{seq.name}", "no frames to dump")

    runner = MeasurementRunner(seq, config, log=log)
    grid = runner.grid
    emit(logger, log, f"{seq.subject}/{seq.name}: {len(selected)} frames, cameras "
                      f"{','.join(seq.camera_names)}, grid {grid.shape[0]}x{grid.shape[1]}x"
                      f"{grid.shape[2]} at {grid.voxel_size:g} mm")
    attrs = {"dataset": str(Path(dataset_root).resolve()), "subject": seq.subject,
             "sequence": seq.name, "config": config_to_toml(config),
             "surface_sigma": float(config.measurement.surface_sigma)}
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=len(selected), desc=f"{seq.subject}/{seq.name}", unit="frame",
                   dynamic_ncols=True)
    totals = {"decode": 0.0}
    t_decode = time.perf_counter()
    try:
        with VoxelDumpWriter(out, grid, cameras=list(seq.rig), attrs=attrs) as writer:
            for number, images in seq.frames(selected):
                totals["decode"] += time.perf_counter() - t_decode
                obs = runner.measure(images, frame=number)
                for key, value in obs.timings.items():
                    totals[key] = totals.get(key, 0.0) + value
                writer.write(int(number), obs.occupancy, surface=obs.surface,
                             smoothed=obs.smoothed, masks=obs.masks if masks else None)
                if ply_dir is not None:
                    write_ply(ply_dir / f"frame_{int(number):05d}.ply", grid, obs.occupancy,
                              points=ply_points)
                if bar is not None:
                    bar.update(1)
                t_decode = time.perf_counter()
    finally:
        if bar is not None:
            bar.close()
    n = len(selected)
    return DumpOutcome(out, np.asarray(selected), ply_dir, {k: v / n for k, v in totals.items()},
                       runner.summary())
