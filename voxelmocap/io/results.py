"""Tracking results in HDF5: one self-describing file per sequence, streamed one frame at a time.

``RUN/<Subject>/<Action>_<Trial>.h5`` holds

* per-frame datasets, frames along axis 0, each with ``units`` and ``description`` attributes:
  ``frames`` (F,) synchronised 1-based frame numbers, ``state`` (F, 27) and ``map_state`` (F, 27)
  (mm, rad; names in ``state_names``), ``landmarks`` (F, 15, 3) mm, ``endpoints`` (F, 20, 3) mm,
  ``part_scores`` (F, n_parts, 4) of the estimate (Out, DO, Empty, Surf), ``ess`` and ``betas``
  (F, L) per annealing layer, ``seconds`` (F,) per frame, ``log_likelihood`` (F,);
  ``landmark_spread`` (F, 15) mm and ``confidence`` (F, 15) in [0, 1] per landmark
  (:mod:`voxelmocap.pose.confidence`), ``observed`` (F,) uint8 (0: flagged without a person, the row
  repeating the last estimate, ``voxelmocap.pose.recovery``; format 3 on —
  a format-2 file reads as NaN spread and confidence and every frame observed);
* ``state_names`` and ``part_names``: UTF-8 string datasets;
* file attributes: ``format`` / ``format_version``, ``voxelmocap_version``, ``created`` (UTC, ISO
  8601), ``length_unit`` ``"mm"``, ``angle_unit`` ``"rad"``, ``coordinate_frame`` (Z up, floor at
  Z = 0), ``frame_rate`` (Hz), ``landmark_names``, ``endpoint_names``, ``state_names``,
  ``part_names``, ``score_names``, and what the writer was given (``config`` TOML, ``seed``,
  ``dataset`` = the data source, ``subject``, ``action``, ``trial``, ``cameras``, ``body_model``,
  ``init_method``, ``frames_requested``, ``person_masks`` = the ``--masks`` folder or empty,
  ``plate_from`` = the ``--plate-from`` result file or empty);
  strings are UTF-8 (variable length);
* ``commit`` (3,) int64: the number of committed frames, the checkpoint slot holding their filter
  state (−1 for none) and 1 once the run is complete. **Rows beyond the committed count are not
  results** (a killed run may leave one half-written row); :func:`read_result` drops them.
* ``checkpoint_0``, ``checkpoint_1``: uint8, an uncompressed NumPy ``.npz`` archive of the filter
  state after the committed frames (``np.load(io.BytesIO(bytes))``), so ``--resume`` continues
  bit-identically. The two slots alternate: a frame's state goes into the slot not committed.

Writing (:class:`ResultWriter`). The file is created under a temporary name
(``.<name>.partial`` beside it), switched to HDF5's single-writer/multiple-reader (SWMR) mode and
renamed into place, then each frame is appended: the per-frame rows and the checkpoint slot are
written and flushed, and only then the ``commit`` record, flushed again. SWMR mode orders HDF5's
metadata writes so that the file on disk is consistent at every instant; with the commit written
last, a run killed at any moment leaves a readable file holding every completed frame and the
checkpoint of the last one. The cost of a frame does not grow with the sequence (chunked, resizable
datasets; ``scripts/bench_results.py``). The writer holds an exclusive ``flock`` on the file for
the whole run (released by the kernel when the process dies), so a second run on the same result
is refused; a short ``flock`` on the folder serialises creation and renaming. The temporary file
exists only while a file is being created; one left by a killed creation is removed by the next
writer in that folder.

Reading. A file being written, or left by a killed run, still carries HDF5's "open for writing"
mark: :func:`read_result` opens it in SWMR-read mode; other tools need ``h5py.File(path, "r",
swmr=True, locking=False)`` (or ``h5clear -s``). ``--resume`` copies the committed frames into a
fresh file, which clears the mark. While a writer runs, a read can overlap its flush (HDF5 then
sees the file's end before its data) or its next commit (which may rewrite the checkpoint slot
two commits on): :func:`read_result` reads the commit record again after the checkpoint and
repeats a read that a running writer disturbed, so it returns the frames committed at one
instant.
"""

from ._result_format import FORMAT, FORMAT_VERSION, PER_FRAME, TrackResult
from ._result_locks import check_not_being_written
from ._result_reader import read_result
from ._result_writer import ResultWriter, write_result

__all__ = ["FORMAT", "FORMAT_VERSION", "PER_FRAME", "ResultWriter", "TrackResult",
           "check_not_being_written", "read_result", "write_result"]
