"""Resume rules: which existing result a run may continue, and when it must refuse.

A result is written frame by frame with the filter's checkpoint (:mod:`voxelmocap.io.results`),
so a run killed at any point can go on exactly (``--resume``) — if it is the same run: the
attributes of :data:`RESUME_KEYS` must match, the ``[export]`` table aside (exports are not
tracking, and a resumed run may change them).
"""

from __future__ import annotations

from ..errors import InputError

__all__ = ["RESUME_KEYS", "previous_run", "tracking_config"]

#: Attributes a resumed run must share with the file it continues.
RESUME_KEYS = ("config", "seed", "subject", "action", "trial", "cameras", "frames_requested",
               "person_masks", "plate_from", "frame_rate")


def previous_run(writer, meta: dict, resume: bool, overwrite: bool):
    """The result a run continues (None for a fresh start), after checking it may.

    Parameters
    ----------
    writer : voxelmocap.io.results.ResultWriter
        The writer of the run's result (its ``path``; it holds the lock).
    meta : dict
        The run's attributes (:data:`RESUME_KEYS` among them).
    resume, overwrite : bool
        The run's ``--resume`` and ``--overwrite``.

    Returns
    -------
    voxelmocap.io.results.Result or None

    Raises
    ------
    InputError
        The result exists and neither ``resume`` nor ``overwrite`` is set, or it was made with
        other settings, or it has frames but no checkpoint.
    """
    path = writer.path
    previous = writer.read_existing() if path.exists() else None
    if previous is None:
        return None
    if not resume and not overwrite:
        raise InputError(path, "result exists; use --resume to continue it or --overwrite to "
                               "replace it")
    if not resume:
        return None
    for key in RESUME_KEYS:
        # a result written before masks could be given was made without them
        old = previous.attrs.get(key, "" if key in ("person_masks", "plate_from") else None)
        new = meta[key]
        if key == "config":  # the [export] table is not tracking: a resumed run may change it
            old, new = tracking_config(old), tracking_config(new)
        if str(old) != str(new):
            raise InputError(path, f"cannot resume: its {key} differs from this run's "
                                   "(use --overwrite to start again)")
    if len(previous) and previous.checkpoint is None:
        if previous.observed is not None and not previous.observed.any():
            return None  # only frames without a person, before any start: start again
        raise InputError(path, "cannot resume: the file has no checkpoint")
    return previous if len(previous) else None  # killed before its first frame: start afresh


def tracking_config(text) -> str:
    """A stored config's TOML without its ``[export]`` table (unparsable text: unchanged)."""
    from ..io.toml import dumps_toml, parse_toml

    try:
        data = parse_toml(str(text), "config")
    except InputError:
        return str(text)
    data.pop("export", None)
    return dumps_toml(data)
