"""A Rerun recording (``.rrd``) of a tracking run, to scrub through it in 3D in the Rerun viewer.

:class:`RerunRecorder` is handed to :func:`voxelmocap.run.pipeline.track_sequence` as its
``recorder`` (``voxelmocap track --rerun FILE.rrd``). What it records, on the ``frame`` timeline
(HumanEva's synchronised 1-based frame numbers):

==================================  =========================================================
entity                              content
==================================  =========================================================
``world``                           view coordinates: right-handed, Z up (HumanEva's world, mm)
``world/cameras/<C>``               static: ``Transform3D`` (camera → world: ``Rᵀ``, centre
                                    ``−Rᵀ T``) and ``Pinhole`` (``K``, image size, RDF axes)
``world/cameras/<C>/image``         per frame: the camera's image (JPEG)
``world/cameras/<C>/silhouette``    per frame: the silhouette as a segmentation image
                                    (class 1, drawn over the image)
``world/voxels``                    per frame: the occupied voxels ``V^R`` as points at the
                                    voxel centres, radius half a voxel
``world/particles/pelvis``          per frame: the pelvis of every last-layer particle,
                                    coloured by normalised weight (dark → bright)
``world/particles/top``             per frame: the skeletons of the ``top_k`` heaviest particles
``world/skeleton``                  per frame: the tracked skeleton, one line per bone between
                                    the 15 landmarks (``joints.LANDMARK_PARENTS``)
``world/skeleton/landmarks``        per frame: the 15 landmarks
==================================  =========================================================

The image planes are placed with the pinhole model: lens distortion (``kc``) is not drawn, so
the silhouettes of a strongly distorted camera sit a few pixels off the voxels' projection at
the image's edges. The principal point is shifted by half a pixel: voxelmocap's pixel (0, 0) is
centred at (0, 0) (``camera.Camera``), Rerun's at (0.5, 0.5).

The recording is written to a hidden temporary sibling while the run goes on (created when the run
starts, after its inputs are checked) and renamed to its name by :meth:`RerunRecorder.close`
(:meth:`RerunRecorder.abort` deletes it after a failure).
``rerun-sdk`` is the optional ``rerun`` extra.

>>> recorder = RerunRecorder("run.rrd")                               # doctest: +SKIP
>>> track_sequence("data", "S1", "Walking_1", "run", recorder=recorder)  # doctest: +SKIP
>>> recorder.close()                                                  # doctest: +SKIP
"""

from __future__ import annotations

import contextlib
import os
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..joints import LANDMARK_PARENTS

__all__ = ["BONES", "RerunRecorder", "camera_pose", "pinhole_matrix"]

#: ``(child, parent)`` landmark index pairs: one line per bone of the tracked skeleton.
BONES: tuple[tuple[int, int], ...] = tuple(
    (child, parent) for child, parent in enumerate(LANDMARK_PARENTS) if parent >= 0)

#: The silhouette's class in the segmentation images, and its colour (magenta, half opaque).
SILHOUETTE_CLASS = 1
_SILHOUETTE_RGBA = (255, 0, 255, 128)


def camera_pose(camera) -> tuple[np.ndarray, np.ndarray]:
    """``(rotation (3, 3), translation (3,))`` mapping camera coordinates to world (mm).

    The ``.cal`` model maps world to camera by ``Xc = R·X + T``, so a camera point goes to the
    world by ``X = Rᵀ·Xc + C`` with the centre ``C = −Rᵀ·T``.
    """
    return camera.R.T.copy(), np.asarray(camera.center, dtype=float)


def pinhole_matrix(camera) -> np.ndarray:
    """(3, 3) ``K`` with the principal point in Rerun's pixel convention (corner at (0, 0))."""
    k = np.array(camera.K, dtype=float)
    k[:2, 2] += 0.5
    return k


def _bone_strips(landmarks: np.ndarray) -> np.ndarray:
    """(B, 2, 3) line segments of one skeleton's bones, or (K·B, 2, 3) for (K, 15, 3)."""
    landmarks = np.asarray(landmarks, dtype=np.float32).reshape(-1, len(LANDMARK_PARENTS), 3)
    child = [c for c, _ in BONES]
    parent = [p for _, p in BONES]
    return np.stack([landmarks[:, parent], landmarks[:, child]], axis=2).reshape(-1, 2, 3)


def _require_rerun():
    try:
        import rerun as rr
    except ImportError:
        raise InputError("--rerun", "needs rerun-sdk: pip install 'voxelmocap[rerun]'") from None
    return rr


