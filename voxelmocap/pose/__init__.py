"""Pose: the body tracker and everything that decides a pose from scores.

:class:`.tracker.BodyTracker` assembles the annealed filter of :mod:`voxelmocap.tracking` over
the body model's likelihood and steps it frame by frame; around it: where a track starts
(:mod:`.initialise`, :mod:`.starts`), the limb search over whole joint ranges
(:mod:`.limb_search`), the hierarchy of partitions (:mod:`.hierarchy`), recovery of a lost
track and of frames without a person (:mod:`.recovery`), the body's size fitted to the voxels
(:mod:`.body_size`), a previous track's body as a plate's cover (:mod:`.body_cover`) and each
landmark's confidence (:mod:`.confidence`). Touches no file; imports ``measure`` and ``score``
below it, never ``run``.
"""
