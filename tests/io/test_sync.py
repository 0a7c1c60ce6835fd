import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from voxelmocap.errors import InputError
from voxelmocap.io.humaneva import read_ofs, sync_starts, write_ofs


def test_ofs_round_trip(tmp_path):
    path = tmp_path / "Walking_1_(C1).ofs"
    write_ofs(path, 83.0, 165.5, 2.0004)
    assert read_ofs(path) == pytest.approx((83.0, 165.5, 2.0004))


@pytest.mark.parametrize(
    ("text", "message"),
    [("1\n2\n", "expected 3 numbers"), ("1\n2\n3\n4\n", "expected 3 numbers"),
     ("1\nx\n2\n", "not a number"), ("1\n2\nnan\n", "not finite"), ("1\n2\n0\n", "mc_sc"),
     ("-5\n1\n2\n", "im_st .* must not be negative, got -5"),
     ("8\n-0.5\n2\n", "mc_st .* must not be negative, got -0.5")],
)
def test_bad_ofs(tmp_path, text, message):
    path = tmp_path / "bad.ofs"
    path.write_text(text)
    with pytest.raises(InputError, match=message) as info:
        read_ofs(path)
    assert str(path) in str(info.value)


@settings(max_examples=200, deadline=None)
@given(st.text(max_size=80))
def test_ofs_parser_fuzz(tmp_path_factory, text):
    path = tmp_path_factory.mktemp("ofs") / "x.ofs"
    path.write_text(text, encoding="utf-8")
    try:
        values = read_ofs(path)
    except InputError:
        return
    assert len(values) == 3 and values[0] >= 0 and values[1] >= 0 and values[2] > 0


def test_sync_worked_example_with_matlab_rounding():
    # Worked by hand with the rules of HUMANEVA.md §3.2:
    # ref A: common_time = 5, start A = 3; B: 10 + (5 − 4)/2 = 10.5; C: 6 + (5 − 9)/2 = 4
    # scaling = 2; min start = 3 → common_time = 5 − 2·2 = 1; starts A 1, B 8.5, C 2
    # MATLAB round(8.5) = 9 (Python's round would give 8).
    starts, common_time, scaling = sync_starts({"A": (3, 5, 2), "B": (10, 4, 2), "C": (6, 9, 2)})
    assert starts == {"A": 1, "B": 9, "C": 2}
    assert common_time == pytest.approx(1.0)
    assert scaling == pytest.approx(2.0)


def test_sync_worked_example_with_negative_common_time():
    # ref A: common_time = 2, start A = 10; B: 4 + (2 − 3)/2 = 3.5; min = 3.5
    # common_time = 2 − 2·2.5 = −3 → starts A 7.5, B 1; common_time < 1 → shift by +2:
    # A 9.5 → 10, B 3, common_time = 1.  (B: image 4 ↔ mocap 3, so mocap 1 ↔ image 3.)
    starts, common_time, _ = sync_starts({"A": (10, 2, 2), "B": (4, 3, 2)})
    assert starts == {"A": 10, "B": 3}
    assert common_time == 1.0


def test_sync_averages_scaling():
    # A ref (common_time 20); B: 15 + (20 − 30)/2.2; C: 8 + (20 − 16)/1.8; mean scaling (2+2.2+1.8)/3
    starts, common_time, scaling = sync_starts({"A": (10, 20, 2.0), "B": (15, 30, 2.2),
                                                "C": (8, 16, 1.8)})
    assert scaling == pytest.approx(2.0)
    assert common_time == pytest.approx(20 - 2.0 * 9)
    assert starts == {"A": 1, "B": 1, "C": 1}


def test_generator_recipe_maps_frames_to_leads():
    leads = {"C1": 5, "C2": 9, "BW1": 7}
    starts, common_time, _ = sync_starts({c: (d + 1, 1, 2.0) for c, d in leads.items()})
    assert starts == {c: d + 1 for c, d in leads.items()}
    assert common_time == 1.0