class RerunRecorder:
    """Records a tracking run into a ``.rrd`` file (see the module docstring).

    Parameters
    ----------
    path : str or os.PathLike
        The ``.rrd`` file to write (atomically).
    top_k : int
        Skeletons of the heaviest particles drawn per frame.
    jpeg_quality : int
        JPEG quality of the camera images (they dominate the file's size).
    voxels : bool
        Record the occupied voxels.

    Raises
    ------
    InputError
        ``rerun-sdk`` is not installed, the name does not end in ``.rrd``, or the file cannot be
        written there (checked before any work).
    """

    def __init__(self, path, *, top_k: int = 5, jpeg_quality: int = 75, voxels: bool = True):
        self.path = Path(path)
        if self.path.suffix.lower() != ".rrd":
            raise InputError(self.path, "expected a Rerun .rrd file name")
        self._rr = _require_rerun()
        self.top_k = int(top_k)
        self.jpeg_quality = int(jpeg_quality)
        self.record_voxels = bool(voxels)
        self._tmp = None  # created by start(): a run refused before it leaves nothing
        self._closed = False
        self._stream = None
        self._grid = None
        self._cameras: list[str] = []
        self.frames: list[int] = []  #: frames with a tracked skeleton, in recording order

    # ------------------------------------------------------------------ the run's hooks
    def start(self, seq, grid) -> None:
        """Open the stream and place the rig: called once the measurement stage exists.

        Raises
        ------
        InputError
            The file cannot be written there (before any frame is processed).
        """
        from ..io._atomic import create_temporary

        rr = self._rr
        if self._stream is not None:
            return
        self._tmp = create_temporary(self.path)
        self._stream = rr.RecordingStream("voxelmocap", recording_id=f"{seq.subject}/{seq.name}")
        self._stream.save(self._tmp)
        self._grid = grid
        self._cameras = [camera.name for camera in seq.rig]  # the order of the masks
        log = self._stream.log
        log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        log("world/cameras", rr.AnnotationContext(
            [(SILHOUETTE_CLASS, "silhouette", _SILHOUETTE_RGBA)]), static=True)
        for name in self._cameras:
            camera = seq.rig[name]
            rotation, centre = camera_pose(camera)
            log(f"world/cameras/{name}", rr.Transform3D(translation=centre, mat3x3=rotation),
                static=True)
            log(f"world/cameras/{name}", rr.Pinhole(
                image_from_camera=pinhole_matrix(camera), resolution=list(camera.size),
                camera_xyz=rr.ViewCoordinates.RDF, image_plane_distance=400.0), static=True)
        lo = np.asarray(grid.origin, dtype=float)
        size = np.asarray(grid.shape, dtype=float) * grid.voxel_size
        log("world/grid", rr.Boxes3D(centers=[lo + size / 2], half_sizes=[size / 2],
                                     colors=[(120, 120, 120)]), static=True)

    def observe(self, frame: int, images, observation) -> None:
        """One measured frame: images, silhouettes and occupied voxels."""
        rr = self._rr
        stream = self._require_started()
        stream.set_time("frame", sequence=int(frame))
        masks = observation.masks
        for index, name in enumerate(self._cameras):
            image = np.asarray(images[name])
            if image.ndim == 3:
                image = np.ascontiguousarray(image[..., ::-1])  # OpenCV's BGR → RGB
            stream.log(f"world/cameras/{name}/image",
                       rr.Image(image).compress(jpeg_quality=self.jpeg_quality))
            if masks is not None:
                mask = np.asarray(masks[index], dtype=np.uint8) * SILHOUETTE_CLASS
                stream.log(f"world/cameras/{name}/silhouette", rr.SegmentationImage(mask))
        if self.record_voxels:
            occupied = np.argwhere(observation.occupancy)
            centres = self._grid.centre_of(occupied) if len(occupied) else np.empty((0, 3))
            stream.log("world/voxels", rr.Points3D(
                centres.astype(np.float32), radii=0.5 * float(self._grid.voxel_size),
                colors=[(170, 170, 190)]))

    def __call__(self, record, tracker) -> None:
        """One tracked frame (a tracker observer): skeleton, and particles when ``tracker``."""
        rr = self._rr
        stream = self._require_started()
        stream.set_time("frame", sequence=int(record.frame))
        self.frames.append(int(record.frame))
        stream.log("world/skeleton", rr.LineStrips3D(_bone_strips(record.landmarks),
                                                     colors=[(40, 220, 90)], radii=12.0))
        stream.log("world/skeleton/landmarks", rr.Points3D(
            np.asarray(record.landmarks, dtype=np.float32), radii=20.0, colors=[(40, 220, 90)]))
        pf = None if tracker is None else tracker.filter
        if pf is None or pf.particles is None:
            return
        joints = tracker.model.forward(np.asarray(pf.particles)).joints  # (P, 15, 3)
        log_w = np.asarray(pf.log_weights, dtype=float)
        w = np.exp(log_w - log_w.max()) if np.isfinite(log_w).any() else np.ones_like(log_w)
        shade = (60 + 195 * w / max(w.max(), 1e-300)).astype(np.uint8)
        colors = np.stack([shade, shade // 2, 255 - shade], axis=1)
        stream.log("world/particles/pelvis", rr.Points3D(
            joints[:, 1].astype(np.float32), radii=8.0, colors=colors))
        top = np.argsort(-log_w, kind="stable")[: self.top_k]
        stream.log("world/particles/top", rr.LineStrips3D(
            _bone_strips(joints[top]), colors=[(255, 170, 40)], radii=5.0))

    # ------------------------------------------------------------------ the file
    def _require_started(self):
        if self._stream is None:
            raise RuntimeError("RerunRecorder: start(seq, grid) has not been called")
        return self._stream

    def close(self) -> Path | None:
        """Finish the file and move it to its name; the path (None: the run never started,
        e.g. its result was already complete, and nothing was written)."""
        if self._closed:
            return self.path
        if self._stream is None:
            return None
        if self._stream is not None:
            self._stream.flush()
            self._stream.disconnect()  # closes the file sink (writes the footer)
            self._stream = None
        try:
            os.replace(self._tmp, self.path)
        except OSError as exc:
            raise InputError(self.path, f"cannot write here ({exc.strerror or exc})") from None
        self._tmp = None
        self._closed = True
        return self.path

    def abort(self) -> None:
        """Drop the recording (a failed run); nothing is left. A no-op after :meth:`close`."""
        if self._stream is not None:
            with contextlib.suppress(Exception):
                self._stream.disconnect()
            self._stream = None
        if self._tmp is not None:
            with contextlib.suppress(FileNotFoundError):
                self._tmp.unlink()
            self._tmp = None
