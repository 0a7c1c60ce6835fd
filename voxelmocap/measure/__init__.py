"""Measure: from camera images to one measured frame.

Silhouettes (:mod:`.silhouette`: background subtraction against a per-pixel Gaussian plate,
MOG2 or given person masks), the background plates learnt from empty videos or from the
sequence itself (:mod:`.background`), shape-from-silhouette carving (:mod:`.carving`), the
surface and its smoothing (:mod:`.surface`), the voxels' extremities (:mod:`.detect`) and the
one measured-frame type every consumer shares, :class:`.observation.VoxelObservation`, built by
:class:`.stage.MeasurementStage`. Pure: arrays and objects in, arrays and objects out; no file
is read or written here (the runner in :mod:`voxelmocap.run` does that). Imports only the
foundations and ``io``-free modules below it.
"""
