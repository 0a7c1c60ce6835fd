"""Pose-error metrics: MMTA/MMTP, μ and σ (paper 002 §3) and the HumanEva ``error()``. Pure functions.

* :func:`landmark_errors`: per-frame, per-landmark Euclidean errors ``(F, M)``.
* :func:`mmta_mmtp`: Multiple Marker Tracking Accuracy (share of landmarks with error ``< δ``, in %)
  and Precision (mean error of those matched landmarks, mm), each computed per frame and then
  averaged over frames, as in the paper.
* :func:`evaluate_sequence`: the paper's Table 1 row for one sequence (μ, σ of the per-frame mean
  error, MMTP, MMTA, plus the mean HumanEva ``error()``), skipping frames whose ground truth has a
  disabled endpoint and frames without an estimate (every estimated endpoint disabled: a frame the
  tracker flagged without a person, ``voxelmocap.pose.recovery``).
* :func:`evaluate_points`: the same errors against any named 3-D reference (a TRC or CSV mapped
  onto some of the landmarks), with missing reference values left out.
* :func:`hip_axis_angle`: the angle in the floor plane between the estimated and true
  left-hip→right-hip vectors (the body's facing error); :func:`left_right_correct`: whether the
  left and right of each limb pair are the right way round; :func:`first_lasting_frame`: from
  which frame a condition holds to the end (a turned start turned round).
"""

from __future__ import annotations

import warnings
from dataclasses import asdict, dataclass

import numpy as np

from .joints import LANDMARK_ENDPOINTS, LANDMARK_NAMES, endpoints_to_landmarks

__all__ = [
    "LIMB_PAIRS",
    "PointScores",
    "SequenceScores",
    "best_cell",
    "evaluate_points",
    "evaluate_sequence",
    "first_lasting_frame",
    "hip_axis_angle",
    "hip_flexion",
    "humaneva_error",
    "humaneva_error_position_average",
    "knee_flexion",
    "landmark_errors",
    "left_right_correct",
    "mmta_mmtp",
]


def humaneva_error(est, gt, est_enabled=None, gt_enabled=None, *, per_joint: bool = False):
    """The HumanEva toolkit's ``error(pose1, pose2)`` over the 15 virtual joints (``HUMANEVA.md`` §5.1).

    For a merged joint (thorax, elbows, knees) the two endpoint *errors* are averaged (not the two
    positions); an endpoint counts only when enabled in both poses. As in the toolkit, a merged
    joint whose available errors are all exactly 0 is dropped, not counted as 0. A single joint
    with a disabled endpoint is skipped (the toolkit would raise; see §5.1). The frame error is the
    plain mean of the joints present.

    Parameters
    ----------
    est, gt : (..., 20, D) array_like
        Estimated and ground-truth endpoints (mm for D = 3, pixels for D = 2).
    est_enabled, gt_enabled : (..., 20) array_like of bool, optional
        Endpoint flags (all enabled by default).
    per_joint : bool
        Also return the ``(..., 15)`` joint errors (NaN where a joint is absent).

    Returns
    -------
    error : (...) ndarray
        Mean joint error per frame; NaN when no joint is present.
    joint_errors : (..., 15) ndarray
        Only with ``per_joint``.

    See Also
    --------
    humaneva_error_position_average : averages merged-joint *positions* (VideoPose3D's convention).
    """
    est = np.asarray(est, dtype=float)
    gt = np.asarray(gt, dtype=float)
    if est.shape != gt.shape or est.shape[-2] != 20:
        raise ValueError(f"poses must both be (..., 20, D), got {est.shape} and {gt.shape}")
    shape = est.shape[:-1]
    ok = np.ones(shape, dtype=bool)
    if est_enabled is not None:
        ok &= np.broadcast_to(np.asarray(est_enabled, dtype=bool), shape)
    if gt_enabled is not None:
        ok &= np.broadcast_to(np.asarray(gt_enabled, dtype=bool), shape)
    e = np.linalg.norm(est - gt, axis=-1)
    joints = np.full(shape[:-1] + (15,), np.nan)
    for j, idx in enumerate(LANDMARK_ENDPOINTS):
        ej = e[..., idx]
        oj = ok[..., idx]
        n = oj.sum(axis=-1)
        s = np.where(oj, ej, 0.0).sum(axis=-1)
        with np.errstate(invalid="ignore", divide="ignore"):
            mean = s / n
        present = n > 0
        if len(idx) == 2:
            present &= np.any(oj & (ej != 0), axis=-1)
        joints[..., j] = np.where(present, mean, np.nan)
    with np.errstate(invalid="ignore"):
        count = np.sum(~np.isnan(joints), axis=-1)
        total = np.nansum(joints, axis=-1)
        frame = np.where(count > 0, total / np.maximum(count, 1), np.nan)
    return (frame, joints) if per_joint else frame


