"""Where a run's body comes from, and the body a previous pass or run tracked.

The one owner of "which body does this run track with":

* :func:`body_model_for`: the subject's body file, else limb lengths measured from the ground
  truth, else the average adult (which the frame loop then sizes from the voxels, or fits);
* :func:`sized_model`: the average adult scaled to the voxels' height (:func:`voxel_height`);
* :func:`model_from_attrs`: the body a result records (``body_dimensions``, ``body_height_mm``),
  so that a resumed run, an overlay or a next pass use the cones the tracker used;
* :func:`tracked_body` (a result on disk, ``--plate-from``) and :func:`tracked_in_memory` (the
  pass just run): a :class:`~voxelmocap.pose.body_cover.TrackedBody` for the next plate.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import InputError
from ..pose.body_size import HEIGHT_RANGE_MM, voxel_height_mm

__all__ = ["HEIGHT_RANGE_MM", "body_model_for", "model_from_attrs", "result_body_model",
           "sized_model", "tracked_body", "tracked_in_memory", "voxel_height"]


def body_model_for(seq, gt=None):
    """The body model tracking uses for a sequence, and a phrase saying where it came from.

    The subject body file when the data set has one, else limb lengths measured from the ground
    truth, else the average adult.
    """
    from ..body import BodyModel

    if seq.body_file is not None:
        from ..io.body_file import read_body_file

        return (BodyModel(read_body_file(seq.body_file)),
                f"subject body file {seq.body_file.name}")
    if gt is not None and gt.enabled.all(axis=1).any():
        from ..joints import endpoints_to_landmarks

        valid = gt.enabled.all(axis=1)
        return BodyModel.from_landmarks(endpoints_to_landmarks(gt.endpoints[valid])), \
            "limb lengths measured from the ground truth"
    return BodyModel(), "average adult (no body file or ground truth)"


def voxel_height(observation, frame) -> float:
    """A frame's standing height (mm) from its voxels (:func:`voxel_height_mm`), clipped to
    :data:`HEIGHT_RANGE_MM`."""
    tall = voxel_height_mm(observation)
    if tall is None:
        from ..measure.observation import no_voxels

        raise no_voxels(f"frame {int(frame)}", "measure the body")
    return float(np.clip(tall, *HEIGHT_RANGE_MM))


def sized_model(height_mm: float, frame):
    """The average adult scaled to ``height_mm``, and the phrase the result records."""
    from ..body import BodyModel

    where = "" if frame is None else f" of frame {int(frame)}"
    return (BodyModel.scaled(height_mm),
            f"average adult scaled to {height_mm:.0f} mm, the height of the voxels{where}")


def model_from_attrs(attrs, seq, gt=None, *, source="result: body_dimensions"):
    """The body model a result's attributes record (or a run's, before it is written).

    ``body_dimensions`` (every length, JSON: a fitted body or a previous pass's) wins; then the
    average adult scaled to ``body_height_mm`` when ``body_model`` says so; else
    :func:`body_model_for` (a body file or the ground truth, which the result names only).

    Raises
    ------
    InputError
        ``body_dimensions`` is not a body's dimensions.
    """
    from ..body import BodyModel
    from ..pose.body_size import dimensions_from_json

    if attrs.get("body_dimensions"):
        return BodyModel(dimensions_from_json(str(attrs["body_dimensions"]), source=source))
    height = attrs.get("body_height_mm")
    if height is not None and str(attrs.get("body_model", "")).startswith("average adult scaled"):
        return BodyModel.scaled(float(height))
    return body_model_for(seq, gt)[0]


def result_body_model(seq, result, gt=None):
    """The body model a result was tracked with, as its file records it.

    A run without body file or ground truth sizes the body itself; the result file records how.
    Drawing :func:`body_model_for`'s unscaled average adult instead would show cones the tracker
    never used.

    Parameters
    ----------
    seq : Sequence
        The tracked sequence (its body file, when the result used one).
    result : voxelmocap.io.results.Result
        The result read back (its ``attrs``).
    gt : GroundTruth, optional
        The sequence's ground truth.

    Returns
    -------
    BodyModel
    """
    return model_from_attrs(result.attrs, seq, gt)


def tracked_body(run, seq, gt=None):
    """The body a previous run tracked in ``seq``: its model and states where it saw the person.

    Parameters
    ----------
    run : str or os.PathLike
        The run folder (its result of ``seq`` is ``RUN/<subject>/<name>.h5``), a pass folder, or
        the result file.
    seq : Sequence
        The sequence about to be tracked.
    gt : GroundTruth, optional
        Its ground truth: a run that measured its body on it recorded no dimensions.

    Returns
    -------
    voxelmocap.pose.body_cover.TrackedBody

    Raises
    ------
    InputError
        No such result, a result of another sequence, or fewer than 2 frames with the person.
    """
    from ..io.results import read_result

    run = Path(run)
    path = run if run.is_file() or run.suffix == ".h5" else \
        Path(run) / seq.subject / f"{seq.name}.h5"
    if not path.is_file() and (run / path.name).is_file():   # a pass folder: RUN/<trial>/pass1
        path = run / path.name
    if not path.is_file():
        raise InputError(path, f"no result of {seq.subject}/{seq.name} here (--plate-from takes a "
                               "run folder of this sequence or its .h5 result)")
    result = read_result(path)
    for key, mine in (("subject", seq.subject), ("action", seq.action), ("trial", seq.trial)):
        theirs = result.attrs.get(key)
        if theirs is not None and str(theirs) != str(mine):
            raise InputError(path, f"a result of {key} {theirs!r}, not of this run's {mine!r}")
    try:
        model = result_body_model(seq, result, gt)
    except InputError as exc:
        raise InputError(path, f"body_dimensions: {exc.problem}") from None
    return _tracked(model, result.frames, result.state, result.observed, seq, path)


def tracked_in_memory(model, frames, states, observed, seq, path):
    """:func:`tracked_body` of the pass this process just wrote to ``path``, from the frames,
    states and presence flags it tracked (equal to reading the file back)."""
    return _tracked(model, frames, states, observed, seq, Path(path))


def _tracked(model, frames, states, observed, seq, path):
    from ..pose.body_cover import TrackedBody

    frames = np.asarray(frames)
    observed = np.ones(len(frames), bool) if observed is None else np.asarray(observed, bool)
    keep = observed & np.isin(frames, seq.frame_numbers)
    if keep.sum() < 2:
        raise InputError(path, f"{int(keep.sum())} frame(s) of this sequence with the person "
                               "tracked: a plate needs at least 2")
    states = np.asarray(states, float)
    if states.ndim != 2 or states.shape[1] != model.n_dims:
        raise InputError(path, f"states of {states.shape[-1]} parameters, the body model has "
                               f"{model.n_dims}")
    frames = frames[keep]
    order = np.argsort(frames)
    return TrackedBody(model, frames[order], states[keep][order], str(path.resolve()))


def dimensions_json(model) -> str:
    """The JSON of a model's dimensions, as a result records them (``body_dimensions``)."""
    from ..pose.body_size import dimensions_to_json

    return dimensions_to_json(model.dimensions)
