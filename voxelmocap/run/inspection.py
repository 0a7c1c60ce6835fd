"""Inspection runners: overlay videos of tracked results, pictures of voxel dumps.

:func:`overlay_video` draws a run's tracked cones and landmarks (and the ground truth) over one
camera's frames and writes a video (``voxelmocap overlay``); :func:`view_dump` shows one frame of a
voxel dump in an Open3D window, or writes its PNG views (``voxelmocap view``). The drawing is in
:mod:`voxelmocap.viz`; reading and writing files goes through :mod:`voxelmocap.io`. Every output
is checked before any work and written atomically: complete, or not at all.

Only this module, the other runners, :mod:`voxelmocap.io` and the command line touch files.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ..errors import InputError
from .bodies import result_body_model  # the body a result used

__all__ = ["ALL_CAMERAS", "ViewOutcome", "overlay_video", "result_body_model", "view_dump",
           "view_png_path"]

#: The ``camera`` value of :func:`overlay_video` that draws every camera side by side.
ALL_CAMERAS = "all"


def overlay_video(run_dir, dataset_root, *, camera: str = "C1", subject: str | None = None,
                  sequence: str | None = None, out=None, fps: float = 30.0,
                  progress: bool = True) -> Path:
    """Write a video of one camera's frames with a run's tracked poses drawn over them.

    Parameters
    ----------
    run_dir : str or os.PathLike
        Run folder written by ``voxelmocap track``.
    dataset_root : str or os.PathLike
        The data set that was tracked.
    camera : str
        Camera name, or ``"all"``: every camera of the sequence side by side in one video
        (:func:`voxelmocap.viz.overlay.overlay_all`).
    subject, sequence : str, optional
        Which result (needed when the run holds more than one).
    out : str or os.PathLike, optional
        ``.mp4``, ``.avi``, ``.mkv`` or ``.mov`` video (default
        ``RUN/<Subject>/<Action>_<Trial>_(<CAM>)_overlay.mp4``).
    fps : float
        Frame rate of the video.
    progress : bool
        Show a progress bar.

    Returns
    -------
    Path
        The video written.

    Raises
    ------
    InputError
        Not exactly one matching result, unreadable data, an output that is not a video name or
        cannot be written, a frame rate that is not positive.
    """
    from ..io.reports import find_result_files
    from ..io.results import read_result
    from ..io.sequence import open_sequence
    from ..io.video_writer import VideoWriter, check_video_path
    from ..joints import endpoints_to_landmarks
    from ..viz.overlay import overlay_all, overlay_frame

    if out is not None:
        check_video_path(out, fps)  # before reading anything
    files = [p for p in find_result_files(run_dir) if p.suffix == ".h5"
             and (subject is None or p.parent.name.lower() == subject.lower())
             and (sequence is None or p.stem.lower() == sequence.lower())]
    if len(files) != 1:
        raise InputError(run_dir, f"{len(files)} matching result files; choose one with "
                                  "--subject and --sequence")
    path = files[0]
    result = read_result(path)
    every = camera.lower() == ALL_CAMERAS
    seq = open_sequence(dataset_root, path.parent.name, path.stem,
                        cameras=None if every else [camera])
    cam = None if every else seq.rig[camera]
    gt = seq.ground_truth()
    model = result_body_model(seq, result, gt)
    label = "all" if every else cam.name
    out = Path(out) if out is not None else path.with_name(f"{path.stem}_({label})_overlay.mp4")
    rows = {int(f): i for i, f in enumerate(result.frames)}
    if every:
        first = next(iter(seq.frames(result.frames[:1])))[1]
        size = overlay_all(first, list(seq.rig), model, result.state[0],
                           result.landmarks[0]).shape[1::-1]
    else:
        size = cam.size
    with VideoWriter(out, fps, size) as video:  # refuses an unwritable output first
        bar = None
        if progress:
            from tqdm.auto import tqdm

            bar = tqdm(total=len(result.frames), desc="overlay", unit="frame")
        try:
            for frame, images in seq.frames(result.frames):
                i = rows[int(frame)]
                truth = None
                if gt is not None:
                    g = int(gt.index_of([frame])[0])
                    if g >= 0:
                        truth = endpoints_to_landmarks(gt.endpoints[g])
                if every:
                    video.write(overlay_all(images, list(seq.rig), model, result.state[i],
                                            result.landmarks[i], truth=truth,
                                            caption=f"{seq.subject} {seq.name} F={frame}"))
                else:
                    video.write(overlay_frame(images[cam.name], cam, model, result.state[i],
                                              result.landmarks[i], truth=truth,
                                              caption=f"{seq.subject} {seq.name} {cam.name} "
                                                      f"F={frame}"))
                if bar is not None:
                    bar.update(1)
        finally:
            if bar is not None:
                bar.close()
    return out


def view_png_path(dump_path, frame: int, out=None) -> Path:
    """Where :func:`view_dump` writes the PNG of ``frame``.

    ``out`` ending in ``.png`` is the file itself; any other ``out`` is a folder (created when
    needed) receiving ``<dump stem>_frame<F>.png``; without ``out`` the PNG goes beside the dump.
    """
    dump_path = Path(dump_path)
    name = f"{dump_path.stem}_frame{int(frame)}.png"
    if out is None:
        return dump_path.with_name(name)
    out = Path(out)
    if out.suffix.lower() == ".png":
        return out
    return out / name


@dataclass
class ViewOutcome:
    """What :func:`view_dump` did."""

    frame: int  #: the frame shown
    png: Path | None  #: the PNG written, or None when a window was shown
    message: str | None = None  #: a note for the user (e.g. why no window opened)


def view_dump(dump_path, *, frame: int | None = None, volume: str = "occupancy", out=None,
              window: bool | None = None) -> ViewOutcome:
    """Show one frame of a voxel dump in an Open3D window, or write its PNG views.

    Parameters
    ----------
    dump_path : str or os.PathLike
        HDF5 voxel dump written by ``voxelmocap dump``.
    frame : int, optional
        Synchronised frame number (default: the first in the dump).
    volume : {"occupancy", "surface", "smoothed"}
        What to show (``"smoothed"``: voxels with ``Ṽ^S > 0.5``).
    out : str or os.PathLike, optional
        PNG file (``*.png``) or folder (see :func:`view_png_path`).
    window : bool, optional
        Try a window first; default: when a display is available.

    Returns
    -------
    ViewOutcome

    Raises
    ------
    InputError
        Unreadable dump, a frame or volume it does not hold, a PNG that cannot be written.
    """
    from ..io._atomic import atomic_path
    from ..io.voxels import VoxelDump
    from ..viz.voxel_views import has_display, open3d_window, views_figure

    if volume not in ("occupancy", "surface", "smoothed"):
        raise InputError("volume", f"expected occupancy, surface or smoothed, got {volume!r}")
    with VoxelDump(dump_path) as dump:
        if frame is None:
            if not len(dump.frames):
                raise InputError(dump_path, "the dump holds no frames")
            frame = int(dump.frames[0])
        if volume == "smoothed":
            voxels = dump.smoothed(frame) > 0.5
        else:
            voxels = getattr(dump, volume)(frame)
        grid = dump.grid
        cameras = dump.cameras()
        masks = dump.masks(frame) if dump.has("masks") else None
        attrs = dump.attrs
    title = (f"{attrs.get('subject', '')}/{attrs.get('sequence', '')} frame {frame}: "
             f"{int(voxels.sum())} {volume} voxels of {grid.voxel_size:g} mm").lstrip("/ ")
    message = None
    if has_display() if window is None else window:
        if open3d_window(grid, voxels, title):
            return ViewOutcome(int(frame), None)
        message = "could not open a window; writing PNG views instead"
    png = view_png_path(dump_path, frame, out)  # its folder is created by atomic_path
    fig = views_figure(grid, voxels, frame, cameras=cameras, masks=masks, title=title)
    with atomic_path(png) as tmp:
        fig.savefig(tmp, format="png")
    return ViewOutcome(int(frame), png, message)
