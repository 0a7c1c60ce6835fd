"""C3D export of landmark trajectories, through the ``c3d`` package (pure Python, as Pose2Sim).

The file holds one POINT per landmark, labelled with its name, at the run's frame rate
(``POINT:RATE``), in millimetres (``POINT:UNITS``), as 32-bit floats (``POINT:SCALE`` −1; their
resolution is below 0.001 mm within 8 m of the origin). The first frame (header and
``TRIAL:ACTUAL_START_FIELD``) is the first synchronised frame number; a C3D has no gaps, so
frames missing from the result are written as invalid points.

The **residual** channel (C3D: the reconstruction's error estimate, in the point units) holds each
landmark's particle spread (:func:`voxelmocap.pose.confidence.landmark_spread`, the filter's own error
estimate) in whole millimetres, clipped to 1…255 mm (a residual of 0 means "interpolated" in
C3D, and the channel is one byte); −1 marks an invalid point (no estimate, or a frame without a
person). Unknown spreads (results before format 3) are written as 1 mm. The camera-mask byte is 0.

>>> import numpy as np, tempfile, pathlib
>>> path = pathlib.Path(tempfile.mkdtemp()) / "a.c3d"
>>> path = write_c3d(path, np.zeros((2, 1, 3)), ["head"], frame_rate=60.0, first_frame=1)
>>> path.stat().st_size % 512
0
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from ._atomic import atomic_path

__all__ = ["RESIDUAL_RANGE_MM", "write_c3d"]

#: The residual byte's range (mm, at POINT:SCALE −1).
RESIDUAL_RANGE_MM = (1.0, 255.0)


def write_c3d(path, positions, names, *, frame_rate: float, first_frame: int = 1,
              residuals=None) -> Path:
    """Write trajectories as a C3D file (atomically).

    Parameters
    ----------
    path : str or os.PathLike
    positions : (F, M, 3) array_like
        Point positions (mm) of consecutive frames; a NaN coordinate makes the point invalid.
    names : sequence of str
        The M point labels.
    frame_rate : float
        POINT:RATE (Hz).
    first_frame : int
        Number of the first frame (1-based).
    residuals : (F, M) array_like, optional
        Error estimates (mm), rounded and clipped to :data:`RESIDUAL_RANGE_MM`; NaN → the lower
        end. Default: all at the lower end.

    Returns
    -------
    Path
    """
    import c3d

    x = np.asarray(positions, dtype=float)
    names = [str(n) for n in names]
    if x.ndim != 3 or x.shape[2] != 3 or x.shape[1] != len(names) or len(x) == 0:
        raise ValueError(f"write_c3d: positions must be (F>0, {len(names)}, 3), got {x.shape}")
    low, high = RESIDUAL_RANGE_MM
    res = np.full(x.shape[:2], low) if residuals is None else np.asarray(residuals, float)
    res = np.clip(np.nan_to_num(res, nan=low), low, high)
    res = np.where(np.isnan(x).any(axis=2), -1.0, res)

    writer = c3d.Writer(point_rate=float(frame_rate), analog_rate=0.0, point_scale=-1.0,
                        point_units="mm  ")
    writer.set_point_labels(names)
    writer.set_start_frame(int(first_frame))
    empty = np.empty((0, 0))
    for i in range(len(x)):
        points = np.zeros((len(names), 5))
        points[:, :3] = np.nan_to_num(x[i])  # invalid points: 0, marked by the residual
        points[:, 3] = res[i]
        writer.add_frames([(points, empty)])
    path = Path(path)
    with atomic_path(path) as tmp, open(tmp, "wb") as handle, warnings.catch_warnings():
        # the package's metadata check warns that a points-only file has no analog channel
        warnings.filterwarnings("ignore", "No analog data found", UserWarning)
        writer.write(handle)
    return path
