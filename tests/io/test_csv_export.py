"""``io.csv_export``: the tidy landmark CSV read by the standard library's ``csv`` module, and
:func:`read_points_csv` on references written here in each accepted layout, and its refusals."""

import csv

import numpy as np
import pytest

from voxelmocap.errors import InputError
from voxelmocap.io.csv_export import COLUMNS, read_points_csv, write_landmarks_csv

NAMES = ["head", "l_wrist", "r_ankle"]


def _data(seed=0, n=3):
    rng = np.random.default_rng(seed)
    x = rng.uniform(-2000.0, 2000.0, (n, 3, 3))
    x[1, 0] = np.nan                                 # no estimate: empty cells
    confidence = rng.random((n, 3))
    confidence[2, 2] = np.nan
    spread = rng.uniform(0.0, 80.0, (n, 3))
    return x, confidence, spread


def test_one_row_per_frame_and_landmark_read_by_the_csv_module(tmp_path):
    x, confidence, spread = _data()
    frames = [5, 6, 9]
    path = write_landmarks_csv(tmp_path / "a.csv", x, NAMES, frames=frames, frame_rate=50.0,
                               confidence=confidence, spread=spread,
                               observed=[True, False, True])
    assert [p.name for p in tmp_path.iterdir()] == ["a.csv"]
    with open(path, newline="", encoding="utf-8") as handle:
        reader = csv.DictReader(handle)
        rows = list(reader)
    assert tuple(reader.fieldnames) == COLUMNS
    assert len(rows) == 3 * 3
    assert [(r["frame"], r["landmark"]) for r in rows] == [
        (str(f), n) for f in frames for n in NAMES]             # by frame, then landmark
    for r, (i, j) in zip(rows, np.ndindex(3, 3), strict=True):
        assert float(r["time_s"]) == pytest.approx((frames[i] - 1) / 50.0, abs=5e-7)
        for k, column in enumerate(("x_mm", "y_mm", "z_mm")):
            if np.isnan(x[i, j, k]):
                assert r[column] == ""
            else:
                assert float(r[column]) == pytest.approx(x[i, j, k], abs=5e-7)
        assert (r["confidence"] == "") == bool(np.isnan(confidence[i, j]))
        if r["confidence"]:
            assert float(r["confidence"]) == pytest.approx(confidence[i, j], abs=5e-7)
        assert float(r["spread_mm"]) == pytest.approx(spread[i, j], abs=5e-7)
        assert r["observed"] == ("0" if i == 1 else "1")
    # without confidence, spread or flags: empty cells and every frame observed
    path = write_landmarks_csv(tmp_path / "b.csv", x[:1], NAMES, frames=[1], frame_rate=30.0)
    with open(path, newline="", encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    assert [(r["time_s"], r["confidence"], r["spread_mm"], r["observed"]) for r in rows] == \
        [("0.000000", "", "", "1")] * 3


def test_the_reader_reads_back_what_the_writer_wrote(tmp_path):
    x, confidence, spread = _data(seed=4, n=5)
    path = write_landmarks_csv(tmp_path / "a.csv", x, NAMES, frames=[9, 3, 4, 5, 7],
                               frame_rate=60.0, confidence=confidence, spread=spread)
    names, frames, positions, axes = read_points_csv(path)
    assert axes is None
    assert names == NAMES and frames.tolist() == [3, 4, 5, 7, 9]     # sorted
    np.testing.assert_allclose(positions, x[[1, 2, 3, 4, 0]], rtol=0, atol=5e-7)
    assert np.isnan(positions[0, 0]).all()                           # frame 3's head: no value


def _write_rows(path, header, rows, encoding="utf-8"):
    with open(path, "w", newline="", encoding=encoding) as handle:
        out = csv.writer(handle)
        out.writerow(header)
        out.writerows(rows)
    return path


@pytest.mark.parametrize("header, scale", [
    (["Frame", "Marker", "X", "Y", "Z"], 1.0),
    (["frame", "name", "x_m", "y_m", "z_m", "extra"], 1000.0),
    (["landmark", "z_mm", "frame", "y_mm", "x_mm"], 1.0),
])
def test_references_in_every_layout_are_read_in_mm(tmp_path, header, scale):
    rng = np.random.default_rng(7)
    truth = rng.uniform(-1.5, 1.5, (2, 2, 3)) * 1000.0 / scale       # in the file's unit
    rows = []
    for fi, frame in enumerate((12, 10)):
        for pi, name in enumerate(("RHEE", "LHEE")):
            cells = {"frame": frame, "name": name, "x": truth[fi, pi, 0],
                     "y": truth[fi, pi, 1], "z": truth[fi, pi, 2], "extra": "-"}
            rows.append([cells[_key(h)] for h in header])
    rows.insert(2, [])                                               # a blank line is skipped
    path = _write_rows(tmp_path / "ref.csv", header, rows, encoding="utf-8-sig")  # with a BOM
    names, frames, positions, axes = read_points_csv(path)
    assert axes is None
    assert names == ["RHEE", "LHEE"] and frames.tolist() == [10, 12]
    np.testing.assert_allclose(positions, truth[::-1] * scale, rtol=1e-12)


def _key(header):
    h = header.lower()
    return {"marker": "name", "landmark": "name"}.get(h, h.split("_")[0])


@pytest.mark.parametrize("content, problem", [
    (None, "CSV file not found"),
    ("", "empty CSV file"),
    ("frame,landmark,x,y\n1,a,1,2\n", "CSV needs columns frame, landmark"),
    ("frame,landmark,x,y,z\n", "CSV file has no data rows"),
    ("frame,landmark,x,y,z\n1,a,1,2\n", "line 2: 4 cells, the header has 5"),
    ("frame,landmark,x,y,z\n1,a,1,2,3\n2.5,a,1,2,3\n", "line 3: frame or coordinate is not a number"),
    ("frame,landmark,x,y,z\n1,a,1,two,3\n", "line 2: frame or coordinate is not a number"),
    ("frame,landmark,x,y,z\n1,a,1,2,3\n1,a,4,5,6\n", "line 3: 'a' given twice for frame 1"),
])
def test_bad_references_are_one_line_naming_the_file(tmp_path, content, problem):
    path = tmp_path / "ref.csv"
    if content is not None:
        path.write_text(content)
    with pytest.raises(InputError) as info:
        read_points_csv(path)
    assert str(info.value).startswith(f"{path}: {problem}") and "\n" not in str(info.value)


def test_a_folder_or_bytes_that_are_not_text_are_refused(tmp_path):
    with pytest.raises(InputError, match="is not a file"):
        read_points_csv(tmp_path)
    path = tmp_path / "ref.csv"
    path.write_bytes(b"frame,landmark,x,y,z\n1,\xff\xfe,1,2,3\n")
    with pytest.raises(InputError, match="cannot read the CSV file"):
        read_points_csv(path)