def humaneva_error_position_average(est, gt):
    """Mean 15-landmark error where merged joints average *positions* first (VideoPose3D style).

    Parameters
    ----------
    est, gt : (..., 20, D) array_like
        Endpoints, all enabled.

    Returns
    -------
    (...) ndarray
        Mean over the 15 landmarks of ``|landmark_est − landmark_gt|``. Differs from
        :func:`humaneva_error` whenever a merged joint's two endpoints disagree.
    """
    le = endpoints_to_landmarks(est)
    lg = endpoints_to_landmarks(gt)
    return np.linalg.norm(le - lg, axis=-1).mean(axis=-1)


def landmark_errors(est, gt) -> np.ndarray:
    """Euclidean error of every landmark of every frame.

    Parameters
    ----------
    est, gt : (F, M, 3) array_like
        Estimated and true landmark positions (mm).

    Returns
    -------
    (F, M) ndarray
        ``|est − gt|`` (mm).
    """
    est = np.asarray(est, dtype=float)
    gt = np.asarray(gt, dtype=float)
    if est.shape != gt.shape or est.ndim != 3:
        raise ValueError(f"landmarks must both be (F, M, 3), got {est.shape} and {gt.shape}")
    return np.linalg.norm(est - gt, axis=-1)


def mmta_mmtp(errors, delta: float = 100.0):
    """MMTA (%) and MMTP (mm) of per-landmark errors, averaged over frames (paper 002 §3).

    A landmark is *matched* when its error is strictly below ``delta``. Per frame, MMTA is the
    percentage of matched landmarks and MMTP the mean error of the matched ones; the sequence
    values are the means over frames (MMTP over the frames with at least one match).

    Parameters
    ----------
    errors : (F, M) array_like
        Landmark errors (mm), from :func:`landmark_errors`.
    delta : float
        Matching threshold δ (mm).

    Returns
    -------
    mmta : float
        Mean over frames of the matched percentage (NaN for no frames).
    mmtp : float
        Mean over frames of the matched landmarks' mean error (NaN when nothing matched).
    per_frame : tuple of (F,) ndarray
        ``(mmta_per_frame, mmtp_per_frame)``; MMTP is NaN in frames without a match.
    """
    errors = np.asarray(errors, dtype=float)
    if errors.ndim != 2:
        raise ValueError(f"errors must be (F, M), got shape {errors.shape}")
    matched = errors < delta
    n = matched.sum(axis=1)
    mmta_f = 100.0 * n / errors.shape[1] if errors.shape[1] else np.full(len(errors), np.nan)
    with np.errstate(invalid="ignore", divide="ignore"):
        mmtp_f = np.where(n > 0, np.where(matched, errors, 0.0).sum(axis=1) / n, np.nan)
    mmta = float(mmta_f.mean()) if len(errors) else float("nan")
    mmtp = float(np.nanmean(mmtp_f)) if np.any(n > 0) else float("nan")
    return mmta, mmtp, (mmta_f, mmtp_f)


