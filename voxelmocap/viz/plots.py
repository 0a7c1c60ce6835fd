"""Matplotlib plots of evaluation results (PNG, no display needed)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..joints import LANDMARK_NAMES

__all__ = ["plot_errors"]


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
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
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
