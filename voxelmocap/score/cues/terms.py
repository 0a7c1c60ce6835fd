"""The likelihood terms ("cues"): the voxel likelihood and the image cues of papers 000 and 004.

Every cue maps ``(P, 27)`` states to ``(P,)`` log-likelihoods (up to a constant) given one
prepared frame (:class:`~voxelmocap.score.cues.frame.CueFrame`) and the states' projected contours
(:class:`Views`, computed once per call for all image cues). With several cameras an image cue
is the sum over cameras of its per-camera log-likelihood (views independent given the pose).

========== ================================================================ ====================
name       log-likelihood per camera                                        paper
========== ================================================================ ====================
voxel      −½ Σ_Y dᵀ Σ⁻¹ d over Out, DO, Empty, Surf (all cameras at once)   002 eqs 7–9
edges      −(ssd / M²) / (2σ²), σ² = 0.0025, on-the-fly edge search         000 §4.1.1, eq 13
dt         −D² / (2σ_e²), D = mean Canny distance at the visible contour      004 §III-B.1
roi        −D² / (2σ_ROI²), D = mean Bhattacharyya distance to references     004 §III-B.2
blob3d     −D² / (2σ_3D²), D = mean distance head/hands → voxel extremities   004 §III-B.3
skin       −D² / (2σ_s²), D = mean (1 − I_S) at projected head and hands       004 §III-B.4
uniform    −D² / (2σ_m²), D = mean colour standard deviation inside limbs     004 §III-B.5
silhouette −D / s, D = (uncovered silhouette + body outside it) / silhouette   —
========== ================================================================ ====================

``roi``, ``skin`` and ``uniform`` need reference appearances, learnt once from the frame and pose
the track starts from (:meth:`Cue.learn`); until then they contribute 0. ``skin`` applies to
colour cameras only; ``uniform`` to the parts whose colour is uniform in the reference frame
(standard deviation at most ``uniform_max_std``). ``voxel`` and ``blob3d`` need voxels carved
from at least two cameras.
"""

from __future__ import annotations

import numpy as np

from ...measure import _silhouette_kernels as _sk
from . import _cue_kernels as _k
from .contours import outline_pixels, project_contours

__all__ = ["CUES", "Cue", "Views", "bhattacharyya"]

#: Hand length as a share of the standing height (Drillis & Contini's segment table: 0.108).
HAND_SHARE = 0.108
#: Landmark indices (``voxelmocap.joints.LANDMARK_NAMES``) and part indices used here.
_L_WRIST, _R_WRIST, _HEAD_TOP = 4, 7, 14
_HEAD, _L_FOREARM, _R_FOREARM = 1, 3, 5
#: A part's histogram or colour spread needs at least this many visible samples.
MIN_SAMPLES = 4