@dataclass(frozen=True)
class SequenceScores:
    """One row of the paper's Table 1 (all distances in mm, MMTA in %)."""

    frames: int  #: frames evaluated
    skipped: int  #: frames skipped because the ground truth had a disabled endpoint
    mu_mm: float  #: mean over frames of the mean landmark error
    sigma_mm: float  #: standard deviation over frames of the mean landmark error
    mmtp_mm: float
    mmta_pct: float
    humaneva_error_mm: float  #: mean over frames of the toolkit's error()
    #: frames skipped because the estimate is flagged absent (every estimated endpoint disabled)
    unobserved: int = 0

    def to_dict(self) -> dict:
        return asdict(self)


def evaluate_sequence(est_endpoints, gt_endpoints, gt_enabled=None, *, delta: float = 100.0,
                      est_enabled=None) -> tuple[SequenceScores, dict]:
    """Score one sequence of estimated poses against its ground truth.

    Parameters
    ----------
    est_endpoints, gt_endpoints : (F, 20, 3) array_like
        Estimated and true body_pose endpoints (mm) of the same frames.
    gt_enabled : (F, 20) array_like of bool, optional
        Ground-truth flags; frames with any disabled endpoint are skipped (and counted).
    delta : float
        MMTA/MMTP threshold (mm).
    est_enabled : (F, 20) array_like of bool, optional
        Estimate flags: disabled endpoints are left out of the HumanEva error (as the toolkit
        does); a landmark with no enabled estimate counts as unmatched for MMTA and is left out
        of μ. A frame with *every* endpoint disabled has no estimate (the tracker flagged it
        without a person): it is skipped like a frame without ground truth and counted in
        ``unobserved``.

    Returns
    -------
    scores : SequenceScores
    per_frame : dict
        ``valid`` (F,) bool, ``landmark_errors`` (F, 15) (NaN rows for skipped frames),
        ``mean_error`` (F,), ``mmta`` (F,), ``mmtp`` (F,), ``humaneva_error`` (F,).
    """
    est = np.asarray(est_endpoints, dtype=float)
    gt = np.asarray(gt_endpoints, dtype=float)
    if est.shape != gt.shape or est.ndim != 3 or est.shape[1:] != (20, 3):
        raise ValueError(f"endpoints must both be (F, 20, 3), got {est.shape} and {gt.shape}")
    n = len(est)
    enabled = np.ones((n, 20), bool) if gt_enabled is None else np.asarray(gt_enabled, bool)
    observed = (np.ones(n, bool) if est_enabled is None
                else np.asarray(est_enabled, bool).reshape(n, 20).any(axis=1))
    valid = enabled.all(axis=1) & observed
    errors = np.full((n, 15), np.nan)
    est_flags = None if est_enabled is None else np.asarray(est_enabled, bool)[valid]
    # A landmark whose estimated endpoints are all disabled has NaN error: never matched (MMTA
    # counts it as a miss) and left out of the frame's mean error.
    errors[valid] = landmark_errors(endpoints_to_landmarks(est[valid], est_flags),
                                    endpoints_to_landmarks(gt[valid]))
    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        mean_error = np.nanmean(errors, axis=1)
    he = np.full(n, np.nan)
    if valid.any():
        he[valid] = humaneva_error(est[valid], gt[valid], est_flags, enabled[valid])
    mmta_f = np.full(n, np.nan)
    mmtp_f = np.full(n, np.nan)
    mmta, mmtp, (a, p) = mmta_mmtp(errors[valid], delta)
    mmta_f[valid] = a
    mmtp_f[valid] = p
    m = mean_error[valid]
    m = m[~np.isnan(m)]
    scores = SequenceScores(
        frames=int(valid.sum()),
        skipped=int((~enabled.all(axis=1)).sum()),
        mu_mm=float(m.mean()) if len(m) else float("nan"),
        sigma_mm=float(m.std()) if len(m) else float("nan"),
        mmtp_mm=mmtp,
        mmta_pct=mmta,
        humaneva_error_mm=float(np.nanmean(he[valid])) if valid.any() else float("nan"),
        unobserved=int((enabled.all(axis=1) & ~observed).sum()),
    )
    per_frame = {"valid": valid, "landmark_errors": errors, "mean_error": mean_error,
                 "mmta": mmta_f, "mmtp": mmtp_f, "humaneva_error": he}
    return scores, per_frame


