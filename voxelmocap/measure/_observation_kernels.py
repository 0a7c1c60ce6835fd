"""Numba kernel of :class:`voxelmocap.measure.observation.VoxelObservation`'s likelihood tables.

The prefix sums along z of the scene mask, the occupancy and the quantised smoothed surface are
what every likelihood kernel reads. NumPy builds them in four passes over the grid (quantise, then
one strided ``cumsum`` per table), single-threaded — about a third of a frame's filter time at the
paper's working point. One pass per (x, y) column, columns spread over the cores, gives the same
integers (``tests/measure/test_measurement.py`` compares it with the NumPy expressions).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange


@njit(cache=True, parallel=True)
def prefix_sums(scene, occupancy, smoothed, qmax, prefix):
    """Fill ``prefix`` (nx, ny, nz + 1, 3) int32 with the z prefix sums of the three tables.

    Parameters
    ----------
    scene, occupancy : (nx, ny, nz) bool ndarray
    smoothed : (nx, ny, nz) float ndarray
        Smoothed surface in [0, 1]; quantised as ``rint(float64(v) · qmax)``.
    qmax : int
    prefix : (nx, ny, nz + 1, 3) int32 ndarray
        Output; ``prefix[i, j, k, t]`` is the sum of table t over ``[i, j, :k]``.
    """
    nx, ny, nz = occupancy.shape
    for i in prange(nx):
        for j in range(ny):
            s = np.int32(0)
            o = np.int32(0)
            q = np.int32(0)
            prefix[i, j, 0, 0] = 0
            prefix[i, j, 0, 1] = 0
            prefix[i, j, 0, 2] = 0
            for k in range(nz):
                s += np.int32(scene[i, j, k])
                o += np.int32(occupancy[i, j, k])
                q += np.int32(np.rint(np.float64(smoothed[i, j, k]) * qmax))
                prefix[i, j, k + 1, 0] = s
                prefix[i, j, k + 1, 1] = o
                prefix[i, j, k + 1, 2] = q
