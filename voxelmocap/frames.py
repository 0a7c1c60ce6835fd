"""Frame selections: which synchronised frames a command works on (``--frames``).

Shared by the runners (track, dump, sweep), so it sits below all of them.
"""

from __future__ import annotations

import numpy as np

from .errors import InputError

__all__ = ["parse_frame_range", "spread", "spread_indices"]


def parse_frame_range(text: str | None, available: np.ndarray) -> np.ndarray:
    """Frames selected by ``"a:b"`` (inclusive, 1-based, either end optional) or ``"a,b,c"``.

    Parameters
    ----------
    text : str or None
        The selection; None selects every available frame.
    available : (F,) ndarray of int
        The frames that exist (sorted).

    Raises
    ------
    InputError
        Malformed text, or frames outside the available range.
    """
    available = np.asarray(available, dtype=int)
    if text is None or text.strip() in ("", ":"):
        return available
    if len(available) == 0:
        raise InputError("--frames", "the sequence has no synchronised frame in every camera")
    lo_avail, hi_avail = int(available.min()), int(available.max())
    try:
        if ":" in text:
            lo_text, hi_text = text.split(":", 1)
            lo = int(lo_text) if lo_text.strip() else lo_avail
            hi = int(hi_text) if hi_text.strip() else hi_avail
            frames = np.arange(lo, hi + 1)
        else:
            frames = np.array(sorted({int(t) for t in text.split(",")}))
    except ValueError:
        raise InputError("--frames", f"expected A:B or a comma-separated list, got {text!r}") from None
    if len(frames) == 0:
        raise InputError("--frames", f"empty range {text!r}")
    outside = np.setdiff1d(frames, available)
    if len(outside):
        raise InputError("--frames", f"frame {outside[0]} is outside the available frames "
                                     f"{lo_avail}..{hi_avail}")
    return frames


def spread_indices(n: int, count: int) -> np.ndarray:
    """Indices of at most ``count`` of ``n`` items spread evenly from the first to the last
    (all of them when ``n <= count``), increasing.

    >>> spread_indices(10, 4).tolist(), spread_indices(3, 5).tolist()
    ([0, 3, 6, 9], [0, 1, 2])
    """
    return np.unique(np.linspace(0, n - 1, min(n, count)).round().astype(int))


def spread(numbers, count: int) -> np.ndarray:
    """At most ``count`` of ``numbers`` (e.g. frame numbers) spread evenly from the first to the
    last (:func:`spread_indices`)."""
    numbers = np.asarray(numbers)
    return numbers[spread_indices(len(numbers), count)]
