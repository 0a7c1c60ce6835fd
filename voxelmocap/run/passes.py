"""What a run's silhouettes decide about its tracking.

* Given person masks (``track --masks``) or a plate learnt from a tracked body
  (``--plate-from``, or a later pass) select the silhouette cue, and with masks open the limb
  sweep's hull gate (:func:`masks_defaults`): with good silhouettes both help, with a plate
  learnt by carving they do not (docs/benchmarks.md).
* A plate learnt from the sequence is tracked in passes (:func:`plate_passes`): the first
  learns its plate by carving against the sequence's temporal median, every later one from the
  body the previous pass tracked (:func:`voxelmocap.pose.body_cover.plate_covers_of`), which finds
  the background behind a person who stays in one place far better; from
  ``[init] previous_pass_start`` on a pass also starts from the previous pass's body and pose
  instead of searching its start again (``pipeline._continues``). The runner
  (:func:`voxelmocap.run.pipeline.track_sequence`) writes the earlier passes' results to
  ``RUN/<subject>/pass<k>/`` (:func:`pass_folder`), beside the final result.

Pure: no file is touched here.
"""

from __future__ import annotations

__all__ = ["MASKS_CUES", "MASKS_MAX_HULL", "MIN_BODY_FRAMES", "final_config", "masks_defaults",
           "pass_folder", "plate_passes"]

#: Fewest frames with the person a pass must track for the next pass to learn its plate from
#: its body (the plate is the median of those frames around the body): on the rendered 8-frame
#: walk the final pass, learning from 3–8 frames, lost the person in 3 of 4 and 4 of 8 frames.
MIN_BODY_FRAMES = 10

#: With ``--masks``: the cues and the limb sweep's hull gate used unless chosen otherwise. On
#: the Pose2Sim demo with MediaPipe's masks, the voxel cue alone with the gate at 2 tracked to
#: 211 mm, the silhouette cue at 10 to 116 mm, and with the gate open 74–77 mm; on the five
#: rendered 4-camera clips (near-perfect silhouettes, no answer) the two are mixed, 91.7 → 109.0 mm
#: on average (better on jog and box, worse on gestures and combo; docs/benchmarks.md).
#: With a plate from a tracked body the cues only (the gate stays: a second run on the demo
#: tracked to 218 mm with it at 2, 223 mm open).
MASKS_CUES = {"voxel": 1.0, "silhouette": 10.0}
MASKS_MAX_HULL = 1000.0


def masks_defaults(config, cues_given: bool, *, why: str = "given person masks",
                   gate: bool = True):
    """The cues (and gate) a run with good silhouettes uses unless chosen otherwise.

    Parameters
    ----------
    config : TrackConfig
    cues_given : bool
        The cues were chosen on the command line (``--cues``): they are kept.
    why : str
        How the message starts.
    gate : bool
        Also open the limb sweep's hull gate (given masks; not a plate from a body).

    Returns
    -------
    config : TrackConfig
        ``config`` with :data:`MASKS_CUES` (unless ``cues_given`` or the config chose other
        cues) and, with ``gate``, :data:`MASKS_MAX_HULL` (unless the config set the gate).
    message : str or None
        What changed, starting with ``why`` (None when nothing did).
    """
    import dataclasses

    from ..config import TrackConfig, with_overrides

    default = TrackConfig()
    changed = []
    if not cues_given and config.cues.weights == default.cues.weights:
        config = dataclasses.replace(config, cues=dataclasses.replace(
            config.cues, weights=dict(MASKS_CUES)))
        changed.append("cues " + ",".join(f"{k}={v:g}" for k, v in MASKS_CUES.items()))
    if gate and config.filter.limb_sweep_max_hull == default.filter.limb_sweep_max_hull:
        config = with_overrides(config, **{"filter.limb_sweep_max_hull": MASKS_MAX_HULL})
        changed.append(f"[filter] limb_sweep_max_hull = {MASKS_MAX_HULL:g} (the limb sweep on "
                       "every sweep frame)")
    if not changed:
        return config, None
    return config, (f"{why}: " + " and ".join(changed) + " (docs/projects.md; "
                    "--cues or the config file choose otherwise)")


def final_config(config, cues_given: bool = False):
    """The config a pass that learns its plate from a body tracks with (and records): the
    silhouette cue added (:func:`masks_defaults` without the gate), and the message."""
    return masks_defaults(config, cues_given, gate=False, why="a plate from a tracked body")


def plate_passes(seq, config, *, masks=None, plate_from=None, n_frames: int) -> int:
    """How many tracking passes a run of ``seq`` takes.

    ``config.measurement.silhouette.plate_passes`` when the run learns its background plate
    from the sequence (:func:`voxelmocap.run.measurement.learns_plate`) by carving — no
    masks, no ``plate_from`` — and tracks at least :data:`MIN_BODY_FRAMES` frames; else 1.

    Parameters
    ----------
    seq : Sequence
        The sequence (its cameras' background videos).
    config : TrackConfig
        Its ``measurement.silhouette`` (method, ``plate_passes``).
    masks, plate_from : optional
        The run's ``--masks`` and ``--plate-from`` (either makes it one pass).
    n_frames : int
        Frames the run tracks.

    Returns
    -------
    int
    """
    from .measurement import learns_plate

    if masks is not None or plate_from is not None or n_frames < MIN_BODY_FRAMES:
        return 1
    if not learns_plate(seq, config.measurement.silhouette):
        return 1
    return int(config.measurement.silhouette.plate_passes)


def pass_folder(k: int) -> str:
    """The folder under ``RUN/<subject>/`` holding pass ``k``'s result (not the last pass's)."""
    return f"pass{int(k)}"
