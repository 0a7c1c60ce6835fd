"""Fusion of the cues: the global log-likelihood is the weighted sum of the selected cues' logs.

Fontmarty et al. (paper 004 §III-C) multiply the cue likelihoods, i.e. add their logs; a weight
per cue (``[cues] weights``) scales each log-likelihood, which is the same as raising its
likelihood to that power. :class:`CueSet` is built once from the config; the tracker asks it for
each frame's ``ll(states) -> (P,)`` (:meth:`CueSet.frame`), which prepares the frame's images once
(grey levels, Canny distance maps, colour bins; :class:`~voxelmocap.score.cues.frame.CueFrame`) and
computes the states' projected contours once per call for all image cues.

>>> from voxelmocap.body import BodyModel
>>> from voxelmocap.config import CuesConfig
>>> cues = CueSet(BodyModel(), CuesConfig())
>>> cues.names, cues.voxel_only
(('voxel',), True)
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ...config import check_cue_weights as check_weights
from ...errors import InputError
from .frame import CueFrame
from .terms import CUES, Views

__all__ = ["FUSED", "CueSet", "parse_cues"]


#: The measured fused selection (``docs/benchmarks.md``, "Image cues"): ``--cues fused``.
FUSED: dict[str, float] = {"voxel": 1.0, "roi": 4.0, "edges": 0.1}


def parse_cues(text: str, source: str = "--cues") -> dict[str, float]:
    """``"voxel,edges=0.5"`` → ``{"voxel": 1.0, "edges": 0.5}`` (a bare name has weight 1).

    ``fused`` stands for :data:`FUSED` (voxel, roi = 4, edges = 0.1).
    """
    weights: dict[str, float] = {}
    for item in (s.strip() for s in str(text).split(",")):
        if not item:
            continue
        name, _, value = item.partition("=")
        name = name.strip()
        if name == "fused" and not value.strip():
            weights.update(FUSED)
            continue
        if name not in CUES:
            raise InputError(source, f"unknown cue {name!r} (known: {', '.join(CUES)})")
        try:
            weights[name] = float(value) if value.strip() else 1.0
        except ValueError:
            raise InputError(source, f"weight of {name!r} must be a number, got {value!r}") from None
    if not weights:
        raise InputError(source, f"no cue given (known: {', '.join(CUES)})")
    return weights


class CueSet:
    """The selected cues and their weights, evaluated together.

    Parameters
    ----------
    model : BodyModel
    config : voxelmocap.config.CuesConfig
        ``weights`` selects the cues; the other fields are their parameters.
    voxel : dict, optional
        Keyword arguments of the voxel cue's :func:`voxelmocap.score.likelihood.log_likelihood`:
        ``variances`` (``[likelihood] variances``) and ``coverage`` (``[likelihood] coverage``).

    Attributes
    ----------
    names : tuple of str
    weights : (n_cues,) ndarray
    cues : dict of str to Cue
    """

    def __init__(self, model, config, *, voxel=None):
        check_weights(dict(config.weights), "cues")
        self.model = model
        self.config = config
        self.names = tuple(config.weights)
        self.weights = np.array([float(config.weights[n]) for n in self.names])
        self.cues = {n: CUES[n](model, config, voxel) for n in self.names}
        self._frame: tuple[object, CueFrame | None] | None = None

    @property
    def voxel_only(self) -> bool:
        """The voxel likelihood alone with weight 1 (the tracker's original callable)."""
        return self.names == ("voxel",) and bool(self.weights[0] == 1.0)

    def __repr__(self) -> str:
        return "CueSet(" + ", ".join(f"{n}={w:g}" for n, w in zip(self.names, self.weights,
                                                                    strict=True)) + ")"

    # ------------------------------------------------------------------ per frame
    def check_cameras(self, n_cameras: int, names=()) -> None:
        """Refuse cues that need voxels from at least two cameras when fewer are used."""
        if n_cameras >= 2:
            return
        bad = [n for n in self.names if self.cues[n].needs_voxels]
        if bad:
            _refuse(bad, n_cameras, names)

    @staticmethod
    def check_weights_for_cameras(weights: dict, cameras) -> None:
        """:meth:`check_cameras` for a selection of cue names and a list of camera names."""
        need = [n for n in weights if n in CUES and CUES[n].needs_voxels]
        cams = [c.strip() for c in cameras if c.strip()]
        if len(cams) < 2 and need:
            _refuse(need, len(cams), cams)

    def prepare(self, observation) -> CueFrame | None:
        """The frame's prepared images (cached for the last observation seen)."""
        if self._frame is not None and self._frame[0] is observation:
            return self._frame[1]
        cams = getattr(observation, "cameras", None)
        if cams is not None:
            self.check_cameras(len(cams), [c.name for c in cams])
        frame = None
        if any(c.needs_images for c in self.cues.values()):
            frame = CueFrame(observation, canny=self.config.canny)
        else:
            frame = _VoxelFrame(observation)
        self._frame = (observation, frame)
        return frame

    def learn(self, observation, state) -> None:
        """Learn the reference appearances of ``roi``, ``skin``, ``uniform`` from one pose."""
        frame = self.prepare(observation)
        views = Views(self.model, frame, np.atleast_2d(np.asarray(state, dtype=float))[:1])
        for cue in self.cues.values():
            if cue.needs_reference:
                cue.learn(frame, views)

    def get_state(self) -> dict:
        """The learnt reference appearances as flat ``cue_<name>_<key>`` arrays (checkpoints)."""
        out: dict = {}
        for name, cue in self.cues.items():
            if cue.needs_reference and cue.learnt:
                out.update({f"cue_{name}_{k}": np.asarray(v) for k, v in cue.get_state().items()})
                out[f"cue_{name}_learnt"] = np.array(True)
        return out

    def set_state(self, state: dict) -> None:
        """Restore :meth:`get_state` (keys of cues not selected are ignored)."""
        for name, cue in self.cues.items():
            if f"cue_{name}_learnt" in state:
                prefix = f"cue_{name}_"
                cue.set_state({k[len(prefix):]: v for k, v in state.items()
                               if k.startswith(prefix) and k != f"cue_{name}_learnt"})

    @property
    def needs_reference(self) -> bool:
        """Some cue still waits for its reference appearance."""
        return any(c.needs_reference and not c.learnt for c in self.cues.values())

    def evaluate(self, observation, states, names=None) -> dict[str, np.ndarray]:
        """Each selected cue's log-likelihood ``(P,)`` (unweighted), in :attr:`names` order
        (only ``names`` when given)."""
        names = self.names if names is None else tuple(names)
        frame = self.prepare(observation)
        images = any(self.cues[n].needs_images for n in names)
        views = Views(self.model, frame if images else None, states)
        return {n: np.asarray(self.cues[n](frame, views), dtype=float) for n in names}

    def log_likelihood(self, observation, states, *, without=()) -> np.ndarray:
        """The fused log-likelihood ``Σ_c w_c log p_c`` of ``(P, 27)`` states → ``(P,)``, over
        the selected cues not named in ``without``."""
        names = [n for n in self.names if n not in without]
        return self.combine(self.evaluate(observation, states, names),
                            len(np.atleast_2d(states)))

    def combine(self, values: dict, n_states: int) -> np.ndarray:
        """``Σ_c w_c values[c]`` ``(n_states,)`` over the cues present in ``values`` (each
        ``(n_states,)``), summed in :attr:`names` order (so that a value computed elsewhere,
        e.g. the voxel cue's from part scores already counted, gives the same sum to the bit)."""
        total = np.zeros(n_states)
        for name, w in zip(self.names, self.weights, strict=True):
            if name in values:
                total += w * values[name]
        return total

    def frame(self, observation, reference=None, *, without=()
              ) -> Callable[[np.ndarray], np.ndarray]:
        """The filter's per-frame callable ``(P, 27) → (P,)``.

        Parameters
        ----------
        observation : VoxelObservation
            The frame (with its images when an image cue is selected).
        reference : (27,) array_like or callable returning one, optional
            The pose to learn reference appearances from, when a cue still needs them (the
            tracker passes the pose it starts from).
        without : sequence of str
            Cues left out of the sum (the hierarchical search scores the voxel cue itself).
        """
        if self.voxel_only and not without:
            from ..likelihood import log_likelihood

            cams = getattr(observation, "cameras", None)
            if cams is not None:
                self.check_cameras(len(cams), [c.name for c in cams])

            kw = self.cues["voxel"].voxel
            return lambda states: log_likelihood(observation, self.model, states, **kw)
        self.prepare(observation)
        if self.needs_reference and reference is not None:
            state = reference() if callable(reference) else reference
            if state is not None:
                self.learn(observation, state)
        return lambda states: self.log_likelihood(observation, states, without=without)


def _refuse(cues, n_cameras, names):
    which = f" ({', '.join(names)})" if names else ""
    raise InputError("cues", f"the {' and '.join(cues)} cue{'s' if len(cues) > 1 else ''} "
                             f"need{'' if len(cues) > 1 else 's'} voxels carved from at least "
                             f"two cameras, this run has {n_cameras}{which}; use image cues "
                             "only, e.g. --cues edges,roi")


class _VoxelFrame:
    """The frame of cues that read only the voxels."""

    def __init__(self, observation):
        self.observation = observation
        self.cameras = []

    def __len__(self) -> int:
        return 0

    @property
    def extremities(self) -> np.ndarray:
        if not hasattr(self, "_ex"):
            from ...measure.detect import find_extremities

            obs = self.observation
            ex = find_extremities(obs.occupancy, obs.grid)
            self._ex = np.empty((0, 3)) if ex is None else np.asarray(ex.points, dtype=float)
        return self._ex
