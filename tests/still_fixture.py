"""A rendered sequence, in memory, of a person who stands still for the first half and then walks.

Used by the tests of the learnt background plate (``tests/measure/test_background.py``): the renderer's
own empty-scene image is the true background the plate must recover.
"""

from __future__ import annotations

import numpy as np

CAMERAS = ("C1", "C2", "C3", "BW1")


def render_still_then_walk(n_frames: int = 24, *, cameras=CAMERAS, noise: float = 2.0,
                           seed: int = 0, still_share: float = 0.5, motion: str = "walk",
                           shadow: bool = True):
    """Render the sequence.

    Returns
    -------
    rig : Rig
    frames : dict of str to (F, H, W, 3) uint8
    truth_bg : dict of str to (H, W, 3) uint8
        The empty scene through the same sensor model without noise.
    masks : dict of str to (F, H, W) bool
        The person's true masks.
    points : (F, 20, 3) canonical points (mm)
    """
    import cv2

    from voxelmocap.io.calibration import read_rig
    from voxelmocap.synth.body_shape import BodyShape, body_primitives
    from voxelmocap.synth.render import Renderer
    from voxelmocap.synth.resample import motion_source, place_in_area, sample_motion
    from voxelmocap.synth.scene import sensor
    from voxelmocap.synth.writer import BLUR, default_rig_path

    rig = read_rig(default_rig_path()).select(list(cameras))
    fps = 8.0   # slow sampling: the walk leaves the standing place within the second half
    source = motion_source(motion, height=1750.0, seed=seed)
    pts = place_in_area(sample_motion(source, n_frames, fps), fps)
    n_still = int(round(still_share * n_frames))
    pts[:n_still] = pts[n_still]      # stands where the walk starts, then walks off
    shape = BodyShape.for_subject("S1", 1750.0)
    renderer = Renderer(rig)
    rng = np.random.default_rng(seed)
    frames = {c.name: [] for c in rig}
    masks = {c.name: [] for c in rig}
    truth = {}
    for cam in rig:
        bg = cv2.GaussianBlur(renderer.background(cam.name), (0, 0), BLUR)
        truth[cam.name] = sensor(bg, gray=False, gain=1.0, noise_sigma=0.0, rng=rng, blur=0.0)
    for k in range(n_frames):
        prims = body_primitives(pts[k], shape)
        for cam in rig:
            radiance, mask = renderer.render(cam.name, prims, shadow=shadow)
            frames[cam.name].append(sensor(radiance, gray=False, gain=1.0, noise_sigma=noise,
                                           rng=rng, blur=BLUR))
            masks[cam.name].append(mask)
    return (rig, {n: np.stack(v) for n, v in frames.items()}, truth,
            {n: np.stack(v) for n, v in masks.items()}, pts)
