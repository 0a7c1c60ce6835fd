"""What a project's files are checked against and what is assumed: names, image sizes, world frame.

* :func:`match_cameras`: calibration cameras ↔ videos (same name; same name ignoring case,
  separators and leading zeros; the video's name containing the camera's as whole words; else, with
  no name in common and as many videos as cameras, natural order as Pose2Sim does).
* :func:`reconcile_size`: a video up to :data:`SIZE_TOLERANCE` pixels narrower / wider than its
  calibration is the calibrated image cropped / padded on the right or at the bottom (principal
  point kept); more is refused.
* :func:`world_frame_notes`: whether the calibration's world looks +Z up with the floor at Z = 0.

Each returns or appends one-line notes saying what was assumed (``voxelmocap info`` prints them).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ..errors import InputError
from .video import natural_key

__all__ = ["SIZE_TOLERANCE", "UP_TOLERANCE_DEG", "match_cameras", "reconcile_size",
           "world_frame_notes"]

#: Largest difference (pixels, per dimension) between a video's size and its calibration's that
#: is taken as a crop or pad on the right / bottom (codecs pad to multiples of 16).
SIZE_TOLERANCE = 16

# ---------------------------------------------------------------------- camera matching
def _tokens(name: str) -> tuple:
    """Lower-case words and integers of a name: ``"Cam_01"`` → ``("cam", 1)``."""
    return tuple(int(t) if t.isdigit() else t for t in re.findall(r"[a-z]+|\d+", name.lower()))


def _contains(haystack: tuple, needle: tuple) -> bool:
    n = len(needle)
    return n > 0 and any(haystack[i:i + n] == needle for i in range(len(haystack) - n + 1))


def match_cameras(camera_names: list[str], video_labels: list[str], *, notes: list[str]
                  ) -> tuple[dict[str, str], list[str], list[str]]:
    """Pair calibration cameras with videos (see the module docstring for the rules).

    Returns
    -------
    pairs : dict of str to str
        Camera name → video label.
    cameras_left, videos_left : list of str
        Cameras without a video and videos without a camera.
    """
    pairs: dict[str, str] = {}
    rules = (("same name", lambda c, v: c.lower() == v.lower()),
             ("same name ignoring case, separators and leading zeros",
              lambda c, v: _tokens(c) == _tokens(v)),
             ("the video's name contains the camera's",
              lambda c, v: _contains(_tokens(v), _tokens(c))))
    used_rules = []
    for phrase, rule in rules:
        cams = [c for c in camera_names if c not in pairs]
        vids = [v for v in video_labels if v not in pairs.values()]
        found = False
        for c in cams:
            hits = [v for v in vids if rule(c, v)]
            if len(hits) == 1 and sum(rule(c2, hits[0]) for c2 in cams) == 1:
                pairs[c] = hits[0]
                found = True
        if found:
            used_rules.append(phrase)
    cams_left = [c for c in camera_names if c not in pairs]
    vids_left = [v for v in video_labels if v not in pairs.values()]
    if not pairs and len(camera_names) == len(video_labels):
        ordered_c = sorted(camera_names, key=natural_key)
        ordered_v = sorted(video_labels, key=natural_key)
        pairs = dict(zip(ordered_c, ordered_v, strict=True))
        notes.append("no video is named after a calibration camera: paired in natural order "
                     "(as Pose2Sim does): " + ", ".join(f"{c} ↔ {v}" for c, v in pairs.items()))
        return pairs, [], []
    if used_rules and any(c.lower() != v.lower() for c, v in pairs.items()):
        notes.append("videos matched to calibration cameras by name (" + "; ".join(used_rules)
                     + "): " + ", ".join(f"{c} ↔ {v}" for c, v in pairs.items()))
    return pairs, cams_left, vids_left


# ---------------------------------------------------------------------- size reconciliation
def reconcile_size(camera, video_size: tuple[int, int], video: Path, *, unsized: bool,
                   notes: list[str]):
    """The camera with the video's image size, or :class:`InputError` when they cannot match."""
    w, h = video_size
    cw, ch = camera.size
    if unsized:
        notes.append(f"{camera.name}: the calibration states no image size; the video's {w}x{h} "
                     "is used")
        return camera.with_size((w, h))
    if (w, h) == (cw, ch):
        return camera
    if (w, h) == (ch, cw) and w != h:
        raise InputError(video, f"frame size {w}x{h} is the calibration's {cw}x{ch} turned by 90°: "
                                "a rotated video (rotate it back, or calibrate it as it is)")
    if abs(w - cw) <= SIZE_TOLERANCE and abs(h - ch) <= SIZE_TOLERANCE:
        parts = []
        if w != cw:
            parts.append(f"{abs(w - cw)} column(s) {'cropped' if w < cw else 'padded'} on the "
                         "right")
        if h != ch:
            parts.append(f"{abs(h - ch)} row(s) {'cropped' if h < ch else 'padded'} at the bottom")
        notes.append(f"{camera.name}: the video is {w}x{h}, the calibration {cw}x{ch}: taken as the "
                     f"calibrated image with {' and '.join(parts)} (principal point kept)")
        return camera.with_size((w, h))
    raise InputError(video, f"frame size {w}x{h} cannot be the calibration's {cw}x{ch} "
                            f"({camera.source}): more than {SIZE_TOLERANCE} pixels apart")


# ---------------------------------------------------------------------- world frame
#: Largest angle (degrees) between the cameras' mean up direction and +Z for a Z-up world.
UP_TOLERANCE_DEG = 30.0
_AXES = {"+X": (1, 0, 0), "-X": (-1, 0, 0), "+Y": (0, 1, 0), "-Y": (0, -1, 0), "+Z": (0, 0, 1),
         "-Z": (0, 0, -1)}


def world_frame_notes(rig) -> list[str]:
    """What the cameras say of the world frame, when it is not what the tracker assumes.

    The tracker assumes +Z up with the floor at Z = 0 (mm). A camera filming upright has its
    image's up (−y of the camera) roughly up in the world; the mean over the cameras is the
    world's up within the cameras' tilts, which cancel for cameras around the scene.
    """
    ups = np.array([-cam.R[1] for cam in rig])
    mean = ups.mean(axis=0)
    norm = np.linalg.norm(mean)
    if norm < 1e-6:
        return ["the cameras' up directions cancel out: cannot tell which world axis is up"]
    mean /= norm
    angle = float(np.degrees(np.arccos(np.clip(mean[2], -1.0, 1.0))))
    if angle <= UP_TOLERANCE_DEG:
        heights = [cam.center[2] for cam in rig]
        if min(heights) < 300.0:
            return [f"the cameras stand at Z = {min(heights):.0f}…{max(heights):.0f} mm: the "
                    "floor may not be at Z = 0 (the tracker assumes it is)"]
        return []
    axis = max(_AXES, key=lambda k: float(np.dot(_AXES[k], mean)))
    return [f"the world frame looks {axis}-up (the cameras' mean up direction is "
            f"({mean[0]:.2f}, {mean[1]:.2f}, {mean[2]:.2f}), {angle:.0f}° from +Z): the tracker "
            "assumes +Z up with the floor at Z = 0, re-express the calibration in such a frame"]
