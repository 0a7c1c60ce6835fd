"""A project's own configuration files, cascading from the session down to each trial.

Pose2Sim keeps a ``Config.toml`` in the session folder and may keep another in each trial folder
that overrides some of its keys (its ``Demo_Batch``: ``[project] multi_person = true`` in
``Trial_2`` only). Pose2Sim reads them with ``read_config_files`` and merges them with
``recursive_update``: the trial's tables are merged into the session's key by key, at every
depth, and a key set in both takes the trial's value. A trial opened on its own still inherits
its parent folder's ``Config.toml`` (Pose2Sim's "level 1"). anipose has one ``config.toml`` at
the project's root (``nesting`` says how deep the sessions lie); a ``config.toml`` in a session
folder overrides it the same way here.

:func:`trial_config` gives the merged configuration of one folder and which file set each
setting read here (:class:`TrialConfig`), so that a bad value is reported against the file that
holds it. Each file's tables that are read here (:data:`CONFIG_TABLES`: ``[project]``,
``[calibration]``, ``[calibration.convert]``, ``[calibration.convert.qualisys]``,
``[triangulation]``) must be tables: ``calibration = 5`` is refused in one line naming the file
as it is read. The settings voxelmocap honours:

* ``[project] frame_range`` (Pose2Sim): ``'auto'``, ``'all'`` or ``[start, end]``, video frames
  counted from 0 with the end excluded (Pose2Sim's ``range(start, end)``): voxelmocap's
  synchronised frames ``start + 1 … end`` (:func:`frame_range_setting`). ``'auto'`` (trim around
  the frames of low reprojection error) has no meaning without 2-D keypoints: every frame;
* ``[project] frame_rate`` (Pose2Sim): a number is the frame rate, as in Pose2Sim, whatever the
  videos state; ``'auto'``: the videos' (:func:`frame_rate_setting`);
* ``[project] exclude_from_batch`` (Pose2Sim): trials left out of ``track --all``
  (:func:`excluded_from_batch`);
* ``[project] multi_person`` (Pose2Sim): noted (voxelmocap tracks one person);
* ``[calibration.convert.qualisys] binning_factor`` (Pose2Sim): see :mod:`voxelmocap.io.qualisys`;
* ``[triangulation] cam_regex`` and ``nesting`` (anipose): see :mod:`voxelmocap.io.project`.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import InputError

__all__ = ["CONFIG_TABLES", "TrialConfig", "check_tables", "config_chain", "excluded_from_batch",
           "frame_range_setting", "frame_rate_setting", "merge_configs", "nesting_setting",
           "trial_config"]

#: The configuration file's name, compared case-insensitively (Pose2Sim: Config.toml, anipose:
#: config.toml).
CONFIG_NAME = "config.toml"

#: Tables this package reads: in every file of the chain each must be a table when present
#: (checked as the file is read, so that a value of the wrong type is one line naming its file).
CONFIG_TABLES = (("project",), ("calibration",), ("calibration", "convert"),
                 ("calibration", "convert", "qualisys"), ("triangulation",))


def merge_configs(base: dict, override: dict) -> dict:
    """``override`` merged into a copy of ``base``: tables key by key at every depth.

    The rule of Pose2Sim's ``recursive_update``: a key whose values are tables on both sides is
    merged recursively; any other key takes ``override``'s value (a list replaces a list).
    Neither argument is modified.
    """
    out = copy.deepcopy(base)
    for key, value in override.items():
        if isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = merge_configs(out[key], value)
        else:
            out[key] = copy.deepcopy(value)
    return out


def _config_file(folder: Path) -> Path | None:
    if not folder.is_dir():
        return None
    for child in sorted(folder.iterdir()):
        if child.is_file() and child.name.lower() == CONFIG_NAME:
            return child
    return None


def config_chain(folder, top, *, include_parent: bool = False) -> list[Path]:
    """The configuration files that apply to ``folder``, outermost first.

    Parameters
    ----------
    folder : str or os.PathLike
        The trial (or session) folder, ``top`` itself or inside it.
    top : str or os.PathLike
        The project folder that was opened.
    include_parent : bool
        Also ``top``'s parent folder (a Pose2Sim trial opened on its own inherits its session's
        ``Config.toml``).
    """
    folder, top = Path(folder), Path(top)
    levels = [top.parent] if include_parent and top.parent != top else []
    levels.append(top)
    for part in folder.relative_to(top).parts:
        levels.append(levels[-1] / part)
    return [f for f in (_config_file(level) for level in levels) if f is not None]


@dataclass
class TrialConfig:
    """The merged configuration of one folder and where each of its values came from."""

    values: dict = field(default_factory=dict)
    files: list[Path] = field(default_factory=list)  #: outermost first

    def source(self, *keys: str) -> Path | str:
        """The innermost file that sets ``keys`` (e.g. ``"project", "frame_range"``)."""
        from .toml import read_toml

        for path in reversed(self.files):
            table = read_toml(path)
            for key in keys:
                table = table.get(key) if isinstance(table, dict) else None
            if table is not None:
                return path
        return "Config.toml"

    def get(self, *keys: str, default=None):
        """The merged value at ``keys`` (tables walked in order), or ``default``."""
        table = self.values
        for key in keys:
            if not isinstance(table, dict) or key not in table:
                return default
            table = table[key]
        return table


def check_tables(data: dict, path) -> dict:
    """``data`` (one configuration file's contents) after checking that each of
    :data:`CONFIG_TABLES` is a table where present.

    Raises
    ------
    InputError
        One that is not (naming ``path``), e.g. ``calibration = 5``.
    """
    for keys in CONFIG_TABLES:
        table = data
        for depth, key in enumerate(keys):
            value = table.get(key, {})
            if not isinstance(value, dict):
                raise InputError(path, f"[{'.'.join(keys[:depth + 1])}] must be a table, "
                                       f"got {value!r:.40}")
            table = value
    return data


def trial_config(folder, top, *, include_parent: bool = False) -> TrialConfig:
    """The configuration files of :func:`config_chain`, read, checked and merged outermost first.

    Raises
    ------
    InputError
        A file that is not valid TOML, or one of whose :data:`CONFIG_TABLES` is not a table
        (naming it).
    """
    from .toml import read_toml

    files = config_chain(folder, top, include_parent=include_parent)
    values: dict = {}
    for path in files:
        values = merge_configs(values, check_tables(read_toml(path), path))
    return TrialConfig(values, files)


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def frame_range_setting(config: TrialConfig) -> tuple[int, int] | None:
    """Pose2Sim's ``[project] frame_range`` as ``(start, end)`` (0-based, end excluded), or None.

    None for ``'auto'``, ``'all'``, ``[]`` or no setting: every frame.

    Raises
    ------
    InputError
        Any other value (naming the file that sets it).
    """
    value = config.get("project", "frame_range", default="auto")
    if value in ("auto", "all") or value == []:
        return None
    if isinstance(value, list) and len(value) == 2 and all(
            _is_number(v) and float(v).is_integer() for v in value):
        start, end = int(value[0]), int(value[1])
        if 0 <= start < end:
            return start, end
    raise InputError(config.source("project", "frame_range"),
                     f"[project] frame_range must be 'auto', 'all' or [start, end] with "
                     f"0 <= start < end (video frames counted from 0, end excluded), "
                     f"got {value!r}")


def frame_rate_setting(config: TrialConfig) -> float | None:
    """Pose2Sim's ``[project] frame_rate`` when it is a positive number, else None (``'auto'``).

    Raises
    ------
    InputError
        A value that is neither ``'auto'`` nor a positive number (naming the file).
    """
    value = config.get("project", "frame_rate", default="auto")
    if value == "auto":
        return None
    if _is_number(value) and value > 0:
        return float(value)
    raise InputError(config.source("project", "frame_rate"),
                     f"[project] frame_rate must be 'auto' or a positive number, got {value!r}")


def excluded_from_batch(config: TrialConfig, folder: Path, top: Path) -> bool:
    """Whether Pose2Sim's ``[project] exclude_from_batch`` names the trial in ``folder``.

    An entry names a trial by its folder's name (what Pose2Sim compares) or by its path from the
    project folder ``top`` (``'S00_P00_Participant/S00_P00_T00_StaticTrial'``, as Pose2Sim's
    template shows).
    """
    entries = config.get("project", "exclude_from_batch", default=[])
    if isinstance(entries, str):
        entries = [entries]
    if not isinstance(entries, list):
        raise InputError(config.source("project", "exclude_from_batch"),
                         f"[project] exclude_from_batch must be a list of trial folders, "
                         f"got {entries!r}")
    wanted = {str(e).replace("\\", "/").strip("/").lower() for e in entries}
    relative = Path(folder).relative_to(top).as_posix().lower()
    return Path(folder).name.lower() in wanted or relative in wanted


def nesting_setting(root: Path) -> int | None:
    """anipose's ``nesting`` from the root's ``config.toml``: how deep the sessions lie, or None.

    ``0``: the root is the session; ``n > 0``: the folders ``n`` levels below it; ``-1`` (any
    negative): every folder at any depth.

    Raises
    ------
    InputError
        A value that is not an integer (naming the file).
    """
    from .toml import read_toml

    path = _config_file(root)
    if path is None:
        return None
    value = read_toml(path).get("nesting")
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int):
        raise InputError(path, f"nesting must be an integer (how many folder levels below the "
                               f"project the sessions lie), got {value!r}")
    return value
