"""Synthetic HumanEva-format sequences: motion sources, a body that is not the tracker's, a renderer.

The pipeline (``docs/synth.md``): a motion source (a BVH clip of any supported skeleton family,
or a built-in procedural motion) gives 20 canonical body points per frame
(:mod:`.skeletons`, :mod:`.motions`); they are resampled to the video rate and placed in the
capture area (:mod:`.resample`); a body of capsules and ellipsoids in clothing colours is built
around them (:mod:`.body_shape`) and ray-cast into every camera of a rig over a textured room with
a soft floor shadow, sensor noise and flicker (:mod:`.render`, :mod:`.scene`); :mod:`.writer`
writes the HumanEva-I layout with the ground truth.

>>> from voxelmocap.synth import generate
>>> root = generate("/tmp/synth", motion="walk", frames=30, cameras=["C1", "BW1"],
...                 progress=False)                                   # doctest: +SKIP
"""

from .motions import MOTIONS, procedural_points
from .skeletons import CANONICAL_NAMES, bvh_canonical_points, endpoints_from_canonical
from .writer import default_rig_path, generate

__all__ = [
    "CANONICAL_NAMES",
    "MOTIONS",
    "bvh_canonical_points",
    "default_rig_path",
    "endpoints_from_canonical",
    "generate",
    "procedural_points",
]
