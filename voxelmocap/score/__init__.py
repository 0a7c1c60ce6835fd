"""Score: how well a body state explains a measured frame.

The voxel scores of paper 002 (:mod:`.likelihood`: Out, DO, Empty = 1 − Occ, Surf per part and
their log-likelihood, eqs 3–9; rasterisation by closed-form column intervals in
:mod:`._raster_kernels`), the exact re-scoring of a moving limb against the held rest of the
body (:mod:`.partial`), and the image cues of papers 000 and 004 (:mod:`.cues`: silhouette,
edges, distance transform, regions, skin, fusion). Every kernel has a plain reference the tests
hold it to. Imports the foundations and :mod:`voxelmocap.measure`, never ``pose`` or ``run``.
"""