@dataclass(frozen=True)
class PointScores:
    """Errors against a named 3-D reference (distances in mm, MMTA in %)."""

    frames: int  #: frames with at least one landmark to compare
    landmarks: tuple  #: the compared landmarks' names
    mu_mm: float  #: mean over frames of the frame's mean landmark error
    sigma_mm: float  #: standard deviation over frames of that mean
    mmtp_mm: float  #: mean over frames of the matched landmarks' mean error
    mmta_pct: float  #: mean over frames of the share of landmarks within δ
    per_landmark_mm: tuple  #: mean error of each landmark over the frames it has (NaN: none)
    per_landmark_mmta_pct: tuple  #: share of its frames within δ

    def to_dict(self) -> dict:
        return asdict(self)


def evaluate_points(est, ref, names, *, delta: float = 100.0) -> tuple[PointScores, dict]:
    """Score estimated landmarks against reference points of the same frames and names.

    NaN in ``ref`` (a marker the reference lacks in a frame) or ``est`` (no estimate) leaves that
    landmark out of that frame: it is neither matched nor missed. A frame with nothing left is
    not counted. Otherwise the definitions of :func:`mmta_mmtp` and :func:`evaluate_sequence`.

    Parameters
    ----------
    est, ref : (F, M, 3) array_like
        Estimated and reference positions (mm).
    names : sequence of str
        The M landmark names.
    delta : float
        MMTA/MMTP threshold (mm).

    Returns
    -------
    scores : PointScores
    per_frame : dict
        ``errors`` (F, M) (NaN where left out), ``valid`` (F,) bool, ``mean_error`` (F,),
        ``mmta`` (F,), ``mmtp`` (F,) (NaN for frames not counted).
    """
    errors = landmark_errors(est, ref)  # NaN wherever either side is NaN
    if errors.shape[1] != len(names):
        raise ValueError(f"{len(names)} names for {errors.shape[1]} landmarks")
    have = ~np.isnan(errors)
    n = have.sum(axis=1)
    valid = n > 0
    matched = have & (np.nan_to_num(errors, nan=np.inf) < delta)
    k = matched.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean_error = np.where(valid, np.where(have, errors, 0.0).sum(axis=1) / n, np.nan)
        mmta_f = np.where(valid, 100.0 * k / n, np.nan)
        mmtp_f = np.where(k > 0, np.where(matched, errors, 0.0).sum(axis=1) / k, np.nan)
        m = have.sum(axis=0)
        per_lm = np.where(m > 0, np.where(have, errors, 0.0).sum(axis=0) / m, np.nan)
        per_lm_mmta = np.where(m > 0, 100.0 * matched.sum(axis=0) / m, np.nan)
    mu = mean_error[valid]
    scores = PointScores(
        frames=int(valid.sum()), landmarks=tuple(names),
        mu_mm=float(mu.mean()) if len(mu) else float("nan"),
        sigma_mm=float(mu.std()) if len(mu) else float("nan"),
        mmtp_mm=float(np.nanmean(mmtp_f)) if np.any(k > 0) else float("nan"),
        mmta_pct=float(mmta_f[valid].mean()) if valid.any() else float("nan"),
        per_landmark_mm=tuple(float(v) for v in per_lm),
        per_landmark_mmta_pct=tuple(float(v) for v in per_lm_mmta),
    )
    return scores, {"errors": errors, "valid": valid, "mean_error": mean_error, "mmta": mmta_f,
                    "mmtp": mmtp_f}


