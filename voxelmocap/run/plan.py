"""The plan of a ``track``: how many passes, where each pass's plate and start come from.

:func:`plan_passes` turns a sequence, its config and the request into a list of
:class:`PassPlan` — built once, logged at the start, run by one loop
(:func:`voxelmocap.run.pipeline.track_sequence`):

* **one pass** when the silhouettes need no plate learnt from the sequence (background videos,
  MOG2), when they are given (``--masks``: the silhouette cue is selected and the limb sweep's
  hull gate opened, :func:`masks_defaults`), when the plate's cover comes from a previous run
  (``--plate-from``: the silhouette cue), or when too few frames are tracked for a plate from a
  body (:data:`MIN_BODY_FRAMES`);
* **several passes** when the plate is learnt from the sequence by carving
  (``[measurement.silhouette] plate_passes``): the first learns its plate by carving against the
  sequence's temporal median; every later one from the body the pass before tracked
  (:func:`voxelmocap.pose.body_cover.plate_covers_of`), which finds the background behind a
  person who stays in one place far better (the plate of pass 2, around the body tracked against
  the carving plate, also covers the support column under its pelvis:
  ``[measurement.silhouette] plate_body_support``); from ``[init] previous_pass_start`` on, a pass also
  starts from the previous pass's body and pose (its arms searched again on that frame,
  :data:`CONTINUED_SEARCH`) instead of searching its start from the voxels.

A pass hands the next its tracked body in memory. One rule is decided while running: a pass that
saw the person in fewer than :data:`MIN_BODY_FRAMES` frames gives no body, and the last pass
then repeats that pass (:meth:`PassPlan.as_last`), the passes between are skipped.

Pure: no file is touched here.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from ..config import TrackConfig, with_overrides

__all__ = ["CONTINUED_SEARCH", "LOST_SHARE", "MASKS_CUES", "MASKS_MAX_HULL", "MIN_BODY_FRAMES",
           "VOXEL_SWEEP_EVERY", "PassPlan", "RunPlan", "carving_config", "final_config",
           "masks_defaults", "pass_folder", "plan_passes"]

#: Fewest frames with the person a pass must track for the next pass to learn its plate from
#: its body (the plate is the median of those frames around the body): on the rendered 8-frame
#: walk the final pass, learning from 3–8 frames, lost the person in 3 of 4 and 4 of 8 frames.
MIN_BODY_FRAMES = 10
#: A pass whose plate (learnt around the previous pass's body) finds the person in fewer than
#: this share of the frames the previous pass found them in ends the passes: the last pass
#: repeats the previous one (a rendered gestures clip without plate: 100 frames, then 36, then 0).
LOST_SHARE = 0.9
#: The periodic limb sweep's period (frames) in a pass whose plate is learnt by carving, where
#: the sweep has the voxels alone: what that sweep was measured at (10: 45.3 → 42.8 mm on the
#: rendered clips, docs/benchmarks.md). The default period (5) is the sweep scored with the
#: silhouettes too; on the Pose2Sim demo a carving pass swept every 5 frames moved three of five
#: seeds' first passes, and through their plates the later passes (one seed 70 → 440 mm).
VOXEL_SWEEP_EVERY = 10

#: With ``--masks``: the cues and the limb sweep's hull gate used unless chosen otherwise
#: (docs/benchmarks.md, "Real recording"). With a plate from a tracked body the cues only.
MASKS_CUES = {"voxel": 1.0, "silhouette": 10.0}
MASKS_MAX_HULL = 1000.0

#: The limbs a pass continuing the previous one searches again on its first frame
#: (``[init] limb_sweep``): a start whose arm the previous pass had wrong keeps it otherwise.
CONTINUED_SEARCH = ("l_arm", "r_arm")


@dataclass(frozen=True)
class PassPlan:
    """One tracking pass of a run.

    Attributes
    ----------
    number, of : int
        This pass's number (1-based) and the run's number of passes.
    config : TrackConfig
        The settings the pass tracks with (and records in its result).
    plate : str
        Where its silhouettes come from: ``"videos"`` (background videos or MOG2), ``"masks"``
        (given), ``"carving"`` (a plate learnt from the sequence by carving), ``"previous"``
        (learnt around the body the previous pass tracked) or ``"run"`` (around the body of the
        request's ``plate_from``).
    continues : bool
        Starts from the previous pass's body and its pose at the first frame with the person
        (unless that frame starts from the ground truth).
    """

    number: int
    of: int
    config: TrackConfig
    plate: str
    continues: bool = False

    @property
    def last(self) -> bool:
        return self.number == self.of

    @property
    def folder(self) -> str:
        """The folder under ``RUN/<subject>/`` holding this pass's result ("" for the last)."""
        return "" if self.last else pass_folder(self.number)

    @property
    def needs_previous(self) -> bool:
        """Learns its plate, or starts, from the body the previous pass tracked."""
        return self.plate == "previous"

    def as_last(self) -> PassPlan:
        """This pass run again as the run's last pass (the previous pass gave no body)."""
        return dataclasses.replace(self, number=self.of)

    def describe(self) -> str:
        """One line for the log: the pass, its plate and its start."""
        plate = {"videos": "the background videos (or MOG2)", "masks": "the given masks",
                 "carving": "a plate learnt by carving",
                 "previous": "a plate learnt around the previous pass's body",
                 "run": "a plate learnt around the body of --plate-from"}[self.plate]
        start = ("the previous pass's body and first pose (arms searched again)"
                 if self.continues else "the ground truth, else the voxels")
        return f"pass {self.number} of {self.of}: silhouettes from {plate}; starts from {start}"


@dataclass(frozen=True)
class RunPlan:
    """The passes of a run and what the request's silhouettes changed in its settings.

    Attributes
    ----------
    passes : tuple of PassPlan
    note : str or None
        What the silhouettes' source changed in the config (the cues a plate from a body or given
        masks select), or None.
    """

    passes: tuple
    note: str | None = None

    def describe(self) -> list[str]:
        """The lines the run logs at its start."""
        if len(self.passes) == 1:
            return [f"note: {self.note}"] if self.note else []
        n = len(self.passes)
        first = next((p.number for p in self.passes if p.continues), None)
        head = (f"{n} tracking passes (measurement.silhouette.plate_passes): the first learns the "
                "background plate by carving, each later one from the body the pass before "
                "tracked"
                + (f"; from pass {first} on a pass starts from the previous pass's body and pose "
                   "(init.previous_pass_start)" if first is not None else "")
                + (f"; {self.note}" if self.note else ""))
        return [head] + [p.describe() for p in self.passes]


def plan_passes(seq, config: TrackConfig, *, masks=None, plate_from=None, n_frames: int,
                cues_given: bool = False) -> RunPlan:
    """The passes a run of ``seq`` takes.

    Parameters
    ----------
    seq : Sequence
        The sequence (its cameras' background videos).
    config : TrackConfig
        The run's settings (``measurement.silhouette.plate_passes``,
        ``init.previous_pass_start``, the cues).
    masks, plate_from : optional
        The run's ``--masks`` and ``--plate-from`` (either makes it one pass).
    n_frames : int
        Frames the run tracks.
    cues_given : bool
        The cues were chosen on the command line (kept as they are).

    Returns
    -------
    RunPlan
    """
    from .measurement import learns_plate

    body_config, body_note = final_config(config, cues_given)
    if masks is not None:
        masked, note = masks_defaults(config, cues_given)
        return RunPlan((PassPlan(1, 1, masked, "masks"),), note)
    if plate_from is not None:
        return RunPlan((PassPlan(1, 1, body_config, "run"),), body_note)
    learnt = learns_plate(seq, config.measurement.silhouette)
    n = int(config.measurement.silhouette.plate_passes) if learnt else 1
    carving = carving_config(config) if learnt else config
    if n == 1 or n_frames < MIN_BODY_FRAMES:
        return RunPlan((PassPlan(1, 1, carving, "carving" if learnt else "videos"),))
    first = config.init.previous_pass_start     # 0 (never) or >= 2: validated
    # The support column is for the body of the carving pass only: its plate, a temporal median,
    # absorbed a leg that stood still, so that body's legs say little about where the legs were.
    # Around a later body it leaves the floor under a standing foot unseen in every frame.
    later = with_overrides(body_config, **{"measurement.silhouette.plate_body_support": 0.0})
    return RunPlan((PassPlan(1, n, carving, "carving"),) + tuple(
        PassPlan(k, n, body_config if k == 2 else later, "previous", continues=0 < first <= k)
        for k in range(2, n + 1)), body_note)


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


def carving_config(config):
    """The config of a pass whose plate is learnt by carving: the periodic limb sweep as it is
    without silhouettes — the voxels alone, every :data:`VOXEL_SWEEP_EVERY` frames — where the
    config holds the defaults (``[filter] limb_sweep_silhouette``, ``limb_sweep_every``).

    That plate is the sequence's temporal median, which keeps whatever of the person stood still
    as background: its silhouettes lack those parts (a standing leg, a still trunk), so the cue
    would pull the sweep's limbs off them (the silhouette cue tracked in that pass was worse on
    the Pose2Sim demo: ``docs/benchmarks.md``, "Tried, not kept"). The default period is the
    sweep scored with the silhouettes; the carving pass keeps the period the sweep had before
    them, which it was measured at (``docs/benchmarks.md``, "How the default got here"), also
    when the config chose a sweep weight. Defaults are recognised by value: a config that sets
    ``limb_sweep_every = 5`` (the default) gets 10 in the carving pass; any other value stands.

    Parameters
    ----------
    config : TrackConfig

    Returns
    -------
    TrackConfig
        ``config`` with ``filter.limb_sweep_silhouette = 0`` and ``filter.limb_sweep_every =``
        :data:`VOXEL_SWEEP_EVERY` where they held the defaults; ``config`` itself when neither did.
    """
    default = TrackConfig().filter
    overrides = {}
    if config.filter.limb_sweep_silhouette == default.limb_sweep_silhouette:
        overrides["filter.limb_sweep_silhouette"] = 0.0
    if config.filter.limb_sweep_every == default.limb_sweep_every:
        overrides["filter.limb_sweep_every"] = VOXEL_SWEEP_EVERY
    return with_overrides(config, **overrides) if overrides else config


def final_config(config, cues_given: bool = False):
    """The config a pass that learns its plate from a body tracks with (and records): the
    silhouette cue added (:func:`masks_defaults` without the gate), and the message."""
    return masks_defaults(config, cues_given, gate=False, why="a plate from a tracked body")


def pass_folder(k: int) -> str:
    """The folder under ``RUN/<subject>/`` holding pass ``k``'s result (not the last pass's)."""
    return f"pass{int(k)}"
