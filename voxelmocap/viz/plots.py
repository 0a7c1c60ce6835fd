"""Matplotlib plots of evaluation results (PNG, no display needed)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..joints import LANDMARK_NAMES

__all__ = ["plot_errors", "plot_sweep_heatmaps", "sweep_grid"]


def _pyplot():
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    return plt


def plot_errors(sequences, out_dir, *, delta: float = 100.0) -> list[Path]:
    """Write ``error_per_frame.png`` and ``error_per_joint.png`` for evaluated sequences.

    Parameters
    ----------
    sequences : list of voxelmocap.io.reports.EvaluatedSequence
        Scored sequences.
    out_dir : str or os.PathLike
        Folder for the PNG files.
    delta : float
        MMTA threshold drawn as a reference line (mm).
    """
    from ..io._atomic import atomic_path

    plt = _pyplot()
    from ..io._atomic import ensure_output_dir

    out_dir = ensure_output_dir(out_dir)
    paths = []

    fig, ax = plt.subplots(figsize=(9, 4))
    for s in sequences:
        ax.plot(s.frames, s.per_frame["mean_error"], label=f"{s.subject} {s.action}_{s.trial}")
    ax.axhline(delta, color="grey", linestyle="--", linewidth=1, label=f"δ = {delta:g} mm")
    ax.set_xlabel("synchronised frame")
    ax.set_ylabel("mean landmark error (mm)")
    ax.set_title("Error per frame")
    ax.legend(fontsize=8)
    fig.tight_layout()
    path = out_dir / "error_per_frame.png"
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110)
    plt.close(fig)
    paths.append(path)

    fig, ax = plt.subplots(figsize=(9, 4))
    errors = np.concatenate([s.per_frame["landmark_errors"] for s in sequences])
    mean = np.nanmean(errors, axis=0)
    std = np.nanstd(errors, axis=0)
    ax.bar(np.arange(15), mean, yerr=std, color="tab:blue", alpha=0.8, capsize=3)
    ax.axhline(delta, color="grey", linestyle="--", linewidth=1)
    ax.set_xticks(np.arange(15), LANDMARK_NAMES, rotation=45, ha="right")
    ax.set_ylabel("error (mm), mean ± sd over frames")
    ax.set_title("Error per joint")
    fig.tight_layout()
    path = out_dir / "error_per_joint.png"
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110)
    plt.close(fig)
    paths.append(path)
    return paths


def sweep_grid(rows, voxel_size: float, n_cameras: int):
    """Mean MMTA over replicates on the ``layers × particles`` grid of one (voxel, cameras) pair.

    Returns
    -------
    layers, particles : list of int
    mmta : (len(layers), len(particles)) ndarray, NaN where no cell finished.
    """
    sel = [r for r in rows if r["voxel_size"] == voxel_size and r["n_cameras"] == n_cameras]
    layers = sorted({r["layers"] for r in sel})
    particles = sorted({r["particles"] for r in sel})
    mmta = np.full((len(layers), len(particles)), np.nan)
    for i, nl in enumerate(layers):
        for j, npart in enumerate(particles):
            vals = [r["mmta_pct"] for r in sel if r["layers"] == nl and r["particles"] == npart
                    and r["mmta_pct"] is not None]
            if vals:
                mmta[i, j] = float(np.mean(vals))
    return layers, particles, mmta


def plot_sweep_heatmaps(rows, out_dir, *, tolerance: float = 0.0) -> list[Path]:
    """One MMTA heatmap per (voxel size, cameras), the cheapest best cell marked in red."""
    from ..evaluation import best_cell
    from ..io._atomic import atomic_path

    plt = _pyplot()
    out_dir = Path(out_dir)
    paths = []
    for voxel, ncam in sorted({(r["voxel_size"], r["n_cameras"]) for r in rows}):
        layers, particles, mmta = sweep_grid(rows, voxel, ncam)
        fig, ax = plt.subplots(figsize=(1.2 * len(particles) + 2.5, 0.9 * len(layers) + 1.8))
        im = ax.imshow(mmta, origin="lower", cmap="viridis", vmin=0, vmax=100, aspect="auto")
        for i in range(len(layers)):
            for j in range(len(particles)):
                if not np.isnan(mmta[i, j]):
                    ax.text(j, i, f"{mmta[i, j]:.0f}", ha="center", va="center",
                            color="white" if mmta[i, j] < 60 else "black", fontsize=8)
        best = best_cell(mmta, layers, particles, tolerance=tolerance)
        if best is not None:
            ax.plot(best[1], best[0], "o", markersize=18, markerfacecolor="none",
                    markeredgecolor="red", markeredgewidth=2)
        ax.set_xticks(range(len(particles)), [str(p) for p in particles])
        ax.set_yticks(range(len(layers)), [str(v) for v in layers])
        ax.set_xlabel("particles per layer $N_p$")
        ax.set_ylabel("layers $N_L$")
        ax.set_title(f"MMTA (%), $s_V$ = {voxel:g} mm, $N_C$ = {ncam}")
        fig.colorbar(im, ax=ax)
        fig.tight_layout()
        path = out_dir / f"mmta_{voxel:g}mm_{ncam}cams.png"
        with atomic_path(path) as tmp:
            fig.savefig(tmp, dpi=100)
        plt.close(fig)
        paths.append(path)
    return paths