def best_cell(mmta: np.ndarray, layers, particles, *, tolerance: float = 0.0):
    """Index ``(i, j)`` of the cheapest cell whose MMTA is within ``tolerance`` of the best.

    The cost is ``N_L · N_p``; among cells of equal cost the higher MMTA wins, then the fewer
    layers.

    Parameters
    ----------
    mmta : (n_layers, n_particles) ndarray
        Mean MMTA (%) per cell, NaN where missing.
    layers, particles : sequence of int
        The axes' values.
    tolerance : float
        Percentage points below the best that still count as reaching it.
    """
    if np.all(np.isnan(mmta)):
        return None
    best = np.nanmax(mmta)
    candidates = [(layers[i] * particles[j], -mmta[i, j], i, j)
                  for i in range(len(layers)) for j in range(len(particles))
                  if not np.isnan(mmta[i, j]) and mmta[i, j] >= best - tolerance]
    _, _, i, j = min(candidates)
    return i, j


_L = {name: i for i, name in enumerate(LANDMARK_NAMES)}

#: Left/right landmark pairs of the limbs tested by :func:`left_right_correct`.
LIMB_PAIRS: tuple[tuple[str, str], ...] = (
    ("l_elbow", "r_elbow"), ("l_wrist", "r_wrist"), ("l_knee", "r_knee"), ("l_ankle", "r_ankle"),
)


def hip_axis_angle(est, gt) -> np.ndarray:
    """Signed angle in the floor plane from the true hip axis to the estimated one.

    The hip axis is the vector from the left hip to the right hip, projected on the floor
    (x, y; Z up). A body facing the right way has an angle near 0; one turned round, near ±180.

    Parameters
    ----------
    est, gt : (F, 15, 3) array_like
        Estimated and true landmarks (mm), :data:`voxelmocap.joints.LANDMARK_NAMES` order.

    Returns
    -------
    (F,) ndarray
        Degrees in (−180, 180], counter-clockwise seen from above positive; NaN where either
        axis has no horizontal extent (hips one above the other) or is NaN.
    """
    est = np.asarray(est, dtype=float)
    gt = np.asarray(gt, dtype=float)
    if est.shape != gt.shape or est.ndim != 3 or est.shape[1:] != (15, 3):
        raise ValueError(f"landmarks must both be (F, 15, 3), got {est.shape} and {gt.shape}")
    a = gt[:, _L["r_hip"], :2] - gt[:, _L["l_hip"], :2]
    b = est[:, _L["r_hip"], :2] - est[:, _L["l_hip"], :2]
    cross = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    dot = np.einsum("ij,ij->i", a, b)
    angle = np.degrees(np.arctan2(cross, dot))
    angle[angle == -180.0] = 180.0
    flat = (np.linalg.norm(a, axis=1) == 0) | (np.linalg.norm(b, axis=1) == 0)
    angle[flat] = np.nan
    return angle


def knee_flexion(landmarks, side: str) -> np.ndarray:
    """Knee flexion from landmarks: the angle between thigh (hip → knee) and shank (knee → ankle).

    Parameters
    ----------
    landmarks : (F, 15, 3) array_like
        mm, :data:`voxelmocap.joints.LANDMARK_NAMES` order.
    side : {"l", "r"}

    Returns
    -------
    (F,) ndarray
        Degrees, 0 for a straight leg.
    """
    lm = np.asarray(landmarks, dtype=float)
    thigh = lm[:, _L[f"{side}_knee"]] - lm[:, _L[f"{side}_hip"]]
    shank = lm[:, _L[f"{side}_ankle"]] - lm[:, _L[f"{side}_knee"]]
    cos = np.sum(thigh * shank, 1) / np.linalg.norm(thigh, axis=1) / np.linalg.norm(shank, axis=1)
    return np.degrees(np.arccos(np.clip(cos, -1, 1)))


