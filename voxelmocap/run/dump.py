"""``voxelmocap dump``: every measured volume of a sequence in an HDF5 voxel dump, for inspection.

:func:`dump_sequence` runs the :class:`~voxelmocap.run.measurement.MeasurementRunner` of one
sequence over its frames and writes each frame's occupancy, surface and smoothed volumes (and,
when asked, its silhouettes) to :mod:`voxelmocap.io.voxels`' dump, and optionally one PLY file per
frame.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..config import TrackConfig
from ..errors import InputError
from ..logs import emit
from .measurement import MeasurementRunner

__all__ = ["DumpOutcome", "DumpRequest", "dump_sequence"]

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class DumpRequest:
    """One sequence to dump and what to write (see :func:`dump_sequence`).

    Attributes
    ----------
    dataset_root : str or os.PathLike
        HumanEva-layout data set, or a project (:func:`~voxelmocap.io.sequence.open_sequence`).
    subject, sequence : str or None
        E.g. ``"S1"``, ``"Walking_1"``.
    out : str or os.PathLike
        The ``.h5`` file to write (atomically: complete, or not at all).
    config : TrackConfig
        ``config.measurement`` is used, as ``track`` uses it.
    frames : str or None
        ``"a:b"`` or ``"a,b,c"`` synchronised frames (default: all).
    cameras : list of str or None
        Cameras to use (default: all with sync files).
    trial : str or None
        Project trial (default its only trial).
    masks : bool
        Also store the silhouettes.
    ply_dir : str or os.PathLike or None
        Also write ``ply_dir/frame_<F>.ply`` per frame.
    ply_points : bool
        PLY as a point cloud of voxel centres instead of an Open3D voxel grid.
    plate_body : voxelmocap.pose.body_cover.TrackedBody or None
        A run's body in this sequence (:func:`voxelmocap.run.bodies.tracked_body`, which
        ``dump --plate-from`` reads): the plate learnt from the sequence takes it for the person,
        as ``track --plate-from`` and a final tracking pass do, so the dump shows what that pass
        measured.
    """

    dataset_root: object
    subject: str | None
    sequence: str | None
    out: object
    config: TrackConfig = field(default_factory=TrackConfig)
    frames: str | None = None
    cameras: list | None = None
    trial: str | None = None
    masks: bool = False
    ply_dir: object = None
    ply_points: bool = False
    plate_body: object = None


@dataclass
class DumpOutcome:
    """What :func:`dump_sequence` wrote."""

    path: Path  #: the HDF5 voxel dump
    frames: np.ndarray  #: (F,) synchronised frame numbers dumped
    ply_dir: Path | None  #: the folder of PLY files, when asked for
    seconds_per_frame: dict  #: mean seconds per frame of ``decode``, ``subtract``, ``carve``, …
    summary: str | None  #: :meth:`MeasurementRunner.summary` of the run


def dump_sequence(request: DumpRequest, *, progress: bool = True, log=None) -> DumpOutcome:
    """Measure the frames of one sequence and write every volume to a voxel dump.

    Parameters
    ----------
    request : DumpRequest
        The sequence, the output and what to write.
    progress : bool
        Show a progress bar.
    log : callable, optional
        Also receives every one-line message (they go to the logger in any case).

    Returns
    -------
    DumpOutcome

    Raises
    ------
    InputError
        Unreadable data, bad frames, an output that is not an ``.h5`` file name or names a folder,
        a PLY folder that is a file.
    """
    from ..config import config_to_toml
    from ..frames import parse_frame_range
    from ..io.sequence import open_sequence
    from ..io.voxels import VoxelDumpWriter, write_ply
    from ..io.working_size import AtMostSide, at_most_side

    r = request
    config, masks, plate_body = r.config or TrackConfig(), r.masks, r.plate_body
    dataset_root, frames = r.dataset_root, r.frames
    out = Path(r.out)
    if out.suffix.lower() not in (".h5", ".hdf5"):
        raise InputError(out, "expected an .h5 file name")
    if out.is_dir():
        raise InputError(out, "is a folder; give an .h5 file name")
    ply_dir = Path(r.ply_dir) if r.ply_dir is not None else None
    if ply_dir is not None and ply_dir.exists() and not ply_dir.is_dir():
        raise InputError(ply_dir, "exists and is not a folder")
    seq = open_sequence(dataset_root, r.subject, r.sequence, trial=r.trial, cameras=r.cameras)
    for problem in seq.problems:  # cameras the data set has but this run cannot use
        emit(logger, log, problem, logging.WARNING)
    seq = at_most_side(seq, config.measurement.max_image_side)
    if isinstance(seq, AtMostSide):
        emit(logger, log, seq.summary)
    selected = parse_frame_range(frames, seq.frame_numbers) if frames else seq.frame_numbers
    if len(selected) == 0:
        raise InputError(f"{seq.subject}/{seq.name}", "no frames to dump")

    runner = MeasurementRunner(seq, config, log=log, plate_body=plate_body)
    grid = runner.grid
    emit(logger, log, f"{seq.subject}/{seq.name}: {len(selected)} frames, cameras "
                      f"{','.join(seq.camera_names)}, grid {grid.shape[0]}x{grid.shape[1]}x"
                      f"{grid.shape[2]} at {grid.voxel_size:g} mm")
    attrs = {"dataset": str(Path(dataset_root).resolve()), "subject": seq.subject,
             "sequence": seq.name, "config": config_to_toml(config),
             "surface_sigma": float(config.measurement.surface_sigma),
             "plate_from": "" if plate_body is None else plate_body.source}
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
                              points=r.ply_points)
                if bar is not None:
                    bar.update(1)
                t_decode = time.perf_counter()
    finally:
        if bar is not None:
            bar.close()
    n = len(selected)
    return DumpOutcome(out, np.asarray(selected), ply_dir, {k: v / n for k, v in totals.items()},
                       runner.summary())