def bhattacharyya(h1, h2) -> np.ndarray:
    """Bhattacharyya distance ``sqrt(1 − Σ sqrt(p q))`` of histograms along the last axis.

    Each histogram is normalised to sum 1 first (OpenCV's ``HISTCMP_BHATTACHARYYA``); an empty
    histogram is at distance 1 from everything.
    """
    h1 = np.asarray(h1, dtype=float)
    h2 = np.asarray(h2, dtype=float)
    s1 = h1.sum(axis=-1, keepdims=True)
    s2 = h2.sum(axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        bc = np.sqrt(h1 * h2).sum(axis=-1) / np.sqrt(s1 * s2)[..., 0]
    bc = np.where((s1[..., 0] > 0) & (s2[..., 0] > 0), bc, 0.0)
    return np.sqrt(np.clip(1.0 - bc, 0.0, 1.0))


class Views:
    """The states' geometry and, per camera, their projected contours (computed once per call).

    Attributes
    ----------
    states : (P, 27) ndarray
    kinematics : voxelmocap.body.kinematics.Kinematics
        Cone frames and landmarks (mm).
    geometry : voxelmocap.body.PartGeometry
    seg, valid, depth : list over cameras of the arrays of
        :func:`~voxelmocap.score.cues.contours.project_contours`.
    """

    def __init__(self, model, frame, states, *, with_contours: bool = True):
        from ...body.model import PartGeometry

        self.states = model.check(states, legal=True)
        # one forward-kinematics pass for the cones and the landmarks
        self.kinematics = model.forward(self.states)
        self.geometry = PartGeometry(self.kinematics, model.parts)
        self._model = model
        self._cameras = frame.cameras if with_contours and frame is not None else []
        self._contours = None

    def _projected(self):
        # on first use: the silhouette cue alone never needs the contours
        if self._contours is None:
            self._contours = [project_contours(self.geometry, cam) for cam in self._cameras]
        return self._contours

    @property
    def seg(self) -> list:
        return [s for s, _, _ in self._projected()]

    @property
    def valid(self) -> list:
        return [v for _, v, _ in self._projected()]

    @property
    def depth(self) -> list:
        return [d for _, _, d in self._projected()]

    @property
    def n(self) -> int:
        """Number of particles."""
        return self.states.shape[0]

    def points(self) -> dict[str, np.ndarray]:
        """``(P, 3)`` model points (mm): head top and centre, hand tips and centres."""
        geo = self.geometry
        kin = self.kinematics
        hand = HAND_SHARE * self._model.dimensions.height
        out = {"head_top": kin.joints[:, _HEAD_TOP],
               "head": geo.base[:, _HEAD] + 0.5 * geo.shape[_HEAD, 2] * geo.axis[:, _HEAD]}
        for side, wrist, forearm in (("l", _L_WRIST, _L_FOREARM), ("r", _R_WRIST, _R_FOREARM)):
            axis = geo.axis[:, forearm]
            out[f"{side}_hand_tip"] = kin.joints[:, wrist] + hand * axis
            out[f"{side}_hand"] = kin.joints[:, wrist] + 0.5 * hand * axis
        return out


class Cue:
    """A likelihood term. Subclasses set :attr:`name` and implement :meth:`__call__`."""

    name = ""
    #: needs voxels carved from at least two cameras
    needs_voxels = False
    #: needs the camera images
    needs_images = True
    #: needs reference appearances (:meth:`learn`)
    needs_reference = False

    def __init__(self, model, config, voxel=None):
        self.model = model
        self.config = config
        #: keyword arguments of :func:`voxelmocap.score.likelihood.log_likelihood` (variances,
        #: coverage) for the voxel cue, read at every call (the tracker owns the dict and may
        #: change the coverage for its start); None: the function's defaults
        self.voxel = {} if voxel is None else voxel
        self.learnt = False

    def learn(self, frame, views: Views) -> None:
        """Learn reference appearances from one frame and a single pose (``views.n == 1``)."""
        self.learnt = True

    def get_state(self) -> dict:
        """The learnt reference appearance as flat arrays (for checkpoints)."""
        return {}

    def set_state(self, state: dict) -> None:
        """Restore :meth:`get_state`."""
        self.learnt = True

    def __call__(self, frame, views: Views) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError


class VoxelCue(Cue):
    """Paper 002's voxel likelihood (:func:`voxelmocap.score.likelihood.log_likelihood`)."""

    name = "voxel"
    needs_voxels = True
    needs_images = False

    def __call__(self, frame, views):
        from ..likelihood import log_likelihood

        return log_likelihood(frame.observation, self.model, views.states, **self.voxel)


class EdgeCue(Cue):
    """Azad's on-the-fly edge search along the projected contours (paper 000 §4.1.1, eq 13)."""

    name = "edges"

    def __call__(self, frame, views):
        cfg = self.config
        c2 = float(cfg.edge_search) ** 2 if cfg.edge_c2 is None else cfg.edge_c2
        c3 = float(cfg.edge_search + 5) ** 2 if cfg.edge_c3 is None else cfg.edge_c3
        out = np.zeros(views.n)
        for c in range(len(frame)):
            ssd, count = _k.empty_outputs(views.n)
            _k.edge_ssd(views.seg[c], views.valid[c], views.depth[c], frame.grey(c),
                        float(cfg.edge_spacing), int(cfg.edge_search), float(cfg.edge_min_gradient),
                        float(cfg.edge_c1), c2, c3, bool(cfg.occlusion), ssd, count)
            # ssd / M² (the listing's return value); a view with no observed point costs C3
            value = np.where(count > 0, ssd / np.maximum(count, 1.0) ** 2, c3)
            out -= value / (2.0 * cfg.edge_variance)
        return out


class DistanceCue(Cue):
    """Fontmarty's edge distance: Canny distance map at the visible contour (004 §III-B.1)."""

    name = "dt"

    def __call__(self, frame, views):
        cfg = self.config
        out = np.zeros(views.n)
        for c in range(len(frame)):
            dt = frame.distance(c)
            total, count = _k.empty_outputs(views.n)
            _k.dt_sum(views.seg[c], views.valid[c], views.depth[c], dt, float(cfg.edge_spacing),
                      bool(cfg.occlusion), total, count)
            # nothing visible: as far from every edge as the image is wide
            d = np.where(count > 0, total / np.maximum(count, 1.0), float(max(dt.shape)))
            out -= d * d / (2.0 * cfg.sigma_dt ** 2)
        return out


class _RegionCue(Cue):
    """Shared sampling of the parts' image regions (histograms and colour moments)."""

    needs_reference = True

    def _stats(self, frame, views, c, n_levels):
        cfg = self.config
        bins, n_bins = frame.bins(c, n_levels)
        colour = frame.colour(c)
        n_s, n_t = cfg.roi_samples
        hist = np.zeros((views.n, self.model.n_parts, n_bins))
        moments = np.zeros((views.n, self.model.n_parts, 1 + 2 * colour.shape[2]))
        _k.region_stats(views.seg[c], views.valid[c], views.depth[c], bins, colour, int(n_s),
                        int(n_t), bool(cfg.occlusion), hist, moments)
        return hist, moments


class HistogramCue(_RegionCue):
    """ROI colour histograms against the reference frame's, Bhattacharyya distance (004 §III-B.2)."""

    name = "roi"

    def learn(self, frame, views):
        self.reference = []
        for c in range(len(frame)):
            hist, _ = self._stats(frame, views, c, self.config.histogram_bins)
            ok = hist[0].sum(axis=1) >= MIN_SAMPLES
            self.reference.append((hist[0], ok))
        self.learnt = True

    def get_state(self):
        out = {}
        for c, (ref, ok) in enumerate(self.reference):
            out[f"ref_{c}"], out[f"ok_{c}"] = ref, ok
        return out

    def set_state(self, state):
        n = len([k for k in state if k.startswith("ref_")])
        self.reference = [(np.asarray(state[f"ref_{c}"], float), np.asarray(state[f"ok_{c}"], bool))
                          for c in range(n)]
        self.learnt = True

    def __call__(self, frame, views):
        out = np.zeros(views.n)
        if not self.learnt:
            return out
        for c in range(len(frame)):
            ref, ok = self.reference[c]
            if not ok.any():
                continue
            hist, _ = self._stats(frame, views, c, self.config.histogram_bins)
            seen = (hist.sum(axis=2) >= MIN_SAMPLES) & ok[None]
            dist = bhattacharyya(hist, ref[None])
            n_seen = seen.sum(axis=1)
            d = np.where(n_seen > 0, (dist * seen).sum(axis=1) / np.maximum(n_seen, 1), 1.0)
            out -= d * d / (2.0 * self.config.sigma_roi ** 2)
        return out


class UniformCue(_RegionCue):
    """Colour uniformity inside the limbs (004 §III-B.5), where the reference shows it."""

    name = "uniform"

    @staticmethod
    def _spread(moments):
        n = np.maximum(moments[..., 0], 1.0)
        s1 = moments[..., 1::2]
        s2 = moments[..., 2::2]
        var = np.maximum(s2 / n[..., None] - (s1 / n[..., None]) ** 2, 0.0)
        return np.sqrt(var).mean(axis=-1)          # mean over channels of the std

    def learn(self, frame, views):
        self.applies = []
        for c in range(len(frame)):
            _, moments = self._stats(frame, views, c, 2)
            spread = self._spread(moments[0])
            ok = (moments[0, :, 0] >= MIN_SAMPLES) & (spread <= self.config.uniform_max_std)
            ok[_HEAD] = False   # a face is not a uniformly coloured limb
            self.applies.append(ok)
        self.learnt = True

    def get_state(self):
        return {f"applies_{c}": ok for c, ok in enumerate(self.applies)}

    def set_state(self, state):
        self.applies = [np.asarray(state[f"applies_{c}"], bool) for c in range(len(state))]
        self.learnt = True

    def __call__(self, frame, views):
        out = np.zeros(views.n)
        if not self.learnt:
            return out
        for c in range(len(frame)):
            ok = self.applies[c]
            if not ok.any():
                continue
            _, moments = self._stats(frame, views, c, 2)
            seen = (moments[..., 0] >= MIN_SAMPLES) & ok[None]
            spread = self._spread(moments)
            n_seen = seen.sum(axis=1)
            d = np.where(n_seen > 0, (spread * seen).sum(axis=1) / np.maximum(n_seen, 1),
                         self.config.uniform_max_std)
            out -= d * d / (2.0 * self.config.sigma_uniform ** 2)
        return out


class SkinCue(Cue):
    """Skin-colour probability at the projected head and hands (004 §III-B.4).

    The skin colour model is learnt from the reference frame: for every colour bin, the share of
    its pixels inside the projected head region (the head cone's quadrangle), divided by the
    largest such share, is ``I_S`` of that bin (a histogram back-projection). Grey cameras are
    not used.
    """

    name = "skin"
    needs_reference = True

    def learn(self, frame, views):
        import cv2

        self.tables = []
        for c in range(len(frame)):
            if not frame.is_colour(c) or not views.valid[c][0, _HEAD]:
                self.tables.append(None)
                continue
            bins, n_bins = frame.bins(c, self.config.skin_bins)
            quad = views.seg[c][0, _HEAD][[0, 0, 1, 1], [0, 1, 1, 0]]
            mask = np.zeros(bins.shape, np.uint8)
            cv2.fillConvexPoly(mask, np.round(quad).astype(np.int32), 1)
            head = np.bincount(bins[mask > 0], minlength=n_bins).astype(float)
            every = np.bincount(bins.ravel(), minlength=n_bins).astype(float)
            share = head / np.maximum(every, 1.0)
            self.tables.append(share / share.max() if share.max() > 0 else None)
        self.learnt = True

    def get_state(self):
        out = {"cameras": np.array(len(self.tables))}
        out.update({f"table_{c}": t for c, t in enumerate(self.tables) if t is not None})
        return out

    def set_state(self, state):
        self.tables = [None if f"table_{c}" not in state else np.asarray(state[f"table_{c}"], float)
                       for c in range(int(state["cameras"]))]
        self.learnt = True

    def __call__(self, frame, views):
        out = np.zeros(views.n)
        if not self.learnt:
            return out
        pts = views.points()
        world = np.stack([pts["head"], pts["l_hand"], pts["r_hand"]], axis=1)   # (P, 3, 3)
        for c, table in enumerate(self.tables):
            if table is None:
                continue
            bins, _ = frame.bins(c, self.config.skin_bins)
            uv = np.floor(frame.cameras[c].project(world.reshape(-1, 3)) + 0.5)
            h, w = bins.shape
            u = np.nan_to_num(uv[:, 0], nan=-1).astype(np.int64)
            v = np.nan_to_num(uv[:, 1], nan=-1).astype(np.int64)
            inside = (u >= 0) & (u < w) & (v >= 0) & (v < h)
            prob = np.zeros(len(u))
            prob[inside] = table[bins[v[inside], u[inside]]]
            d = (1.0 - prob).reshape(views.n, 3).mean(axis=1)
            out -= d * d / (2.0 * self.config.sigma_skin ** 2)
        return out


class BlobCue(Cue):
    """3D distance of the model's head and hands to the voxel extremities (004 §III-B.3).

    The voxel extremities (:func:`voxelmocap.measure.detect.find_extremities`: head, hand and foot tips,
    unlabelled) stand for Fontmarty's triangulated skin blobs; each model point is linked to its
    nearest extremity. No extremity: the cue contributes 0.
    """

    name = "blob3d"
    needs_voxels = True
    needs_images = False

    def __call__(self, frame, views):
        ex = frame.extremities
        if len(ex) == 0:
            return np.zeros(views.n)
        pts = views.points()
        model_pts = np.stack([pts["head_top"], pts["l_hand_tip"], pts["r_hand_tip"]], axis=1)
        dist = np.linalg.norm(model_pts[:, :, None, :] - ex[None, None], axis=-1).min(axis=2)
        d = dist.mean(axis=1)
        return -d * d / (2.0 * self.config.sigma_3d_mm ** 2)


class SilhouetteCue(Cue):
    """The projected body against each camera's silhouette.

    With few cameras the visual hull is several times the body (phantom volume between the
    views), and the voxel likelihood cannot tell the body from it; a silhouette pixel, though,
    must be covered by the body's image in its own view. Per camera
    ``D = (|S \\ M| + |M \\ S|) / |S|`` for the silhouette ``S`` and the body's image ``M``
    (the union of the parts' projected convex outlines, :func:`project_outlines`), both at
    ``silhouette_size`` pixels along the longer side; the log-likelihood is ``−D / s`` with
    ``s = silhouette_scale``. A camera whose silhouette is empty adds nothing. With
    ``silhouette_unseen = "ignore"`` (not the default), ``S \\ M`` counts only the silhouette
    pixels whose background the learnt plate has seen (``observation.known``).
    """

    name = "silhouette"

    def __call__(self, frame, views):
        cfg = self.config
        out = np.zeros(views.n)
        for c in range(len(frame)):
            mask, scale = frame.silhouette(c, cfg.silhouette_size)
            total = int(mask.sum())
            if total == 0:
                continue
            pixels, valid = outline_pixels(views.geometry, frame.cameras[c], scale)
            hit = np.empty(views.n, np.int64)
            extra = np.empty(views.n, np.int64)
            _sk.count_cover(pixels, valid, frame.silhouette_prefix(c, cfg.silhouette_size), hit,
                            extra)
            known = frame.silhouette_known(c, cfg.silhouette_size) \
                if cfg.silhouette_unseen == "ignore" else None
            if known is None:
                uncovered = total - hit
            else:
                # A silhouette pixel whose background was never seen is GrabCut's guess (often
                # a ghost beside the torso): leaving it uncovered costs nothing; body pixels
                # outside the silhouette still do.
                seen = np.ascontiguousarray(mask & known)
                hit_seen = np.empty(views.n, np.int64)
                _sk.cover_counts(pixels, valid, seen, hit_seen, np.empty(views.n, np.int64))
                uncovered = int(seen.sum()) - hit_seen
            out -= (uncovered + extra) / total / cfg.silhouette_scale
        return out


#: Cue name → class (the names of ``[cues] weights`` and ``track --cues``).
CUES: dict[str, type[Cue]] = {cls.name: cls for cls in (
    VoxelCue, EdgeCue, DistanceCue, HistogramCue, BlobCue, SkinCue, UniformCue, SilhouetteCue)}
