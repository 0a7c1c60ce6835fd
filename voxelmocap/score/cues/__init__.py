"""Image cues of papers 000 (Azad et al.) and 004 (Fontmarty et al.) and their fusion.

The body tracker's likelihood is the weighted sum of the log-likelihoods of the selected cues
(``[cues] weights``, ``voxelmocap track --cues``): paper 002's voxel likelihood, Azad's
on-the-fly edge search along the cones' projected contours with the fast occlusion test, and
Fontmarty's Canny distance, ROI histograms, 3D blobs, skin colour and limb colour uniformity.
See ``docs/cues.md``.

- :mod:`.contours` — the two contour segments of every cone in every camera (000 §3.1.2);
- :mod:`.frame` — one frame's images prepared once (grey, Canny distance maps, colour bins);
- :mod:`.terms` — the cues (:data:`CUES`);
- :mod:`.fusion` — :class:`CueSet`, the weighted sum, built once and prepared per frame;
- :mod:`.reference` — plain references of the numba kernels (``voxelmocap.score.cues._cue_kernels``).
"""

from .contours import contour_angles, contour_points, project_contours
from .frame import CueFrame, image_bins
from .fusion import FUSED, CueSet, check_weights, parse_cues
from .terms import CUES, Cue, Views, bhattacharyya

__all__ = ["CUES", "FUSED", "Cue", "CueFrame", "CueSet", "Views", "bhattacharyya", "check_weights",
           "contour_angles", "contour_points", "image_bins", "parse_cues", "project_contours"]
