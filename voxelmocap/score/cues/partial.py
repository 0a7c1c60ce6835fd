"""The silhouette cue of poses that move only a few parts of a reference pose, re-scored exactly.

A limb search (:mod:`voxelmocap.pose.limb_search`) scores thousands of poses that differ from one
reference in one limb's angles: two cones move, eight stay. :class:`~voxelmocap.score.cues.terms.
SilhouetteCue` draws all ten in every view for every pose; :class:`PartialSilhouette` draws the
static parts once per view (:func:`~voxelmocap.measure._silhouette_kernels.draw_parts`, the
pixels exactly as the cue's kernel counts them) and counts only the moving parts against the
silhouette pixels and the background pixels those leave free. The counts are the whole cue's to
the pixel, so the values are the same to the bit (``tests/score/cues/test_partial_silhouette.py``),
as :class:`~voxelmocap.score.partial.PartialScorer` is for the voxels.
"""

from __future__ import annotations

import types

import numpy as np

from ...measure import _silhouette_kernels as _sk
from .contours import outline_pixels

__all__ = ["PartialSilhouette", "WeightedPartialSilhouette"]


def _geometry(model, states, parts=None):
    """The parts' cone geometry of ``(P, 27)`` states as the cues compute it
    (:class:`~voxelmocap.score.cues.terms.Views`), only ``parts`` when given."""
    from .terms import Views

    geo = Views(model, None, states).geometry
    if parts is None:
        return geo
    return types.SimpleNamespace(base=geo.base[:, parts], axis=geo.axis[:, parts],
                                 u1=geo.u1[:, parts], u2=geo.u2[:, parts],
                                 shape=geo.shape[parts])


class PartialSilhouette:
    """The silhouette cue's log-likelihood of states that move only ``parts`` of ``reference``.

    Parameters
    ----------
    frame : voxelmocap.score.cues.frame.CueFrame
        The frame's prepared images (its silhouettes and cameras).
    model : BodyModel
    config : voxelmocap.config.CuesConfig
        ``silhouette_size`` and ``silhouette_scale``; ``silhouette_unseen`` must be ``"count"``
        (the default: every silhouette pixel counts).
    reference : (27,) array_like
        The pose of the static parts (legal).
    parts : sequence of int
        The parts the states may move (every other part must be where ``reference`` puts it).
    """

    def __init__(self, frame, model, config, reference, parts):
        if config.silhouette_unseen != "count":
            raise ValueError("PartialSilhouette counts every silhouette pixel "
                             f"(silhouette_unseen = 'count'), got {config.silhouette_unseen!r}")
        self.model = model
        self.scale = float(config.silhouette_scale)
        self.parts = np.asarray(sorted({int(p) for p in parts}), dtype=np.int64)
        static = np.setdiff1d(np.arange(len(model.parts)), self.parts)
        geo = _geometry(model, np.asarray(reference, dtype=float)[None])
        #: per camera with a silhouette: (camera, mask scale, |S|, static parts' pixels inside
        #: and outside S, the row prefix sums of the pixels of S they leave free and of the
        #: background pixels they leave free)
        self.views = []
        for c in range(len(frame)):
            mask, scale = frame.silhouette(c, config.silhouette_size)
            total = int(mask.sum())
            if total == 0:
                continue                          # the cue adds nothing for this camera
            points, valid = outline_pixels(geo, frame.cameras[c], scale)
            drawn = np.zeros(mask.shape, np.bool_)
            _sk.draw_parts(np.ascontiguousarray(points[0, static]),
                           np.ascontiguousarray(valid[0, static]), drawn)
            self.views.append((frame.cameras[c], scale, total, int((drawn & mask).sum()),
                               int((drawn & ~mask).sum()), _sk.row_prefix(mask & ~drawn),
                               _sk.row_prefix(~mask & ~drawn)))

    def __call__(self, states) -> np.ndarray:
        """``(P,)`` the silhouette cue of ``(P, 27)`` states (unweighted), as
        :class:`~voxelmocap.score.cues.terms.SilhouetteCue` computes it."""
        states = np.atleast_2d(np.asarray(states, dtype=float))
        n = len(states)
        geo = _geometry(self.model, states, self.parts)
        out = np.zeros(n)
        hit, extra, scratch = (np.empty(n, np.int64) for _ in range(3))
        for camera, scale, total, hit0, extra0, free_in, free_out in self.views:
            points, valid = outline_pixels(geo, camera, scale)
            _sk.count_cover(points, valid, free_in, hit, scratch)
            _sk.count_cover(points, valid, free_out, extra, scratch)
            # the whole cue's integers, then its arithmetic in its order
            uncovered = total - (hit0 + hit)
            out -= (uncovered + (extra0 + extra)) / total / self.scale
        return out


class WeightedPartialSilhouette:
    """``(scorer, states) -> weight ×`` the silhouette cue of states moving the scorer's parts
    (:class:`~voxelmocap.pose.limb_search.LimbScoring`'s ``partial``): a
    :class:`PartialSilhouette` rebuilt when the scorer (the limb, or its reference pose)
    changes.

    Parameters
    ----------
    cues : voxelmocap.score.cues.CueSet
        Whose ``config`` holds the silhouette settings and whose frame cache prepares the images.
    observation : VoxelObservation
    weight : float
    """

    def __init__(self, cues, observation, weight: float):
        self.cues, self.frame, self.weight = cues, cues.prepare(observation), float(weight)
        self._scorer = self._partial = None

    def __call__(self, scorer, states) -> np.ndarray:
        if scorer is not self._scorer:
            self._scorer = scorer
            self._partial = PartialSilhouette(self.frame, self.cues.model, self.cues.config,
                                              scorer.reference, scorer.parts)
        return self.weight * self._partial(states)
