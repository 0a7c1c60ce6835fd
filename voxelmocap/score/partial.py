"""The voxel likelihood when only some parts move: exact partial re-scoring.

A limb layer of the hierarchical search (:mod:`voxelmocap.pose.hierarchy`) varies the four angles of
one limb while every other dimension is held at a reference pose. The parts outside the limb then
keep their voxels, so their Out, Occ and Surf counts are computed once per layer; only their
double occupancy (DO) can change, where the moving limb enters them. :class:`PartialScorer`
finds the static parts' runs once (``_partial_kernels.static_runs``) and, per particle,
rasterises the moving parts only (``_partial_kernels.partial_counts``). A limb layer costs two
cones per particle instead of ten, and the counts equal :func:`voxelmocap.score.likelihood.part_counts`
of the full state exactly (integers; ``tests/score/test_partial_likelihood.py``).

>>> import numpy as np
>>> from voxelmocap.body import BodyModel
>>> from voxelmocap.grid import VoxelGrid
>>> from voxelmocap.score.likelihood import Measurement, part_counts, rasterise
>>> model = BodyModel()
>>> grid = VoxelGrid((-1000.0, -1000.0, 0.0), 40.0, (50, 50, 50))
>>> x = model.default_state()
>>> seen = Measurement(rasterise(model, x[None], grid) > 0, grid)
>>> arm = PartialScorer(seen, model, x, parts=(2, 3), dims=(11, 12, 13, 17))
>>> xs = np.repeat(x[None], 3, axis=0); xs[:, 11] = (0.0, 0.5, 1.0)
>>> bool(np.array_equal(arm.counts(xs), part_counts(seen, model, xs)))
True
"""

from __future__ import annotations

import numpy as np

from ..thread_waits import serial
from . import _partial_kernels as _pk
from . import _raster_kernels as _k
from .likelihood import DEFAULT_VARIANCES, QMAX, VoxelObservation, log_likelihood_from_counts

__all__ = ["PartialScorer"]


class PartialScorer:
    """Counts and log-likelihoods of states that differ from ``reference`` only in ``dims``.

    Parameters
    ----------
    observation : VoxelObservation
    model : BodyModel
    reference : (27,) array_like
        The pose of the static parts (legal; mm, rad).
    parts : sequence of int
        Indices of the parts that ``dims`` move (every other part must not depend on them).
    dims : sequence of int
        The state dimensions that may differ from ``reference``.
    check : bool
        Verify on every call that the other dimensions equal the reference (cheap).
    """

    def __init__(self, observation: VoxelObservation, model, reference, parts, dims, *,
                 check: bool = True):
        self.observation, self.model = observation, model
        self.reference = np.asarray(reference, dtype=float).reshape(-1)
        self.parts = np.asarray(sorted(set(int(p) for p in parts)), dtype=np.int64)
        n_parts = len(model.parts)
        self.static = np.asarray([q for q in range(n_parts) if q not in set(self.parts)],
                                 dtype=np.int64)
        self.dims = np.zeros(self.reference.size, dtype=bool)
        self.dims[list(dims)] = True
        self.check = check
        geo = model.geometry(self.reference[None], legal=True)
        g = observation.grid
        # The static parts' own counts (DO among themselves included), once.
        self._static_counts = np.zeros((n_parts, _k.N_COUNTS), dtype=np.int64)
        if self.static.size:
            sub = np.zeros((1, self.static.size, _k.N_COUNTS), dtype=np.int64)
            _k.part_counts(geo.base[:, self.static], geo.axis[:, self.static],
                           geo.u1[:, self.static], geo.u2[:, self.static],
                           np.ascontiguousarray(geo.shape[self.static]), *g.origin,
                           g.voxel_size, observation.prefix, observation.prefix_lattice, QMAX,
                           1, sub)
            self._static_counts[self.static] = sub[0]
        self._box = np.zeros(6, dtype=np.int64)
        args = (geo.base[:, self.static], geo.axis[:, self.static], geo.u1[:, self.static],
                geo.u2[:, self.static], np.ascontiguousarray(geo.shape[self.static]),
                *g.origin, g.voxel_size)
        if self.static.size:
            _pk.static_box(*args, self._box)
        # each static part's run in each column of their box (klo > khi: none)
        self._table = np.empty((*(int(s) for s in self._box[3:5]), self.static.size, 2),
                               dtype=np.int64)
        self._table[..., 0] = 1
        self._table[..., 1] = 0
        if self.static.size:
            _pk.static_runs(*args, self._box, self._table)
        self._shape = np.ascontiguousarray(geo.shape[self.parts])

    def counts(self, states) -> np.ndarray:
        """(P, n_parts, 6) integer counts, equal to ``part_counts`` of the full states."""
        x = np.asarray(states, dtype=float)
        if self.check and not np.array_equal(x[:, ~self.dims],
                                             np.broadcast_to(self.reference[~self.dims],
                                                             (x.shape[0], int((~self.dims).sum())))):
            raise ValueError("PartialScorer: states differ from the reference outside dims")
        geo = self.model.geometry(x, legal=True)
        g = self.observation.grid
        n = x.shape[0]
        moving = np.zeros((n, self.parts.size, _k.N_COUNTS), dtype=np.int64)
        static_do = np.zeros((n, len(self.model.parts)), dtype=np.int64)
        p = self.parts
        count = _pk.partial_counts_serial if serial(n) else _pk.partial_counts
        count(np.ascontiguousarray(geo.base[:, p]), np.ascontiguousarray(geo.axis[:, p]),
              np.ascontiguousarray(geo.u1[:, p]), np.ascontiguousarray(geo.u2[:, p]),
              self._shape, *g.origin, g.voxel_size, self.observation.prefix,
              self.observation.prefix_lattice, QMAX, self._box, self._table, self.static,
              _k.default_chunks(), moving, static_do)
        out = np.repeat(self._static_counts[None], n, axis=0)
        out[:, :, 2] += static_do
        out[:, p] = moving
        return out

    def log_likelihood(self, states, *, variances=DEFAULT_VARIANCES,
                       coverage: float = 0.0) -> np.ndarray:
        """(P,) log-likelihoods, equal to :func:`voxelmocap.score.likelihood.log_likelihood`."""
        return log_likelihood_from_counts(self.observation, self.counts(states),
                                          variances=variances, coverage=coverage)

