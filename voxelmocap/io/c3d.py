"""C3D export of landmark trajectories, through the ``c3d`` package (pure Python, as Pose2Sim).

The file holds one POINT per landmark, labelled with its name, at the run's frame rate
(``POINT:RATE``), in millimetres (``POINT:UNITS``), as 32-bit floats (``POINT:SCALE`` −1; their
resolution is below 0.001 mm within 8 m of the origin). The first frame (header and
``TRIAL:ACTUAL_START_FIELD``) is the first synchronised frame number; a C3D has no gaps, so
frames missing from the result are written as invalid points.

The **residual** channel (C3D: the reconstruction's error estimate, in the point units) holds each
landmark's particle spread (:func:`voxelmocap.pose.confidence.searched_spread`, the filter's own error
estimate) in whole millimetres, clipped to 1…255 mm (a residual of 0 means "interpolated" in
C3D, and the channel is one byte); −1 marks an invalid point (no estimate, or a frame without a
person), whose coordinates are written as zeros (the C3D convention; the ``c3d`` package's writer
would leave the previous frame's coordinates there, visible to readers that ignore the residual).
Unknown spreads (results before format 3) are written as 1 mm. The camera-mask byte is 0.

``POINT:X_SCREEN`` / ``POINT:Y_SCREEN`` say which axes point right and up on a viewer's screen:
``+X`` / ``+Z`` in the calibration's world frame (Z up), ``+X`` / ``+Y`` for OpenSim's Y-up axes
(``axes="y_up"``).

>>> import numpy as np, tempfile, pathlib
>>> path = pathlib.Path(tempfile.mkdtemp()) / "a.c3d"
>>> path = write_c3d(path, np.zeros((2, 1, 3)), ["head"], frame_rate=60.0, first_frame=1)
>>> path.stat().st_size % 512
0
"""

from __future__ import annotations

import io
import struct
import warnings
from pathlib import Path

import numpy as np

from ._atomic import atomic_path

__all__ = ["RESIDUAL_RANGE_MM", "SCREEN_AXES", "write_c3d"]

#: The residual byte's range (mm, at POINT:SCALE −1).
RESIDUAL_RANGE_MM = (1.0, 255.0)
#: POINT:X_SCREEN and POINT:Y_SCREEN of each export frame (which axes point right and up).
SCREEN_AXES = {"world": ("+X", "+Z"), "y_up": ("+X", "+Y")}


def write_c3d(path, positions, names, *, frame_rate: float, first_frame: int = 1,
              residuals=None, axes: str = "world") -> Path:
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
    axes : {"world", "y_up"}
        The frame of ``positions``, written as POINT:X_SCREEN / Y_SCREEN (:data:`SCREEN_AXES`).

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
    invalid = np.isnan(x).any(axis=2)
    res = np.where(invalid, -1.0, res)
    if axes not in SCREEN_AXES:
        raise ValueError(f"write_c3d: axes must be one of {sorted(SCREEN_AXES)}, got {axes!r}")

    writer = c3d.Writer(point_rate=float(frame_rate), analog_rate=0.0, point_scale=-1.0,
                        point_units="mm  ")
    writer.set_point_labels(names)
    writer.set_start_frame(int(first_frame))
    writer.set_screen_axis(*SCREEN_AXES[axes])
    empty = np.empty((0, 0))
    for i in range(len(x)):
        points = np.zeros((len(names), 5))
        points[:, :3] = np.nan_to_num(x[i])  # invalid points: 0, marked by the residual
        points[:, 3] = res[i]
        writer.add_frames([(points, empty)])
    buffer = io.BytesIO()
    with warnings.catch_warnings():
        # the package's metadata check warns that a points-only file has no analog channel
        warnings.filterwarnings("ignore", "No analog data found", UserWarning)
        writer.write(buffer)
    data = bytearray(buffer.getvalue())
    _zero_invalid(data, invalid)
    path = Path(path)
    with atomic_path(path) as tmp:
        tmp.write_bytes(bytes(data))
    return path


def _zero_invalid(data: bytearray, invalid: np.ndarray) -> None:
    """Zero the coordinates of invalid points in a float, points-only C3D file held in ``data``.

    The ``c3d`` writer (0.6) reuses one frame buffer and sets only the residual word of an
    invalid point, so its coordinates are the last valid frame's. The data section starts at
    the 512-byte block named by header word 9 (1-based); each frame is ``M`` points of four
    little-endian float32 words (x, y, z, residual/camera word) and no analog sample.
    """
    if data[1] != 0x50:
        raise ValueError("write_c3d: the c3d writer's output is not a C3D file")
    start = (struct.unpack_from("<H", data, 16)[0] - 1) * 512
    n, m = invalid.shape
    block = np.frombuffer(data, dtype="<f4", count=n * m * 4, offset=start).reshape(n, m, 4)
    block[..., :3][invalid] = 0.0
