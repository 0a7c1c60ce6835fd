"""Parameter sweeps on Dask: every combination of settings × seeds, as independent tasks.

A *cell* is one combination of annealing layers ``N_L``, particles per layer ``N_p``, voxel size,
number of cameras and a replicate index. Each cell tracks the sequence with its own seed (derived
from the cell's parameters, so seeds are distinct and stable across re-runs), evaluates it and
writes ``SWEEP/cells/<cell>/score.json``. Cells whose score file exists are skipped, so an
interrupted or extended sweep only runs what is missing; the settings shared by all cells (data
set, sequence, frames, δ, base config) are kept in ``SWEEP/settings.json`` and a re-run with
other ones is refused rather than mixed in. The collected table goes to
``SWEEP/sweep.csv``; :func:`voxelmocap.evaluation.best_cell` finds the cheapest cell (smallest
``N_L · N_p``) that reaches the best MMTA, which :func:`voxelmocap.viz.plots.plot_sweep_heatmaps`
marks on one MMTA heatmap over ``N_L × N_p`` per (voxel size, cameras), like the paper's Fig. 4 (the ``sweep``
command draws them; this module does not import ``viz``).

Tasks run through :mod:`voxelmocap.run.tasks` (shared with ``track --all``) on a local Dask cluster
(one single-threaded worker process per core by default) or on an existing cluster given by its
scheduler address (``dask[distributed]`` is the optional ``distributed`` extra).
"""

from __future__ import annotations

import csv
import dataclasses
import io
import itertools
import json
import logging
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..logs import emit, run_started

__all__ = ["SweepCell", "SweepRequest", "collect_rows", "plan_cells", "run_cell", "run_sweep",
           "write_table"]

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class SweepCell:
    """One task of a sweep."""

    layers: int
    particles: int
    voxel_size: float
    n_cameras: int
    replicate: int

    @property
    def name(self) -> str:
        return (f"L{self.layers}_P{self.particles}_V{self.voxel_size:g}_C{self.n_cameras}"
                f"_r{self.replicate}")

    @property
    def seed(self) -> int:
        """A seed distinct for every cell and stable across runs."""
        ss = np.random.SeedSequence([self.replicate, self.layers, self.particles,
                                     int(round(self.voxel_size * 1000)), self.n_cameras])
        return int(ss.generate_state(1)[0])


def plan_cells(layers, particles, voxel_sizes, cameras, seeds: int) -> list[SweepCell]:
    """The Cartesian product of the settings × ``seeds`` replicates."""
    if seeds < 1:
        raise InputError("--seeds", "must be at least 1")
    for name, values in (("--layers", layers), ("--particles", particles),
                         ("--voxel-size", voxel_sizes), ("--cameras", cameras)):
        if not values or min(values) <= 0:
            raise InputError(name, "needs positive values")
    return [SweepCell(int(nl), int(npart), float(v), int(nc), r)
            for nl, npart, v, nc, r in itertools.product(layers, particles, voxel_sizes, cameras,
                                                         range(seeds))]


@dataclass(frozen=True)
class SweepRequest:
    """One sweep: the sequence, the settings crossed, and what every cell shares.

    Attributes
    ----------
    dataset, subject, sequence
        HumanEva-layout data set root and sequence (it needs ground truth).
    out_dir : str or os.PathLike
        The sweep folder ``SWEEP``.
    layers, particles, voxel_sizes, cameras : sequence of int or float
        Annealing layers, particles per layer, voxel sizes (mm) and numbers of cameras crossed.
    seeds : int
        Replicates of every combination (each with its own seed, :attr:`SweepCell.seed`).
    frames : str or None
        ``"a:b"`` synchronised frames of every cell.
    base_config_toml : str or None
        The configuration the cells' settings override (TOML text; None: the defaults).
    delta : float
        MMTA threshold (mm).
    """

    dataset: object
    subject: str
    sequence: str
    out_dir: object
    layers: tuple
    particles: tuple
    voxel_sizes: tuple = (20.0,)
    cameras: tuple = (7,)
    seeds: int = 1
    frames: str | None = None
    base_config_toml: str | None = None
    delta: float = 100.0

    def cells(self) -> list[SweepCell]:
        """Every cell of this sweep (:func:`plan_cells`)."""
        return plan_cells(self.layers, self.particles, self.voxel_sizes, self.cameras,
                          self.seeds)


