"""The subject's body size from the voxels of the first frames, when there is no body file.

Without a body file the tracker starts with the average adult scaled to the height of the first
frame's voxels (``[init] body = "voxels"``), but people differ from the average in proportion,
not only in size: on the benchmark subjects the body files' forearms are 0.77–0.87 of the
average's, their hips hang 0–10 mm below the pelvis where the average has 60 mm, and such
errors stay in the track as constant offsets of the knees, head and shoulders.

:func:`fit_body_dimensions` fits the skeleton lengths to the voxels of a few frames whose poses
the tracker has already estimated (with the height-scaled average): it maximises the summed voxel
log-likelihood (:func:`voxelmocap.score.likelihood.log_likelihood`, the tracker's own kernel) over one
factor per length (left and right alike) by compass search
(:func:`voxelmocap.tracking.refine.pattern_search`), alternating with a compass search of each
frame's pose under the current lengths, so that lengths and poses stay consistent. Each candidate
body is scored with the poses re-aimed at the same elbows, wrists, knees and ankles
(:func:`voxelmocap.body.retarget`): with the angles held, a narrower shoulder would swing the arm
into the chest and never win, and the fitted shoulders stayed at the average adult's (1.4–1.6
times the benchmark subjects'). The fit leaves out the likelihood's double-occupancy term: real
bodies overlap at the shoulders (a motion-capture skeleton's shoulder joint sits inside the
chest), and the term pushed the fitted shoulders outwards. Bent knees and elbows make lengths
observable; frames spread over the first ones are used. The factors are bounded to
:data:`FACTOR_RANGES` (a plausible adult range around the average), the widths stay those of the
average adult at the voxel height.

:func:`refit_start` is the tracker's side: fit on the frames tracked so far, at frame 1's
voxel height and at the standing height the frames' voxels and poses imply
(:func:`standing_height_from_poses`: a crouch or a stride in frame 1 does not then shrink the
body), keep the fit that explains the frames better, then track them again from the fitted first
pose with the fitted body, so that every recorded frame comes from the final body. The runner
(:func:`voxelmocap.run.pipeline.track_sequence`) calls it when ``[init] body = "fitted"``; the
dimensions are stored in the result file (``body_dimensions``) and re-read on ``--resume``.

>>> dims = BodyDimensions.average(1700.0)
>>> d2 = dimensions_from_factors(dims, np.ones(len(FITTED_KEYS)))
>>> round(d2.height)     # the average adult's skeleton chain gives its height
1700
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, replace

import numpy as np

from ..body import BodyModel, retarget
from ..body.shapes import ANKLE_HEIGHT_SHARE, BodyDimensions
from ..errors import InputError
from ..frames import spread_indices
from ..score.likelihood import (
    DEFAULT_VARIANCES,
    coverage_log_likelihood,
    log_likelihood_from_scores,
    part_counts,
    scores_from_counts,
)

__all__ = ["DEFAULT_FIT_KEYS", "FACTOR_RANGES", "FITTED_KEYS", "HEIGHT_AGREEMENT", "HEIGHT_KEYS",
           "HEIGHT_RANGE_MM", "START_COVERAGE", "BodyFit", "compass_combined",
           "dimensions_from_factors", "dimensions_from_json", "dimensions_to_json",
           "fit_body_dimensions", "pick_frames", "posed_height_share", "refit_start", "rescaled",
           "standing_height", "standing_height_from_poses", "voxel_height_mm"]

#: The fitted skeleton lengths (fields of :class:`BodyDimensions`); pairs keep left = right.
FITTED_KEYS: tuple[str, ...] = ("torso", "head", "shoulder_offset", "shoulder_drop",
                                "hip_offset", "hip_drop", "upper_arm", "forearm", "thigh",
                                "shin")
#: Bounds of each factor (fitted length / the average adult's at the same height). Segment
#: lengths of adults of one stature vary by about ±15 % (2 s.d., e.g. the ANSUR II survey); the
#: joint offsets, which depend on where a motion-capture skeleton puts its joints, are allowed
#: more (the benchmark subjects' body files: shoulder offset 0.55–0.99, shoulder drop 0.8–1.6,
#: hip drop 0.01–0.08 of the average's).
FACTOR_RANGES: dict[str, tuple[float, float]] = {
    "torso": (0.8, 1.2), "head": (0.8, 1.35),
    "shoulder_offset": (0.5, 1.2), "shoulder_drop": (0.0, 2.5),
    "hip_offset": (0.6, 1.4), "hip_drop": (0.0, 1.5),
    "upper_arm": (0.8, 1.2), "forearm": (0.7, 1.2),
    "thigh": (0.8, 1.2), "shin": (0.8, 1.2),
}
#: Plausible standing heights (mm). The voxels' vertical extent is the height of a standing
#: person; raised arms or a crouch move it, and outside this range it is more likely that than
#: a person of that size.
HEIGHT_RANGE_MM = (1400.0, 2100.0)
#: How far below the median of a few frames' standing heights one may read and still count
#: (share of it): a pose's share and the voxels' crown are a few percent off; a head that did
#: not carve is about 15 % (:func:`standing_height_from_poses`).
HEIGHT_AGREEMENT = 0.05
#: The lengths of the standing chain, head top to ankle (:func:`standing_height`).
HEIGHT_KEYS: tuple[str, ...] = ("torso", "head", "hip_drop", "thigh", "shin")
#: The lengths fitted by default: all but the forearm. On the rendered benchmark subjects the
#: forearm cone also takes in the hand (which the cone model lacks), and its fitted length varied
#: from 0.71 to 1.38 of the body file's with the motion (``scripts/study_body_size.py``), where the
#: average adult's is 1.00–1.17.
DEFAULT_FIT_KEYS: tuple[str, ...] = tuple(k for k in FITTED_KEYS if k != "forearm")
# First compass steps: lengths 8 % of their value (drops: 0.5 of the average's), poses 20 mm and
# 0.06 rad; the search halves them down to 1/16.
_FACTOR_STEP = {"shoulder_drop": 0.5, "hip_drop": 0.5}
_DEFAULT_FACTOR_STEP = 0.08
_POSE_STEP = np.r_[np.full(3, 20.0), np.full(24, 0.06)]
# Root heights (mm) a candidate body is scored at, around each frame's pose (see _frames_ll).
_ROOT_SHIFTS = np.arange(-40.0, 41.0, 10.0)


@dataclass(frozen=True)
class BodyFit:
    """What :func:`fit_body_dimensions` found.

    Attributes
    ----------
    dimensions : BodyDimensions
        The fitted subject.
    factors : (len(FITTED_KEYS),) ndarray
        Fitted length / the start's length (mean of left and right), in :data:`FITTED_KEYS`
        order.
    states : (F, 27) ndarray
        The frames' poses re-estimated with the fitted body.
    log_likelihood : float
        Summed log-likelihood of the frames, fitted body and poses.
    start_log_likelihood : float
        The same for the starting body and poses.
    evaluations : int
        Likelihood evaluations spent (one state of one frame each).
    other : BodyFit or None
        :func:`refit_start`'s fit at the other standing height (the voxels' of frame 1, or
        the one the poses imply), which explained the frames less well; ``None`` when only one
        was fitted.
    """

    dimensions: BodyDimensions
    factors: np.ndarray
    states: np.ndarray
    log_likelihood: float
    start_log_likelihood: float
    evaluations: int
    other: BodyFit | None = None


def standing_height(dims: BodyDimensions) -> float:
    """Standing height (mm) of a skeleton: head top → ankle chain plus the ankle height (as
    :meth:`BodyDimensions.from_landmarks` defines it)."""
    chain = (dims.head + dims.torso + float(np.mean(dims.hip_drop)) + float(np.mean(dims.thigh))
             + float(np.mean(dims.shin)))
    return chain / (1.0 - ANKLE_HEIGHT_SHARE)


def dimensions_from_factors(base: BodyDimensions, factors, *,
                            keep_height: bool = False) -> BodyDimensions:
    """``base`` with each length of :data:`FITTED_KEYS` multiplied by its factor.

    Pairs get the mean of the base's left and right times the factor on both sides; the widths
    are kept; the height is the skeleton's :func:`standing_height`.

    Parameters
    ----------
    base : BodyDimensions
    factors : (len(FITTED_KEYS),) array_like
        Finite, ≥ 0.
    keep_height : bool
        Scale the lengths of the standing chain (:data:`HEIGHT_KEYS`) together afterwards so
        that the standing height stays ``base.height``: the factors then set the chain's
        proportions, the measured height its sum.
    """
    f = np.asarray(factors, dtype=float)
    if f.shape != (len(FITTED_KEYS),) or not np.all(np.isfinite(f)) or np.any(f < 0):
        raise ValueError(f"factors must be {len(FITTED_KEYS)} finite values >= 0")
    changes = {}
    for key, k in zip(FITTED_KEYS, f, strict=True):
        value = getattr(base, key)
        if isinstance(value, tuple):
            v = float(np.mean(value)) * float(k)
            changes[key] = (v, v)
        else:
            changes[key] = float(value) * float(k)
    dims = base.replace(**changes)
    height = standing_height(dims)
    if keep_height and height > 0:
        s = base.height / height
        dims = dims.replace(**{k: (getattr(dims, k)[0] * s, getattr(dims, k)[1] * s)
                               if isinstance(getattr(dims, k), tuple) else getattr(dims, k) * s
                               for k in HEIGHT_KEYS})
        height = standing_height(dims)
    return dims.replace(height=height)


def dimensions_to_json(dims: BodyDimensions) -> str:
    """The dimensions as one JSON line (for a result file's attributes)."""
    return json.dumps(asdict(dims), sort_keys=True)


def dimensions_from_json(text, *, source: str = "body_dimensions") -> BodyDimensions:
    """Inverse of :func:`dimensions_to_json`; bad text raises :class:`InputError`."""
    try:
        data = json.loads(str(text))
        data = {k: tuple(float(x) for x in v) if isinstance(v, list) else float(v)
                for k, v in data.items()}
        return BodyDimensions(**data)
    except (ValueError, TypeError) as exc:
        raise InputError(source, f"not a body's dimensions: {exc}") from None


def pick_frames(n_frames: int, n_fit: int) -> np.ndarray:
    """Indices of ``n_fit`` frames spread evenly over ``n_frames`` (all when fewer)."""
    return spread_indices(n_frames, n_fit)


def _bounds():
    lo = np.array([FACTOR_RANGES[k][0] for k in FITTED_KEYS])
    hi = np.array([FACTOR_RANGES[k][1] for k in FITTED_KEYS])
    return lo, hi


def compass_combined(log_likelihood, x0, steps, *, low, high, max_evaluations: int,
                     min_step: float = 1.0 / 16.0, f0: float | None = None):
    """Maximise ``log_likelihood`` from ``x0`` by a compass search that moves every coordinate.

    Each iteration scores ``x ± step_i e_i`` for all ``i`` in one batch, then the sum of every
    coordinate's better improving move; it keeps the best of these candidates. A coordinate whose
    two moves both fail has its step halved. Unlike
    :func:`voxelmocap.tracking.refine.pattern_search` (one coordinate per iteration) it adjusts
    a whole pose in a few iterations, which the alternation of lengths and poses needs.

    Parameters
    ----------
    log_likelihood : callable
        ``(P, D) -> (P,)``.
    x0 : (D,) ndarray
        Start.
    steps : (D,) ndarray
        First step per coordinate (> 0; 0 keeps the coordinate fixed).
    low, high : (D,) ndarray
        Bounds; candidates are clipped into them.
    max_evaluations : int
        Budget (the start's own evaluation included when ``f0`` is None).
    min_step : float
        A coordinate stops moving below this fraction of its first step.
    f0 : float, optional
        ``log_likelihood(x0)`` when known.

    Returns
    -------
    x : (D,) ndarray
    f : float
    evaluations : int
    """
    x = np.array(x0, dtype=float)
    step = np.array(steps, dtype=float)
    floor = min_step * step
    used = 0
    if f0 is None:
        f0 = float(log_likelihood(x[None])[0])
        used = 1
    f = float(f0)
    while True:
        live = np.flatnonzero((step >= floor) & (step > 0))
        n = live.size
        if n == 0 or used + 2 * n + 1 > max_evaluations:
            break
        rows = np.arange(n)
        cand = np.repeat(x[None], 2 * n, axis=0)
        cand[rows, live] += step[live]
        cand[n + rows, live] -= step[live]
        np.clip(cand, low, high, out=cand)
        fc = np.asarray(log_likelihood(cand), dtype=float)
        used += 2 * n
        plus, minus = fc[:n], fc[n:]
        better = np.maximum(plus, minus)
        gain = better > f
        step[live[~gain]] *= 0.5
        if not gain.any():
            continue
        best = int(np.argmax(fc))
        x_best, f_best = cand[best], float(fc[best])
        if gain.sum() > 1:
            combo = x.copy()
            use = live[gain]
            combo[use] = np.where(plus[gain] >= minus[gain], cand[rows[gain], use],
                                  cand[n + rows[gain], use])
            np.clip(combo, low, high, out=combo)
            f_combo = float(log_likelihood(combo[None])[0])
            used += 1
            if f_combo > f_best:
                x_best, f_best = combo, f_combo
        x, f = x_best, f_best
    return x, f, used


def _objective(observation, model, states, variances, coverage,
               double_occupancy=True) -> np.ndarray:
    """(P,) the tracker's voxel log-likelihood, plus the coverage term when ``coverage`` > 0;
    without the double-occupancy term unless ``double_occupancy``."""
    counts = part_counts(observation, model, states, clip=True)
    scores = scores_from_counts(counts)
    if not double_occupancy:
        scores[..., 1] = 0.0
    ll = log_likelihood_from_scores(scores, variances=variances)
    if coverage:
        ll = ll + coverage_log_likelihood(observation, counts, coverage)
    return ll


def _frames_ll(observations, states, dims, variances, shifts=(0.0,), coverage=0.0,
               double_occupancy=True):
    """Each frame's log-likelihood under one body, best over root heights.

    Returns ``(F,)`` log-likelihoods and ``(F,)`` the shift of the root height (mm, of
    ``shifts``) that scored it: longer legs lift the pelvis, and without that freedom a change of
    a leg's length is judged with the feet pushed into the floor or lifted off it.
    """
    model = BodyModel(dims)
    shifts = np.asarray(shifts, dtype=float)
    values, best = np.empty(len(states)), np.empty(len(states))
    for i, (obs, x) in enumerate(zip(observations, states, strict=True)):
        cand = np.repeat(x[None], shifts.size, axis=0)
        cand[:, 2] += shifts
        ll = _objective(obs, model, cand, variances, coverage, double_occupancy)
        j = int(np.argmax(ll))
        values[i], best[i] = ll[j], shifts[j]
    return values, best


def fit_body_dimensions(observations, states, base: BodyDimensions, *,
                        variances=DEFAULT_VARIANCES, rounds: int = 3,
                        length_evaluations: int = 200, pose_evaluations: int = 300,
                        keep_height: bool = True, keys=DEFAULT_FIT_KEYS,
                        coverage: float = 0.0, retarget_poses: bool = True,
                        double_occupancy: bool = False) -> BodyFit:
    """Fit the skeleton lengths (and re-fit the poses) to the voxels of a few frames.

    Each round runs a compass search over the factors of :data:`FITTED_KEYS` (bounded by
    :data:`FACTOR_RANGES`) maximising the frames' summed log-likelihood with the poses held, then
    a compass search of every frame's 27 pose dimensions with the lengths held.

    Parameters
    ----------
    observations : sequence of voxelmocap.measure.observation.VoxelObservation
        F measured frames.
    states : (F, 27) array_like
        Their estimated poses under ``base`` (e.g. the tracker's estimates).
    base : BodyDimensions
        The starting body (the factors are relative to it and the bounds too).
    variances : 4 floats
        The likelihood's variances (the tracker's).
    rounds : int
        Alternations of lengths and poses (≥ 1).
    length_evaluations : int
        Bodies tried per round (each scored on all F frames).
    pose_evaluations : int
        Poses tried per frame and round.
    keep_height : bool
        Keep ``base``'s standing height (the voxels' measured height) and fit the proportions
        of the standing chain (see :func:`dimensions_from_factors`). Without it, a standing
        subject's legs can shrink into the visual hull (the likelihood has no term for occupied
        voxels that no part explains).
    keys : iterable of str
        The lengths fitted (of :data:`FITTED_KEYS`); the others keep ``base``'s.
    coverage : float
        Weight of the term for the occupied voxels no part contains
        (:func:`voxelmocap.score.likelihood.coverage_log_likelihood`) in this fit (0: none; the
        tracker's own weight is ``[likelihood] coverage``).
    retarget_poses : bool
        Score each candidate body with the poses re-aimed at the same elbows, wrists, knees and
        ankles (:func:`voxelmocap.body.retarget`) instead of with the same angles: a narrower
        shoulder then keeps the arm on the arm's voxels rather than swinging it into the chest,
        so joint offsets and lengths can move without their poses following one step behind.
    double_occupancy : bool
        Keep the likelihood's double-occupancy term (DO) in the fit. Off by default: real bodies
        (and the benchmark's rendered ones) overlap at the shoulders, where a motion-capture
        skeleton puts the joint inside the chest, so DO pushes the fitted shoulders outwards
        (1.37–1.55 of the body files' offsets with it, 1.21–1.36 without). Five clips without
        the answer, 3 seeds: 56.3 → 54.9 mm (docs/benchmarks.md). The tracker keeps DO.

    Returns
    -------
    BodyFit
    """
    states = np.array(states, dtype=float, ndmin=2)
    if len(observations) != len(states) or len(states) == 0:
        raise ValueError("need one state per observation, at least one")
    if rounds < 1:
        raise ValueError("rounds must be >= 1")
    lo, hi = _bounds()
    factors = np.ones(len(FITTED_KEYS))
    keys = set(keys)
    if not keys <= set(FITTED_KEYS):
        raise ValueError(f"keys must be among {FITTED_KEYS}")
    steps = np.array([_FACTOR_STEP.get(k, _DEFAULT_FACTOR_STEP) if k in keys else 0.0
                      for k in FITTED_KEYS])
    used = 0
    pose_low, pose_high = BodyModel(base).low, BodyModel(base).high
    states = BodyModel(base).clip(states)
    start = float(_frames_ll(observations, states, base, variances, coverage=coverage,
                             double_occupancy=double_occupancy)[0].sum())
    used += len(states)
    f_total = start
    for _ in range(rounds):
        held = states
        held_model = BodyModel(dimensions_from_factors(base, factors, keep_height=keep_height))

        def poses_for(model, held=held, held_model=held_model):
            return retarget(held_model, model, held) if retarget_poses else held.copy()

        def body_ll(cands):
            out = []
            for c in cands:
                dims_c = dimensions_from_factors(base, c, keep_height=keep_height)
                out.append(_frames_ll(observations, poses_for(BodyModel(dims_c)), dims_c,
                                      variances, _ROOT_SHIFTS, coverage,
                                      double_occupancy)[0].sum())
            return np.array(out)

        if retarget_poses:  # the held poses' own score, re-aimed like every candidate's
            f_total = float(body_ll([factors])[0])
            used += len(states) * len(_ROOT_SHIFTS)
        factors, f_total, n = compass_combined(body_ll, factors, steps, low=lo, high=hi,
                                               max_evaluations=length_evaluations, f0=f_total)
        used += n * len(states) * len(_ROOT_SHIFTS)
        dims = dimensions_from_factors(base, factors, keep_height=keep_height)
        model = BodyModel(dims)
        states = poses_for(model)
        states[:, 2] += _frames_ll(observations, states, dims, variances, _ROOT_SHIFTS,
                                   coverage, double_occupancy)[1]
        total = 0.0
        new = np.empty_like(states)
        for i, (obs, x) in enumerate(zip(observations, states, strict=True)):
            def pose_ll(cands, obs=obs, model=model):
                return _objective(obs, model, cands, variances, coverage, double_occupancy)

            new[i], f, n = compass_combined(pose_ll, x, _POSE_STEP, low=pose_low,
                                            high=pose_high, max_evaluations=pose_evaluations)
            used += n
            total += f
        states, f_total = new, total
    dims = dimensions_from_factors(base, factors, keep_height=keep_height)
    ratios = np.array([np.mean(getattr(dims, k)) / max(np.mean(getattr(base, k)), 1e-9)
                       for k in FITTED_KEYS])
    return BodyFit(dims, ratios, states, f_total, start, used)


def posed_height_share(model, states) -> np.ndarray:
    """How much of its standing height each pose stands: head top to the lower sole, over
    the standing height.

    1 for the upright pose; a crouch, bent knees or a lean lower it (a jogger's stride:
    about 0.9). The soles are :data:`ANKLE_HEIGHT_SHARE` of the height below the ankles.

    Parameters
    ----------
    model : BodyModel
    states : (P, 27) array_like

    Returns
    -------
    (P,) float64 ndarray
    """
    from ..joints import LANDMARK_NAMES

    lm = model.landmarks(np.array(states, dtype=float, ndmin=2))
    head, ankles = LANDMARK_NAMES.index("head"), [LANDMARK_NAMES.index("l_ankle"),
                                                   LANDMARK_NAMES.index("r_ankle")]
    height = model.dimensions.height
    return (lm[:, head, 2] - lm[:, ankles, 2].min(axis=1)) / height + ANKLE_HEIGHT_SHARE


def voxel_height_mm(observation) -> float | None:
    """How tall a frame's voxels stand (mm): from the lowest voxel to the top of the head on the
    trunk's axis (:attr:`voxelmocap.measure.detect.Extremities.height_mm`); ``None`` without
    voxels."""
    from ..measure.detect import find_extremities

    ex = find_extremities(observation.occupancy, observation.grid, max_extremities=0)
    return None if ex is None else float(ex.height_mm)


def standing_height_from_poses(model, observations, states, *,
                               height_range=HEIGHT_RANGE_MM) -> float | None:
    """The standing height the voxels and the poses tracked in them imply (mm).

    Each frame's voxels stand :func:`voxel_height_mm` high, a
    pose that stands :func:`posed_height_share` of the standing height; their ratio is the
    standing height, whatever the size the poses were tracked with (the share does not depend
    on it). The smallest over the frames within :data:`HEIGHT_AGREEMENT` of their median: the
    visual hull contains the person, so each frame's height is an upper bound (a hand near the
    head top reads as crown: +40–60 mm on a waving clip) and the tightest one is kept, but a
    frame whose head did not carve reads a head's length lower, and is left out. ``None`` when
    no frame has voxels. Frame 1's voxel height alone measures a crouch, not the person: a jog's
    first frame stands 0.9 of the runner's height, and a body scaled to it kept the ankles
    90–100 mm high.

    Parameters
    ----------
    model : BodyModel
        The body the states were tracked with.
    observations : sequence of VoxelObservation
    states : (F, 27) array_like
        One pose per observation.
    height_range : (float, float)
        Plausible standing heights (mm); the result is clipped into it.

    Returns
    -------
    float or None
    """
    shares = posed_height_share(model, states)
    heights = []
    for obs, share in zip(observations, shares, strict=True):
        tall = voxel_height_mm(obs)
        if tall is not None and share > 0:
            heights.append(tall / share)
    if not heights:
        return None
    heights = np.array(heights)
    agree = heights[heights >= (1.0 - HEIGHT_AGREEMENT) * np.median(heights)]
    return float(np.clip(agree.min(), *height_range))


def rescaled(dims: BodyDimensions, states, height: float):
    """``dims`` scaled to ``height`` and ``states`` (F, 27) on it: the angles kept, the root's
    height above the floor scaled with the body (the feet stay on it)."""
    states = np.array(states, dtype=float, ndmin=2)
    s = float(height) / dims.height
    states[:, 2] *= s
    return dims.scaled(height), states


#: Weight of the coverage term in the start's fit (see :func:`fit_body_dimensions`).
START_COVERAGE = 10.0


def refit_start(tracker, observations, records, config, seed, *, n_fit: int = 5,
                coverage: float | None = None):
    """Fit the body on the frames tracked so far and track them again with it.

    Parameters
    ----------
    tracker : voxelmocap.pose.tracker.BodyTracker
        The tracker that produced ``records`` (its model is the starting body).
    observations : sequence of VoxelObservation
        The frames' measurements, in order.
    records : sequence of voxelmocap.pose.records.FrameRecord
        The tracker's records of those frames (their ``state`` are the starting poses).
    config : voxelmocap.config.TrackConfig
    seed : int
        Seed of the new tracker's filter.
    n_fit : int
        Frames (spread over the tracked ones) the lengths are fitted on.
    coverage : float, optional
        Weight of the coverage term (default :data:`START_COVERAGE`).

    Returns
    -------
    tracker : BodyTracker
        A tracker with the fitted body, having tracked every frame again.
    records : list of FrameRecord
        Its records of those frames.
    checkpoints : list of dict
        Its filter state after each of them.
    fit : BodyFit
    """
    from .tracker import BodyTracker

    if len(observations) != len(records) or not records:
        raise ValueError("need one record per observation, at least one")
    pick = pick_frames(len(records), n_fit)
    if pick[0] != 0:
        pick = np.r_[0, pick]
    base, states = tracker.model.dimensions, np.array([rec.state for rec in records])
    fit_obs = [observations[i] for i in pick]
    coverage = START_COVERAGE if coverage is None else coverage

    def fitted(dims, poses):
        return fit_body_dimensions(fit_obs, poses[pick], dims, variances=tracker.variances,
                                   coverage=coverage)

    fit = fitted(base, states)
    # The standing height again, from the poses, kept only when the body fitted at it explains
    # the frames better: a start tracked wrong (every pose crouched) implies a body far too tall.
    # Not a sure guard: on voxels carved against the temporal median (the Pose2Sim demo's first
    # pass, poses at 0.6 of the height) the 2.1 m body still scored better (docs/benchmarks.md).
    height = standing_height_from_poses(tracker.model, observations, states)
    if height is not None and abs(height - base.height) >= fit_obs[0].grid.voxel_size:
        other = fitted(*rescaled(base, states, height))
        if other.log_likelihood > fit.log_likelihood:
            fit, other = other, fit
        fit = replace(fit, other=other)
    new = BodyTracker(BodyModel(fit.dimensions), config, seed=seed, frame_rate=tracker.frame_rate)
    new.start("fitted body", fit.states[0])
    out, checkpoints = [], []
    for obs, rec in zip(observations, records, strict=True):
        out.append(new.step(obs, frame=rec.frame))
        checkpoints.append(new.get_state())
    return new, out, checkpoints, fit
