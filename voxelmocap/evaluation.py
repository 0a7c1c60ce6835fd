"""Pose-error metrics: the HumanEva ``error()`` and (later) MMTA/MMTP, μ and σ. Pure array functions."""

from __future__ import annotations

import numpy as np

from .joints import LANDMARK_ENDPOINTS, endpoints_to_landmarks

__all__ = ["humaneva_error", "humaneva_error_position_average"]


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
