"""The measurement runner: the measurement stage of a sequence on disk.

:class:`MeasurementRunner` is the :class:`~voxelmocap.measure.stage.MeasurementStage` of one
HumanEva-layout sequence: it reads the background videos once (the only file access), learns the
background models, derives the grid, and then measures frames like any stage, saying through its
``log`` what it notices (a frame with no person in view, a camera with no picture).
:func:`voxelmocap.run.dump.dump_sequence` runs it over a sequence and writes every volume to an
HDF5 voxel dump (:mod:`voxelmocap.io.voxels`) and optionally PLY files, for inspection.

Only this module, :mod:`voxelmocap.run.pipeline`, :mod:`voxelmocap.io` and the command line touch files.

>>> seq = Dataset("data").sequence("S1", "Walking_1")                  # doctest: +SKIP
>>> runner = MeasurementRunner(seq, TrackConfig())                      # doctest: +SKIP
>>> for number, obs in runner.observations(seq.frame_numbers[:5]): ... # doctest: +SKIP
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path

import numpy as np

from ..config import TrackConfig
from ..errors import InputError
from ..frames import spread, spread_indices
from ..logs import emit
from ..measure.observation import VoxelObservation
from ..measure.stage import MeasurementStage

__all__ = ["MeasurementRunner", "learns_plate", "person_grid"]

#: Top (mm) of the coarse box carved to learn a plate or place the grid: a raised hand.
COARSE_HEIGHT_MM = 2500.0
#: The coarse box covers the floor area three cameras see at floor and waist height (this probe)…
COARSE_PROBE_MM = 1000.0
#: … grown by this much (mm) for limbs reaching beyond it.
COARSE_MARGIN_MM = 500.0
#: A sampled frame whose person box has more than this many times the median floor area is
#: left out of the grid placement.
OUTLIER_BOX = 2.0
#: Frames sampled to place the grid when no plate is learnt.
GRID_FRAMES = 20


def person_grid(stage: MeasurementStage, samples: Iterable[Mapping[str, np.ndarray]],
                voxel_size: float, *, margin: float, bytes_per_voxel: float | None = None,
                masks=None):
    """The grid around the person: the box of the person's voxels over sampled frames.

    Parameters
    ----------
    stage : MeasurementStage
        A stage on a coarse grid (its ``person_only`` keeps the largest component per frame).
    samples : iterable of mapping of str to (H, W, C) uint8 ndarray
        Sampled frames, each the images of every camera (e.g. ``Sequence.frames(numbers)``
        without the numbers: one frame in memory at a time).
    voxel_size : float
        Voxel edge of the grid returned (mm).
    margin : float
        Grows the box on every side (mm); the floor side stops at the coarse grid's floor.
    bytes_per_voxel : float, optional
        Checks that the grid's volumes fit in memory.
    masks : sequence of sequences of (H_c, W_c) bool ndarray, optional
        The silhouettes of each sampled frame (rig order), given instead of segmented.

    Returns
    -------
    VoxelGrid

    Raises
    ------
    InputError
        When no frame holds a person.
    """
    from ..grid import VoxelGrid

    coarse = stage.grid
    n = 0
    boxes = []
    for f, images in enumerate(samples):
        n += 1
        obs = stage.measure({c: images[c] for c in stage.names},
                            masks=None if masks is None else masks[f])
        ijk = np.argwhere(obs.occupancy)
        if len(ijk):
            boxes.append((coarse.low + ijk.min(axis=0) * coarse.voxel_size,
                          coarse.low + (ijk.max(axis=0) + 1) * coarse.voxel_size))
    if boxes:
        # a frame whose "person" box is far wider than the typical one carved something else
        # along (a background person touching it, a ghost): it does not move the grid
        size = np.array([np.prod((h - lo_)[:2]) for lo_, h in boxes])
        keep = size <= OUTLIER_BOX * np.median(size)
        lo = np.min([b[0] for b, k in zip(boxes, keep, strict=True) if k], axis=0)
        hi = np.max([b[1] for b, k in zip(boxes, keep, strict=True) if k], axis=0)
    else:
        lo = np.full(3, np.inf)
    if not np.all(np.isfinite(lo)):
        raise InputError("grid", f"no person found in {n} frames sampled over the sequence: "
                                 "cannot place the grid around the person; check the background "
                                 "or give measurement.grid_origin and grid_shape")
    low = np.maximum(lo - margin, coarse.low)
    low[2] = coarse.low[2]                       # the floor
    high = hi + margin
    low[:2] = np.floor(low[:2] / voxel_size) * voxel_size
    grid = VoxelGrid.from_bounds(low, high, voxel_size)
    if bytes_per_voxel is not None:
        grid.check_memory(bytes_per_voxel, what="the measurement volumes")
    return grid

logger = logging.getLogger(__name__)


def learns_plate(seq, silhouette) -> bool:
    """Whether a run learns a background plate from the sequence itself.

    Parameters
    ----------
    seq : Sequence
        Its cameras' background videos (``background_paths``).
    silhouette : SilhouetteConfig
        ``method``.

    Returns
    -------
    bool
        A camera has no background video and ``method`` is ``gaussian`` or ``plate`` (not
        ``mog2``).
    """
    return (silhouette.method in ("gaussian", "plate")
            and any(not seq.background_paths(c) for c in seq.camera_names))


class MeasurementRunner(MeasurementStage):
    """The measurement stage of one sequence: its grid and background models, read once.

    Parameters
    ----------
    seq : voxelmocap.io.humaneva.Sequence
        The sequence (its cameras, calibration and background videos).
    config : TrackConfig
        ``config.measurement`` is used.
    log : callable or None
        Also receives every one-line message (they go to the ``voxelmocap.run.measurement``
        logger in any case).
    person_masks : voxelmocap.io.masks.PersonMasks, optional
        Silhouettes given with the recording (no background model).
    plate_body : voxelmocap.pose.body_cover.TrackedBody, optional
        A previous run's body: a plate learnt from the sequence takes its image in each sampled
        frame for the person (:func:`~voxelmocap.pose.body_cover.plate_covers_of`) instead of finding
        the person by carving.

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

    def __init__(self, seq, config: TrackConfig, log=None, *, person_masks=None,
                 plate_body=None):
        from ..grid import VoxelGrid
        from ..measure.background import learn_plates, plates_from_covers
        from ..measure.plate import plate_from_frames
        from ..measure.silhouette import build_backgrounds
        from ..pose.body_cover import plate_covers_of

        mc = config.measurement
        self.measurement_config = mc
        self.log = log
        self.empty_frames: list[int] = []
        self.excluded_frames: dict[str, list[int]] = {}
        self._said_no_voxel = False
        silhouette = mc.silhouette
        rig = seq.rig
        for key in ("camera_risk", "camera_var_threshold"):
            unknown = sorted(set(getattr(silhouette, key)) - set(seq.all_camera_names))
            if unknown:
                raise InputError(f"measurement.silhouette.{key}",
                                 f"unknown camera {unknown[0]!r} (this sequence has "
                                 f"{', '.join(seq.all_camera_names)})")
        n_cam = len(seq.camera_names)
        #: the silhouettes of every frame, given (:class:`voxelmocap.io.masks.PersonMasks`)
        self.person_masks = person_masks
        if person_masks is not None:
            self._given_masks(seq, config, person_masks)
            return
        frames = {}
        for cam in seq.camera_names:
            paths = seq.background_paths(cam)
            if paths:
                per_video = max(1, mc.background_frames // len(paths))
                frames[cam] = seq.background_sets(cam, max_frames=per_video)
        missing = [c for c in seq.camera_names if c not in frames]
        #: the background is learnt from the sequence itself (a real recording without plate)
        self.learnt_plate = learns_plate(seq, silhouette)
        holes = mc.carve_holes if mc.carve_holes is not None else (
            1 if self.learnt_plate and n_cam >= 4 else 0)
        person_only = mc.person_only if mc.person_only is not None else self.learnt_plate
        placement = mc.grid_placement
        if placement == "auto":
            placement = "person" if self.learnt_plate else "rig"
        coarse = None
        if self.learnt_plate or (mc.grid_origin is None and placement == "person"):
            coarse = _coarse_grid(rig, mc)
        samples = None
        if plate_body is not None and not self.learnt_plate:
            raise InputError("--plate-from", "no plate is learnt for this sequence (every camera "
                                             "has a background video, or the method is mog2)")
        if self.learnt_plate:
            if plate_body is not None:
                numbers = spread(plate_body.frames, silhouette.plate_frames)
                samples = seq.by_camera(numbers)
                states = plate_body.states[np.searchsorted(plate_body.frames, numbers)]
                plain = [cam for cam in rig if cam.name in missing]  # the others have videos
                seen = max(silhouette.plate_min_seen,
                           int(round(silhouette.plate_body_min_seen * len(numbers))))
                plates = plates_from_covers(samples, plain, plate_covers_of(
                    plain, plate_body.model, states, silhouette.plate_body_margin,
                    support=silhouette.plate_body_support),
                    dataclasses.replace(silhouette, plate_min_seen=seen))
                how = f"the person where the body of {plate_body.source} was"
            else:
                samples = seq.by_camera(spread(seq.frame_numbers, silhouette.plate_frames))
                plates = learn_plates(samples, rig, coarse, silhouette, holes=holes,
                                      log=self._say)
                how = "the person found by carving"
            self._say(f"no background video for {', '.join(missing)}: background plate learnt "
                      f"from {len(samples.numbers)} frames of the sequence, {how} "
                      "(noise σ " + ", ".join(f"{c} {plates[c].camera_sigma:.1f}"
                                               for c in missing) + " grey levels)")
            backgrounds = {c: plates[c] for c in missing}
            if len(missing) < n_cam:
                backgrounds.update(build_backgrounds(
                    silhouette, [c for c in seq.camera_names if c in frames], frames, sets=True))
        elif silhouette.method == "plate":
            backgrounds = {c: plate_from_frames(np.stack([f for s in frames[c] for f in s]),
                                                silhouette) for c in seq.camera_names}
        else:
            if missing:
                # MOG2 asked for: train on frames spread over the whole sequence.
                # (frame numbers rounded from 1..n, not spread(): its ties round differently, and
                # MOG2's training frames are kept as they were)
                n = seq.n_frames
                sample = np.unique(np.linspace(1, n, min(n, mc.background_frames)).round()
                                   .astype(int))
                for cam in missing:
                    frames[cam] = [[]]
                for _, images in seq.frames(sample):
                    for cam in missing:
                        frames[cam][0].append(images[cam])
                self._say(f"no background video for {', '.join(missing)}: using MOG2 learnt "
                          f"from {len(sample)} frames spread over the sequence")
            backgrounds = build_backgrounds(silhouette, seq.camera_names, frames, sets=True)
        self.adaptive = silhouette.method == "mog2" and silhouette.mog2_learning_rate != 0
        if mc.grid_origin is not None:
            grid = VoxelGrid(mc.grid_origin, mc.voxel_size, mc.grid_shape)
            grid.check_memory(8.0, what="the measurement volumes")
        elif placement == "person" and not self.adaptive:
            if samples is None:
                samples = self._spread_frames(seq, GRID_FRAMES)
            else:
                # the plate's samples, thinned: each one segments every camera (with GrabCut
                # on a learnt plate's never-seen pixels), and 20 spread frames place the box
                samples = samples.frames(spread_indices(len(samples.numbers), GRID_FRAMES))
            stage = MeasurementStage(rig, coarse, backgrounds, silhouette, holes=holes,
                                     person_only=True, hole_reach=mc.carve_hole_reach)
            grid = person_grid(stage, samples, mc.voxel_size, margin=mc.grid_margin,
                               bytes_per_voxel=8.0)
            self._say(_placed(grid, mc.grid_margin))
        else:
            grid = VoxelGrid.from_rig(rig, mc.voxel_size, bytes_per_voxel=8.0)
        super().__init__(rig, grid, backgrounds, silhouette, min_views=mc.min_views,
                         sigma=mc.surface_sigma, holes=holes, person_only=person_only,
                         hole_reach=mc.carve_hole_reach)
        self.sequence = seq

    def _given_masks(self, seq, config: TrackConfig, person_masks) -> None:
        """Set up for silhouettes given with the recording: no background model.

        Given masks are treated like a learnt plate's silhouettes when there are four cameras or
        more: one hole tolerated near the silhouette (another tool's masks miss a limb in one
        view now and then), the grid placed around the person from the masks of
        :data:`GRID_FRAMES` frames spread over the sequence. With fewer cameras the coarse carve's
        largest component may be a phantom of the cone intersections, not the person: the grid
        is the rig's floor box. The largest 3D component is kept in every case.
        """
        from ..grid import VoxelGrid

        mc = config.measurement
        rig, n_cam = seq.rig, len(seq.camera_names)
        self.learnt_plate, self.adaptive = False, False
        holes = mc.carve_holes if mc.carve_holes is not None else (1 if n_cam >= 4 else 0)
        person_only = mc.person_only if mc.person_only is not None else True
        placement = mc.grid_placement
        if placement == "auto":
            placement = "person" if n_cam >= 4 else "rig"
        if mc.grid_origin is not None:
            grid = VoxelGrid(mc.grid_origin, mc.voxel_size, mc.grid_shape)
            grid.check_memory(8.0, what="the measurement volumes")
        elif placement == "person":
            coarse = _coarse_grid(rig, mc)
            samples = self._spread_frames(seq, GRID_FRAMES)
            given = [m for _, m in person_masks.read(spread(seq.frame_numbers, GRID_FRAMES))]
            stage = MeasurementStage(rig, coarse, None, mc.silhouette, holes=holes,
                                     person_only=True, hole_reach=mc.carve_hole_reach)
            grid = person_grid(stage, samples, mc.voxel_size, margin=mc.grid_margin,
                               bytes_per_voxel=8.0, masks=given)
            self._say(_placed(grid, mc.grid_margin))
        else:
            grid = VoxelGrid.from_rig(rig, mc.voxel_size, bytes_per_voxel=8.0)
        self._say("silhouettes: the person masks given in "
                  f"{Path(next(iter(person_masks.paths.values()))).parent} (no background "
                  "subtraction)")
        MeasurementStage.__init__(self, rig, grid, None, mc.silhouette, min_views=mc.min_views,
                                  sigma=mc.surface_sigma, holes=holes, person_only=person_only,
                                  hole_reach=mc.carve_hole_reach)
        self.sequence = seq

    @staticmethod
    def _spread_frames(seq, count: int) -> Iterator[dict[str, np.ndarray]]:
        """The images of ``count`` frames spread evenly over the sequence, one frame at a time."""
        return (images for _, images in seq.frames(spread(seq.frame_numbers, count)))

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
        given = None
        if self.person_masks is not None:
            if frame is None:
                raise InputError("masks", "a frame measured with given person masks needs its "
                                          "frame number")
            given = self.person_masks.of(frame)
        obs = super().measure(images, masks=given)
        where = "a frame" if frame is None else f"frame {int(frame)}"
        for cam, reason in obs.excluded.items():
            seen = self.excluded_frames.setdefault(cam, [])
            if not seen:
                self._say(f"camera {cam}, {where}: {reason}; it is left out of the carving of "
                          "this and any later such frame")
            if frame is not None:
                seen.append(int(frame))
        if not obs.empty and not obs.occupancy.any() and not self._said_no_voxel:
            self._said_no_voxel = True
            how = ("the person masks given (are they numbered by video frame?)"
                   if self.person_masks is not None
                   else "the background plate learnt from the sequence (e.g. with 'dump "
                        "--masks')" if self.learnt_plate
                   else "the background model (e.g. with 'dump --masks')")
            self._say(f"{where}: the silhouettes carve into no voxel: the cameras disagree "
                      f"about the person; check {how} and the calibration")
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


def _coarse_grid(rig, mc):
    """The coarse box carved to learn a plate or place the grid (floor area three cameras see)."""
    from ..grid import VoxelGrid

    n_cam = len(rig)
    return VoxelGrid.from_rig(rig, mc.coarse_voxel_size, min_views=min(3, n_cam),
                              height=COARSE_HEIGHT_MM, probe_height=COARSE_PROBE_MM,
                              margin=COARSE_MARGIN_MM, bytes_per_voxel=4.0 * n_cam + 8)


def _placed(grid, margin: float) -> str:
    """The message saying where the grid was placed around the person."""
    return (f"grid placed around the person ({margin:g} mm margin): "
            f"{grid.shape[0]}x{grid.shape[1]}x{grid.shape[2]} voxels from "
            f"({', '.join(f'{v:.0f}' for v in grid.low)}) to "
            f"({', '.join(f'{v:.0f}' for v in grid.high)}) mm")


def _list(frames: list[int], n: int = 10) -> str:
    return ", ".join(str(f) for f in frames[:n]) + (" …" if len(frames) > n else "")
