"""Print the Markdown table of ``docs/bad_inputs.md``: every bad-input case and its message.

Runs each case of ``tests/bad_input_cases.py`` (the same cases ``tests/test_bad_inputs.py``
checks) on a fresh tiny data set in a temporary folder and prints the command's one-line
message, with the temporary paths shortened to ``DATA/`` and ``TMP/``.

Usage: ``python scripts/bad_inputs_table.py > docs/bad_inputs.md``

Not a benchmark: it writes ``docs/bad_inputs.md``.
"""

from __future__ import annotations

import contextlib
import io
import sys
import tempfile
from pathlib import Path

TESTS = Path(__file__).resolve().parents[1] / "tests"
sys.path.insert(0, str(TESTS))

from bad_input_cases import CASES  # noqa: E402
from humaneva_fixture import make_tiny_dataset  # noqa: E402

from voxelmocap.cli import main  # noqa: E402


def run_case(case) -> tuple[int, str]:
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        data = make_tiny_dataset(tmp / "data")
        scratch = tmp / "scratch"
        scratch.mkdir()
        argv = case.setup(data, scratch)
        quiet = io.StringIO()
        if case.name.startswith("view"):
            with contextlib.redirect_stdout(quiet), contextlib.redirect_stderr(quiet):
                main(["dump", str(data), "--subject", "S1", "--sequence", "Walking_1", "--frames",
                      "1:2", "--out", str(scratch / "vox.h5"), "--no-progress"])
        err = io.StringIO()
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
            code = main(argv)
        text = err.getvalue().strip().replace(str(data), "DATA").replace(str(scratch), "TMP")
        return code, text


def main_table() -> None:
    print("# Bad input and the one line it gets\n")
    print("Every row is a test (`tests/test_bad_inputs.py`, cases in `tests/bad_input_cases.py`):")
    print("exit code 2, one line on stderr naming the file or option and the problem, no traceback,")
    print("and no file created or changed. Regenerate with")
    print("`python scripts/bad_inputs_table.py > docs/bad_inputs.md`.\n")
    print("| bad input | exit | message |")
    print("|---|---|---|")
    for case in CASES:
        code, text = run_case(case)
        print(f"| {case.name} | {code} | `{text.replace('|', '¦')}` |")


if __name__ == "__main__":
    import argparse

    argparse.ArgumentParser(description=__doc__.split("\n\n")[0]).parse_args()
    main_table()
