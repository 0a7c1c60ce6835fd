"""``voxelmocap view``: look at one frame of a voxel dump.

With a display (``DISPLAY`` / ``WAYLAND_DISPLAY`` set) and without ``--png`` it opens an Open3D
window on the occupied voxels. Otherwise (headless machines, ``--png``) it writes a PNG: front
(x–z), side (y–z) and top (x–y) depth-shaded orthographic views of the volume, and beside them each
camera's silhouette (when the dump holds masks) with the occupied voxel centres projected on it.
"""

from __future__ import annotations

import argparse
import os

VOLUMES = ("occupancy", "surface", "smoothed")


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "view",
        help="show one frame of a voxel dump (Open3D window, or PNG views when headless)",
        description="Open an Open3D window on one frame of a voxel dump written by "
                    "'voxelmocap dump', or write PNG views (front, side, top, silhouettes) when "
                    "there is no display or --png is given.",
    )
    parser.add_argument("dump", help="the HDF5 voxel dump (from 'voxelmocap dump')")
    parser.add_argument("--frame", type=int, help="synchronised frame number (default: the first)")
    parser.add_argument("--volume", choices=VOLUMES, default="occupancy",
                        help="what to show (smoothed: voxels with Ṽ^S > 0.5)")
    parser.add_argument("--png", action="store_true", help="write PNG views even with a display")
    parser.add_argument("--out", help="PNG file (default: <dump>_frame<F>.png beside the dump)")
    parser.set_defaults(run=run)


def has_display() -> bool:
    """Whether a window can be opened (an X11 or Wayland display is set)."""
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def _depth_view(volume, axis: int, from_high: bool):
    """(A, B) shade in [0, 1] of the first occupied voxel seen along ``axis``; NaN where empty."""
    import numpy as np

    vol = np.flip(volume, axis=axis) if from_high else volume
    hit = vol.any(axis=axis)
    first = np.argmax(vol, axis=axis).astype(float)
    if not hit.any():
        return np.full(first.shape, np.nan)
    # stretch over the depths actually seen, so a person's relief shows (near = bright)
    lo, hi = first[hit].min(), first[hit].max()
    shade = 1.0 - 0.8 * (first - lo) / max(hi - lo, 1.0)
    return np.where(hit, shade, np.nan)


def render_png(path, grid, volume, frame: int, *, cameras=(), masks=None, title: str = ""):
    """Write the PNG views of one volume (see the module docstring)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from ..io._atomic import atomic_path

    lo, hi = grid.low, grid.high
    views = [
        ("front (looking +y)", _depth_view(volume, 1, False).T, (lo[0], hi[0], lo[2], hi[2]),
         ("x (mm)", "z (mm)")),
        ("side (looking −x)", _depth_view(volume, 0, True).T, (lo[1], hi[1], lo[2], hi[2]),
         ("y (mm)", "z (mm)")),
        ("top (looking −z)", _depth_view(volume, 2, True).T, (lo[0], hi[0], lo[1], hi[1]),
         ("x (mm)", "y (mm)")),
    ]
    n_cam = len(cameras)
    ncols = max(3, min(4, n_cam))
    cam_rows = (n_cam + ncols - 1) // ncols if n_cam else 0
    fig = plt.figure(figsize=(4.2 * ncols, 4.0 * (1 + cam_rows)), dpi=80)
    occupied = np.argwhere(volume)
    centres = grid.centre_of(occupied) if len(occupied) else np.zeros((0, 3))
    for i, (name, img, extent, labels) in enumerate(views):
        ax = fig.add_subplot(1 + cam_rows, ncols, i + 1)
        ax.imshow(img, origin="lower", extent=extent, cmap="viridis", vmin=0, vmax=1,
                  interpolation="nearest")
        ax.set_title(name, fontsize=10)
        ax.set_xlabel(labels[0], fontsize=8)
        ax.set_ylabel(labels[1], fontsize=8)
        ax.tick_params(labelsize=7)
        ax.set_facecolor("#202020")
    for c, cam in enumerate(cameras):
        ax = fig.add_subplot(1 + cam_rows, ncols, ncols + c + 1)
        w, h = cam.size
        if masks is not None:
            ax.imshow(masks[c], cmap="gray", vmin=0, vmax=1, interpolation="nearest")
            label = "silhouette + voxels"
        else:
            ax.imshow(np.zeros((h, w)), cmap="gray", vmin=0, vmax=1)
            label = "voxels"
        if len(centres):
            pix, depth = cam.project(centres, return_depth=True)
            keep = (depth > 0) & (pix[:, 0] >= 0) & (pix[:, 0] < w) & (pix[:, 1] >= 0) & \
                   (pix[:, 1] < h)
            ax.scatter(pix[keep, 0], pix[keep, 1], s=0.5, c="tab:red", alpha=0.35, linewidths=0)
        ax.set_xlim(-0.5, w - 0.5)
        ax.set_ylim(h - 0.5, -0.5)
        ax.set_title(f"{cam.name}: {label}", fontsize=10)
        ax.set_xticks([])
        ax.set_yticks([])
    fig.suptitle(title or f"frame {frame}", fontsize=11)
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png")
    plt.close(fig)


def _open3d_window(grid, volume, title: str) -> bool:
    """Show the voxels in an Open3D window; False when no window could be created."""
    import numpy as np
    import open3d as o3d
    from matplotlib import colormaps

    idx = np.argwhere(volume)
    centres = grid.centre_of(idx) if len(idx) else np.zeros((0, 3))
    span = max(grid.high[2] - grid.low[2], 1e-9)
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(centres))
    cloud.colors = o3d.utility.Vector3dVector(
        colormaps["viridis"]((centres[:, 2] - grid.low[2]) / span)[:, :3])
    vg = o3d.geometry.VoxelGrid.create_from_point_cloud_within_bounds(
        cloud, grid.voxel_size, grid.low, grid.high)
    frame = o3d.geometry.TriangleMesh.create_coordinate_frame(size=500.0)
    vis = o3d.visualization.Visualizer()
    if not vis.create_window(window_name=title, width=1280, height=800):
        return False
    vis.add_geometry(vg)
    vis.add_geometry(frame)
    vis.run()
    vis.destroy_window()
    return True


def run(args: argparse.Namespace) -> int:
    from pathlib import Path

    from ..io.voxels import VoxelDump

    with VoxelDump(args.dump) as dump:
        frame = int(dump.frames[0]) if args.frame is None and len(dump.frames) else args.frame
        if frame is None:
            from ..errors import InputError

            raise InputError(args.dump, "the dump holds no frames")
        if args.volume == "smoothed":
            volume = dump.smoothed(frame) > 0.5
        else:
            volume = getattr(dump, args.volume)(frame)
        grid = dump.grid
        cameras = dump.cameras()
        masks = dump.masks(frame) if dump.has("masks") else None
        attrs = dump.attrs
    title = (f"{attrs.get('subject', '')}/{attrs.get('sequence', '')} frame {frame}: "
             f"{int(volume.sum())} {args.volume} voxels of {grid.voxel_size:g} mm").lstrip("/ ")
    if has_display() and not args.png:
        if _open3d_window(grid, volume, title):
            return 0
        print("could not open a window; writing PNG views instead")
    dump_path = Path(args.dump)
    out = Path(args.out) if args.out else dump_path.with_name(f"{dump_path.stem}_frame{frame}.png")
    render_png(out, grid, volume, frame, cameras=cameras, masks=masks, title=title)
    print(f"wrote {out}")
    return 0