def run_cell(cell: SweepCell, request: SweepRequest) -> dict:
    """Track and evaluate one cell (runs in a worker); returns its table row."""
    from ..config import TrackConfig, config_from_toml, with_overrides
    from ..io._atomic import atomic_write_text
    from ..io.humaneva import Dataset
    from ..io.reports import score_against
    from ..logs import task_log
    from .pipeline import track_sequence

    dataset, subject, sequence = request.dataset, request.subject, request.sequence
    out_dir, base_config_toml = request.out_dir, request.base_config_toml
    cell_dir = Path(out_dir) / "cells" / cell.name
    score_path = cell_dir / "score.json"
    if score_path.exists():
        return json.loads(score_path.read_text())
    base = config_from_toml(base_config_toml) if base_config_toml else TrackConfig()
    config = with_overrides(base, **{"filter.layers": cell.layers,
                                     "filter.particles": cell.particles,
                                     "measurement.voxel_size": cell.voxel_size})
    seq = Dataset(dataset).sequence(subject, sequence)
    if cell.n_cameras > len(seq.camera_names):
        raise InputError("--cameras", f"{cell.n_cameras} cameras asked, the sequence has "
                                      f"{len(seq.camera_names)}")
    cameras = seq.camera_names[: cell.n_cameras]
    with task_log(Path(out_dir) / "voxelmocap.log", cell.name):  # the worker's lines, too
        outcome = track_sequence(dataset, subject, sequence, cell_dir / "run", config=config,
                                 frames=request.frames, cameras=cameras, seed=cell.seed,
                                 progress=False, overwrite=True)
    scored = score_against(outcome.result_path, seq.ground_truth_path or seq.ground_truth(),
                           delta=request.delta)
    row = dict(asdict(cell), seed=cell.seed, cameras=",".join(cameras),
               frames=scored.scores.frames, mu_mm=scored.scores.mu_mm,
               sigma_mm=scored.scores.sigma_mm, mmtp_mm=scored.scores.mmtp_mm,
               mmta_pct=scored.scores.mmta_pct,
               humaneva_error_mm=scored.scores.humaneva_error_mm,
               seconds_per_frame=outcome.seconds_per_frame)
    atomic_write_text(score_path, json.dumps(row, indent=1, default=float) + "\n")
    return row


def collect_rows(out_dir) -> list[dict]:
    """Every finished cell's row (from ``cells/*/score.json``)."""
    rows = []
    for path in sorted(Path(out_dir).glob("cells/*/score.json")):
        rows.append(json.loads(path.read_text()))
    return rows


_COLUMNS = ("layers", "particles", "voxel_size", "n_cameras", "replicate", "seed", "cameras",
            "frames", "mu_mm", "sigma_mm", "mmtp_mm", "mmta_pct", "humaneva_error_mm",
            "seconds_per_frame")


def write_table(out_dir, rows: list[dict]) -> Path:
    """``sweep.csv``: one row per finished cell."""
    from ..io._atomic import atomic_write_text

    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=_COLUMNS, extrasaction="ignore", lineterminator="\n")
    writer.writeheader()
    for row in sorted(rows, key=lambda r: (r["voxel_size"], r["n_cameras"], r["layers"],
                                           r["particles"], r["replicate"])):
        writer.writerow(row)
    path = Path(out_dir) / "sweep.csv"
    atomic_write_text(path, buf.getvalue())
    return path


def _check_settings(out_dir: Path, settings: dict) -> None:
    """Refuse to mix cells made with other shared settings into one sweep folder.

    Cells differ only by their own parameters (layers, particles, voxel size, cameras, replicate);
    everything else is recorded once in ``SWEEP/settings.json`` and must match on a re-run.
    """
    from ..io._atomic import atomic_write_text, ensure_output_dir

    ensure_output_dir(out_dir)
    path = out_dir / "settings.json"
    if path.exists():
        try:
            previous = json.loads(path.read_text())
        except (OSError, ValueError) as exc:
            raise InputError(path, f"unreadable sweep settings ({exc})") from None
        for key, value in settings.items():
            if previous.get(key) != value:
                raise InputError(out_dir, f"this sweep folder was made with another {key} "
                                          f"({previous.get(key)!r}); use a new --out")
        return
    atomic_write_text(path, json.dumps(settings, indent=1) + "\n")


def run_sweep(request: SweepRequest, *, scheduler: str | None = None,
              n_workers: int | None = None, log=None,
              progress: bool = True) -> tuple[Path, list[dict]]:
    """Run (or complete) a sweep; returns the CSV path and the table rows (one dict per cell).

    The cells run as tasks of :func:`voxelmocap.run.tasks.run_tasks` (a local Dask cluster of
    ``n_workers`` processes, or the cluster at ``scheduler``); a failing cell stops the sweep
    with its error. ``log`` (optional) also receives the messages of the ``voxelmocap.run.sweep``
    logger.
    """
    from ..io.humaneva import Dataset
    from .tasks import run_tasks

    r = request
    seq = Dataset(r.dataset).sequence(r.subject, r.sequence)
    if seq.ground_truth_source is None:
        raise InputError(f"{r.subject}/{r.sequence}", "a sweep needs ground truth to score cells")
    if max(r.cameras) > len(seq.camera_names):
        raise InputError("--cameras", f"at most {len(seq.camera_names)} cameras in this sequence")
    out_dir = Path(r.out_dir)
    _check_settings(out_dir, {"dataset": str(Path(r.dataset).resolve()), "subject": seq.subject,
                              "sequence": seq.name, "frames": r.frames, "delta_mm": r.delta,
                              "config": r.base_config_toml or ""})
    run_started()  # the sweep folder holds its settings: its log file is written from now on
    cells = r.cells()
    todo = [c for c in cells if not (out_dir / "cells" / c.name / "score.json").exists()]
    emit(logger, log, f"{len(cells)} cells, {len(cells) - len(todo)} already done, "
                      f"{len(todo)} to run")
    # the workers see absolute paths: they may run in another folder
    resolved = dataclasses.replace(r, dataset=str(Path(r.dataset).resolve()),
                                   out_dir=str(out_dir.resolve()))
    run_tasks([(f"cell-{c.name}", run_cell, (c, resolved)) for c in todo],
              scheduler=scheduler, n_workers=n_workers, stop_on_error=True, progress=progress,
              desc="sweep")
    rows = collect_rows(out_dir)
    return write_table(out_dir, rows), rows
