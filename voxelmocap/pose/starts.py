"""Where a track starts: the ground truth, a search over the voxels, or several starts at once.

* :func:`ground_truth_landmarks`: a frame's true landmarks, when the data set has them;
* :func:`initial_state_from_voxels`: a standing pose at the voxels' centre, facing the best of
  a ring of headings (``[init] method = "voxels"``); the extremity fit of
  :mod:`voxelmocap.pose.initialise` is the default;
* (:class:`voxelmocap.pose.multistart.MultiStart`: several starting poses tracked side by side
  for the first frames; the likeliest one goes on.)
"""

from __future__ import annotations

import numpy as np

__all__ = ["GROUND_TRUTH_START", "ground_truth_landmarks", "initial_state_from_voxels"]

#: How :meth:`BodyTracker.initial_state <voxelmocap.pose.tracker.BodyTracker.initial_state>`
#: names a start from the ground truth.
GROUND_TRUTH_START = "the ground truth"


def ground_truth_landmarks(gt, frame: int) -> np.ndarray | None:
    """A frame's true landmarks ``(15, 3)`` (mm) for :meth:`BodyTracker.initialise`.

    Parameters
    ----------
    gt : voxelmocap.io.body_pose_xml.BodyPoseSequence or None
        The sequence's ground truth.
    frame : int
        Synchronised frame number.

    Returns
    -------
    (15, 3) ndarray or None
        None when there is no ground truth, the frame is not in it, or an endpoint is disabled.
    """
    from ..joints import endpoints_to_landmarks

    if gt is None:
        return None
    row = int(gt.index_of([frame])[0])
    if row < 0 or not bool(gt.enabled[row].all()):
        return None
    return endpoints_to_landmarks(gt.endpoints[row])


def initial_state_from_voxels(measurement, model, variances, *, n_yaw: int = 36,
                              coverage: float = 0.0) -> np.ndarray:
    """A standing pose at the voxel blob's centroid, facing the best of ``n_yaw`` headings.

    Parameters
    ----------
    measurement : voxelmocap.score.likelihood.Measurement
        The first frame.
    model : BodyModel
    variances : (4,) sequence of float
        The likelihood's σ².
    n_yaw : int
        Headings tried, evenly spread over the full turn.
    coverage : float
        Weight of the likelihood's coverage term.

    Returns
    -------
    (27,) ndarray

    Raises
    ------
    InputError
        When the frame has no occupied voxel.
    """
    from ..score.likelihood import log_likelihood

    occ = measurement.occupancy
    idx = np.argwhere(occ)
    if len(idx) == 0:
        from ..measure.observation import no_voxels

        raise no_voxels("first frame", "initialise from the voxels")
    centre = measurement.grid.centre_of(idx).mean(axis=0)
    base = model.default_state()
    base[0], base[1] = centre[0], centre[1]
    yaw_i = list(model.state_names).index("root_yaw")
    candidates = np.repeat(base[None], n_yaw, axis=0)
    candidates[:, yaw_i] = np.linspace(-np.pi, np.pi, n_yaw, endpoint=False)
    scores = log_likelihood(measurement, model, candidates, variances=variances,
                            coverage=coverage)
    return candidates[int(np.argmax(scores))]
