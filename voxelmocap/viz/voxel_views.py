"""Pictures of one voxel volume: depth-shaded orthographic views, silhouettes, an Open3D window.

:func:`views_figure` draws front (x–z), side (y–z) and top (x–y) depth-shaded orthographic views of
a volume and, beside them, each camera's silhouette (when given) with the occupied voxel centres
projected on it; :func:`open3d_window` shows the voxels in an interactive window. Pure drawing:
saving the figure is the caller's (:func:`voxelmocap.run.inspection.view_dump`).
"""

from __future__ import annotations

import os

import numpy as np

__all__ = ["depth_view", "has_display", "open3d_window", "views_figure"]


def has_display() -> bool:
    """Whether a window can be opened (an X11 or Wayland display is set)."""
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def depth_view(volume, axis: int, from_high: bool) -> np.ndarray:
    """Shade of the first occupied voxel seen along one grid axis.

    Parameters
    ----------
    volume : (nx, ny, nz) array_like of bool
        The voxels.
    axis : int
        The viewing axis (0, 1 or 2).
    from_high : bool
        Look from the high end of the axis (towards −axis) instead of the low end.

    Returns
    -------
    (A, B) float ndarray
        The two remaining axes in order; 1 = nearest voxel seen, 0.2 = farthest, NaN = none.
    """
    volume = np.asarray(volume, dtype=bool)
    vol = np.flip(volume, axis=axis) if from_high else volume
    hit = vol.any(axis=axis)
    first = np.argmax(vol, axis=axis).astype(float)
    if not hit.any():
        return np.full(first.shape, np.nan)
    # stretch over the depths actually seen, so a person's relief shows (near = bright)
    lo, hi = first[hit].min(), first[hit].max()
    shade = 1.0 - 0.8 * (first - lo) / max(hi - lo, 1.0)
    return np.where(hit, shade, np.nan)


def views_figure(grid, volume, frame: int, *, cameras=(), masks=None, title: str = ""):
    """The views of one volume as a Matplotlib figure (Agg; close it with ``plt.close``).

    Parameters
    ----------
    grid : VoxelGrid
        The volume's grid.
    volume : (nx, ny, nz) bool ndarray
        The voxels to show.
    frame : int
        Frame number (the default title).
    cameras : sequence of Camera
        Cameras whose views get a panel each.
    masks : (N_C, H, W) bool ndarray or list of (H_c, W_c) bool ndarray, optional
        Their silhouettes, drawn under the projected voxels.
    title : str
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure

    lo, hi = grid.low, grid.high
    views = [
        ("front (looking +y)", depth_view(volume, 1, False).T, (lo[0], hi[0], lo[2], hi[2]),
         ("x (mm)", "z (mm)")),
        ("side (looking −x)", depth_view(volume, 0, True).T, (lo[1], hi[1], lo[2], hi[2]),
         ("y (mm)", "z (mm)")),
        ("top (looking −z)", depth_view(volume, 2, True).T, (lo[0], hi[0], lo[1], hi[1]),
         ("x (mm)", "y (mm)")),
    ]
    n_cam = len(cameras)
    ncols = max(3, min(4, n_cam))
    cam_rows = (n_cam + ncols - 1) // ncols if n_cam else 0
    # a bare Figure (no pyplot): no global state, no GUI back end, safe in threads
    fig = Figure(figsize=(4.2 * ncols, 4.0 * (1 + cam_rows)), dpi=80)
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
    return fig


def open3d_window(grid, volume, title: str) -> bool:
    """Show the voxels in an Open3D window until it is closed; False when none could be opened."""
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
