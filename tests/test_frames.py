"""``frames``: the ``--frames`` selection, and frames spread evenly over a sequence.

The spread is checked against its definition written out (the k-th of ``count`` picks is the
item nearest ``k (n − 1) / (count − 1)``) for every small ``n`` and ``count``.
"""

import itertools

import numpy as np
import pytest

from voxelmocap.errors import InputError
from voxelmocap.frames import parse_frame_range, spread, spread_indices


def test_parse_frame_range():
    available = np.arange(1, 21)
    np.testing.assert_array_equal(parse_frame_range("6:9", available), [6, 7, 8, 9])
    np.testing.assert_array_equal(parse_frame_range(":3", available), [1, 2, 3])
    np.testing.assert_array_equal(parse_frame_range("18:", available), [18, 19, 20])
    np.testing.assert_array_equal(parse_frame_range(" 4 : 5 ", available), [4, 5])
    np.testing.assert_array_equal(parse_frame_range("3,1,3", available), [1, 3])
    for everything in (None, "", " : "):
        np.testing.assert_array_equal(parse_frame_range(everything, available), available)
    with pytest.raises(InputError, match="outside"):
        parse_frame_range("15:25", available)
    with pytest.raises(InputError, match="expected A:B"):
        parse_frame_range("a:b", available)
    with pytest.raises(InputError, match="empty range"):
        parse_frame_range("9:3", available)


@pytest.mark.parametrize("text, problem", [
    ("0:4", "frame 0 is outside the available frames 3..7"),
    ("3,5,9", "frame 9 is outside the available frames 3..7"),
    ("2:", "frame 2 is outside the available frames 3..7"),
    ("4-6", "expected A:B or a comma-separated list, got '4-6'"),
    ("3,,4", "expected A:B or a comma-separated list, got '3,,4'"),
    ("1.5:3", "expected A:B or a comma-separated list, got '1.5:3'"),
])
def test_a_bad_selection_is_one_line_about_frames(text, problem):
    with pytest.raises(InputError) as info:
        parse_frame_range(text, np.arange(3, 8))
    assert str(info.value) == f"--frames: {problem}"


def test_a_sequence_without_frames_has_nothing_to_select():
    assert parse_frame_range(None, np.array([], int)).tolist() == []
    with pytest.raises(InputError, match="no synchronised frame in every camera"):
        parse_frame_range("1:2", np.array([], int))


def test_frames_missing_inside_the_range_are_outside_it():
    """``available`` may have gaps: a range across one is refused at the first missing frame."""
    available = np.array([1, 2, 3, 7, 8])
    np.testing.assert_array_equal(parse_frame_range("7:", available), [7, 8])
    with pytest.raises(InputError, match=r"frame 4 is outside the available frames 1\.\.8"):
        parse_frame_range("2:7", available)


def test_spread_indices_are_the_nearest_to_even_steps():
    for n in range(1, 40):
        for count in range(1, 45):
            got = spread_indices(n, count).tolist()
            if n <= count:
                assert got == list(range(n)), (n, count)
            elif count == 1:
                assert got == [0], (n, count)
            else:
                steps = [k * (n - 1) / (count - 1) for k in range(count)]
                assert len(got) == count and got[0] == 0 and got[-1] == n - 1, (n, count)
                assert all(abs(g - s) <= 0.5 for g, s in zip(got, steps, strict=True)), (n, count)
                assert all(b > a for a, b in itertools.pairwise(got)), (n, count)


def test_spread_picks_those_numbers():
    frames = np.array([3, 4, 8, 9, 10, 15, 16, 30])
    np.testing.assert_array_equal(spread(frames, 3), frames[[0, 4, 7]])      # 0, 3.5, 7
    np.testing.assert_array_equal(spread(frames, 20), frames)
    assert spread([], 4).tolist() == []
