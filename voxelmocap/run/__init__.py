"""Run: sequences on disk in, results on disk out.

A ``track`` is a plan (:mod:`.plan`: how many passes, where each pass's plate and start come
from) executed by one loop (:mod:`.pipeline`); :mod:`.measurement` binds the measurement stage
to a sequence on disk (and writes voxel dumps); :mod:`.batch` and :mod:`.sweep` run many
sequences or settings as Dask tasks (:mod:`.tasks`); :mod:`.inspection` draws results over the
images. With :mod:`voxelmocap.io` and the command line, the only place that touches files.
"""
