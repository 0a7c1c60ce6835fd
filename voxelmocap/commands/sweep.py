"""``voxelmocap sweep``: annealing layers × particles (× voxel size × cameras × seeds) on Dask."""

from __future__ import annotations

import argparse
import logging

from ..logs import NO_PROGRESS_HELP

logger = logging.getLogger(__name__)


def _ints(text: str) -> list[int]:
    from ..errors import InputError

    try:
        return [int(t) for t in text.split(",") if t.strip()]
    except ValueError:
        raise InputError("sweep", f"expected comma-separated integers, got {text!r}") from None


def _floats(text: str) -> list[float]:
    from ..errors import InputError

    try:
        return [float(t) for t in text.split(",") if t.strip()]
    except ValueError:
        raise InputError("sweep", f"expected comma-separated numbers, got {text!r}") from None


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "sweep",
        help="track one sequence for every combination of settings as Dask tasks; MMTA heatmaps",
        description="Runs every combination of --layers × --particles × --voxel-size × --cameras "
                    "× --seeds replicates as Dask tasks (a local cluster, or --scheduler ADDRESS), "
                    "skipping cells already finished, then writes SWEEP/sweep.csv and MMTA "
                    "heatmaps over N_L × N_p with the cheapest best cell marked (paper Fig. 4).",
    )
    parser.add_argument("dataset", help="data set root")
    parser.add_argument("--subject", default="S1", help="subject (default S1)")
    parser.add_argument("--sequence", default="Walking_1", help="sequence (default Walking_1)")
    parser.add_argument("--frames", help="synchronised frames A:B (default: all with ground truth)")
    parser.add_argument("--layers", default="1,2,4,6,8", help="N_L values (default 1,2,4,6,8)")
    parser.add_argument("--particles", default="100,200,400,600",
                        help="N_p values (default 100,200,400,600)")
    parser.add_argument("--voxel-size", default="20", help="voxel sizes in mm (default 20)")
    parser.add_argument("--cameras", default=None,
                        help="numbers of cameras, first N in HumanEva order (default: all)")
    parser.add_argument("--seeds", type=int, default=1, help="replicates per cell (default 1)")
    parser.add_argument("--config", help="base TOML config of every cell")
    parser.add_argument("--scheduler", help="address of an existing Dask scheduler")
    parser.add_argument("--workers", type=int, help="local worker processes (default: cores)")
    parser.add_argument("--delta", type=float, default=100.0, help="MMTA threshold (mm)")
    parser.add_argument("--tolerance", type=float, default=0.0,
                        help="MMTA points below the best that still count as best (default 0)")
    parser.add_argument("--no-progress", action="store_true", help=NO_PROGRESS_HELP)
    parser.add_argument("--out", required=True, help="sweep folder SWEEP")
    parser.set_defaults(run=run, log_folder=lambda args: args.out)


def run(args: argparse.Namespace) -> int:
    from ..config import config_to_toml, load_config
    from ..io.humaneva import Dataset
    from ..run.sweep import SweepRequest, run_sweep
    from ..viz.plots import plot_sweep_heatmaps

    base = config_to_toml(load_config(args.config)) if args.config else None
    if args.cameras:
        cameras = _ints(args.cameras)
    else:
        cameras = [len(Dataset(args.dataset).sequence(args.subject, args.sequence).camera_names)]
    request = SweepRequest(
        args.dataset, args.subject, args.sequence, args.out, layers=tuple(_ints(args.layers)),
        particles=tuple(_ints(args.particles)), voxel_sizes=tuple(_floats(args.voxel_size)),
        cameras=tuple(cameras), seeds=args.seeds, frames=args.frames, base_config_toml=base,
        delta=args.delta)
    csv_path, rows = run_sweep(request, scheduler=args.scheduler, n_workers=args.workers,
                               progress=not args.no_progress)
    logger.info("table: %s", csv_path)
    for path in plot_sweep_heatmaps(rows, args.out, tolerance=args.tolerance):
        logger.info("heatmap: %s", path)
    return 0
