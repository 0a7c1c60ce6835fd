"""Every bad input of ``tests/bad_input_cases.py`` and ``tests/bad_project_cases.py`` (issue 36):
exit 2, one line, no traceback, nothing left."""

from __future__ import annotations

import pytest
from bad_input_cases import CASES as INPUT_CASES
from bad_project_cases import CASES as PROJECT_CASES
from humaneva_fixture import make_tiny_dataset

from voxelmocap.cli import main


def _snapshot(*folders):
    return {p: p.lstat().st_size for f in folders for p in f.rglob("*")}


CASES = INPUT_CASES + PROJECT_CASES


@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_bad_input(case, tmp_path, capsys):
    data = make_tiny_dataset(tmp_path / "data")
    scratch = tmp_path / "scratch"
    scratch.mkdir()
    argv = case.setup(data, scratch)
    if case.name.startswith("view"):
        assert main(["dump", str(data), "--subject", "S1", "--sequence", "Walking_1", "--frames",
                     "1:2", "--out", str(scratch / "vox.h5"), "--no-progress"]) == 0
    capsys.readouterr()
    before = _snapshot(data, scratch)
    code = main(argv)
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert code == 2, err
    assert len(lines) == 1, err
    assert "Traceback" not in err
    for expected in case.expect:
        assert expected.format(data=data, tmp=scratch) in lines[0], lines[0]
    # Nothing new: no partial, temporary or half-written file anywhere.
    assert _snapshot(data, scratch) == before