def hip_flexion(landmarks, side: str) -> np.ndarray:
    """Hip flexion from landmarks: the thigh's angle from the trunk in the pelvis' sagittal plane.

    Pelvis frame: Z along the hips (left → right), Y the trunk (pelvis → thorax) made
    perpendicular to Z, X = Y × Z forward; flexion = atan2(thigh·X, −thigh·Y).

    Parameters
    ----------
    landmarks : (F, 15, 3) array_like
        mm, :data:`voxelmocap.joints.LANDMARK_NAMES` order.
    side : {"l", "r"}

    Returns
    -------
    (F,) ndarray
        Degrees: 0 with the thigh along the trunk, 90 with it forward.
    """
    lm = np.asarray(landmarks, dtype=float)
    z = lm[:, _L["r_hip"]] - lm[:, _L["l_hip"]]
    z /= np.linalg.norm(z, axis=1, keepdims=True)
    up = lm[:, _L["thorax"]] - lm[:, _L["pelvis"]]
    y = up - np.sum(up * z, 1)[:, None] * z
    y /= np.linalg.norm(y, axis=1, keepdims=True)
    x = np.cross(y, z)
    thigh = lm[:, _L[f"{side}_knee"]] - lm[:, _L[f"{side}_hip"]]
    return np.degrees(np.arctan2(np.sum(thigh * x, 1), -np.sum(thigh * y, 1)))


def left_right_correct(est, gt, pairs=LIMB_PAIRS) -> dict[str, bool]:
    """Whether each limb pair's left and right are the right way round over some frames.

    A pair (left ``L``, right ``R``) is right when, averaged over the frames, the estimated
    ``L`` is nearer the true ``L`` than the true ``R``, *and* the estimated ``R`` nearer the true
    ``R`` than the true ``L``. So a swapped pair fails, and so does a pair whose two estimates
    both sit on one true limb.

    Parameters
    ----------
    est, gt : (F, 15, 3) array_like
        Estimated and true landmarks (mm) of the same frames (F ≥ 1), in
        :data:`voxelmocap.joints.LANDMARK_NAMES` order. Frames with a NaN in either are left out.
    pairs : sequence of (str, str)
        Left and right landmark names (default :data:`LIMB_PAIRS`: elbows, wrists, knees,
        ankles).

    Returns
    -------
    dict
        ``{"l_elbow/r_elbow": bool, ...}`` in the order of ``pairs`` (False when no frame is
        left).
    """
    est = np.asarray(est, dtype=float)
    gt = np.asarray(gt, dtype=float)
    if est.shape != gt.shape or est.ndim != 3 or est.shape[1:] != (15, 3):
        raise ValueError(f"landmarks must both be (F, 15, 3), got {est.shape} and {gt.shape}")
    out = {}
    for left, right in pairs:
        i, j = _L[left], _L[right]
        e, g = est[:, [i, j]], gt[:, [i, j]]
        keep = ~(np.isnan(e).any(axis=(1, 2)) | np.isnan(g).any(axis=(1, 2)))
        if not keep.any():
            out[f"{left}/{right}"] = False
            continue
        e, g = e[keep], g[keep]
        # d[a, b]: mean distance of estimated side a from true side b (0 left, 1 right)
        d = np.linalg.norm(e[:, :, None, :] - g[:, None, :, :], axis=-1).mean(axis=0)
        out[f"{left}/{right}"] = bool(d[0, 0] < d[0, 1] and d[1, 1] < d[1, 0])
    return out


def first_lasting_frame(ok) -> int | None:
    """Index of the first element from which ``ok`` holds to the end, or None if the last fails.

    Parameters
    ----------
    ok : (F,) array_like of bool
        A condition per frame (e.g. ``abs(hip_axis_angle(...)) <= 45``).

    Returns
    -------
    int or None
        ``k`` such that ``ok[k:]`` are all True and ``k == 0`` or ``ok[k − 1]`` is False.
    """
    ok = np.asarray(ok, dtype=bool).ravel()
    if not len(ok) or not ok[-1]:
        return None
    bad = np.flatnonzero(~ok)
    return int(bad[-1] + 1) if len(bad) else 0
