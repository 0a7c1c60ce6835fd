"""What a finished pass writes beside its result: body_pose XML, BVH, TRC / C3D / CSV.

The result file itself is streamed frame by frame (:class:`voxelmocap.io.results.ResultWriter`);
these exports are written once, at the end, from the frames the result holds.
"""

from __future__ import annotations

import numpy as np

__all__ = ["frame_list", "kernels_cached", "landmark_exports", "write_exports"]


def write_exports(xml_path, bvh_path, seq, gt, frames, endpoints, fps, observed=None) -> None:
    """The body_pose XML (HUMANEVA.md §6) and the BVH of tracked poses.

    Frames flagged without a person (``observed`` False) have every endpoint disabled in the
    XML; the BVH holds the repeated last estimate there (a BVH has no flags).

    Parameters
    ----------
    xml_path, bvh_path : Path
    seq : Sequence
    gt : GroundTruth or None
        Its attributes name the data set in the XML.
    frames : (F,) int ndarray
    endpoints : (F, 20, 3) ndarray
        mm.
    fps : float
        The BVH's frame rate (Hz).
    observed : (F,) bool ndarray, optional
    """
    from ..io.body_pose_xml import write_body_pose_xml
    from ..io.bvh_writer import write_landmarks_bvh
    from ..joints import endpoints_to_landmarks

    source = gt.attributes if gt is not None else {}
    attributes = {"DatasetName": source.get("DatasetName", "HumanEvaI"),
                  "DatasetBasePath": source.get("DatasetBasePath", "../"),
                  "SubjectName": seq.subject, "ActionType": seq.action, "Trial": seq.trial,
                  "FrameStart": int(frames[0]), "FrameEnd": int(frames[-1]),
                  "Partition": source.get("Partition", "Validate")}
    enabled = None if observed is None else np.repeat(np.asarray(observed, bool)[:, None], 20,
                                                      axis=1)
    write_body_pose_xml(xml_path, frames, endpoints, enabled, attributes=attributes)
    write_landmarks_bvh(bvh_path, endpoints_to_landmarks(endpoints), fps)


def landmark_exports(result_path, config, result=None) -> list:
    """The TRC / C3D / CSV files of ``config.export``, from the finished result file."""
    from ..io.exports import export_result

    ex = config.export
    return export_result(result_path, ex.formats, cutoff_hz=ex.cutoff_hz, order=ex.order,
                         axes=ex.axes, result=result)


def kernels_cached() -> bool:
    """Whether numba's on-disk cache holds the likelihood kernel (else the first frame compiles).

    Looks for the kernel's cache index where numba keeps it (``NUMBA_CACHE_DIR``, else the
    module's ``__pycache__``), through numba's public configuration only; the message it gates is
    a courtesy, so anything unexpected counts as cached.
    """
    from pathlib import Path

    from ..score import _raster_kernels

    try:
        import numba

        if _raster_kernels.part_counts.signatures:  # compiled in this process already
            return True
        module = Path(_raster_kernels.__file__)
        cache_dir = getattr(numba.config, "CACHE_DIR", "") or ""
        places = [module.parent / "__pycache__"]
        if cache_dir:
            places.append(Path(cache_dir))
        return any(any(place.rglob(f"{module.stem}.part_counts-*.nbi")) for place in places
                   if place.is_dir())
    except (AttributeError, OSError):
        return True


def frame_list(frames, n: int = 10) -> str:
    """``"1, 2, 3 … (7 more)"``: the first ``n`` frame numbers of a list, for a message."""
    shown = ", ".join(str(int(f)) for f in frames[:n])
    return shown + (f" … ({len(frames) - n} more)" if len(frames) > n else "")
