"""A pinhole camera looking at a point: the image cues' and the limb sweep's test rigs."""

import numpy as np

from voxelmocap.camera import Camera


def look_at_camera(name="C", eye=(0.0, -4000.0, 1000.0), size=(640, 480), focal=500.0,
                   target=(0.0, 0.0, 1000.0)) -> Camera:
    """A camera at ``eye`` (mm) looking at ``target``, its x axis level, focal length ``focal``
    pixels, the principal point at the image centre, no distortion."""
    eye = np.asarray(eye, dtype=float)
    z = np.asarray(target, dtype=float) - eye
    z /= np.linalg.norm(z)
    x = np.cross(z, [0, 0, 1.0])
    x /= np.linalg.norm(x)
    rot = np.stack([x, np.cross(z, x), z])
    return Camera(name, fc=(focal, focal), cc=(size[0] / 2, size[1] / 2), R=rot, T=-rot @ eye,
                  size=size)
