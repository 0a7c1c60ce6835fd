"""Rewrite the configuration reference tables of ``docs/usage.md`` from the config's schema.

Each section's table sits between ``<!-- config-table SECTION -->`` and
``<!-- end config-table -->``; this replaces what is between them with
:func:`voxelmocap._config_schema.reference_table` of the section (key, default, range, unit,
one-line meaning), and leaves the hand-written notes around them alone.
``tests/test_config_schema.py`` fails while the tables and the schema differ.

Usage: ``python scripts/config_reference.py [docs/usage.md]``
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

from voxelmocap._config_schema import reference_table
from voxelmocap.config import SECTIONS
from voxelmocap.io._atomic import atomic_write_text

USAGE = Path(__file__).resolve().parents[1] / "docs" / "usage.md"


def rewrite(text: str) -> str:
    """``text`` with every section's table block replaced by the schema's table."""
    for cls in SECTIONS:
        begin = f"<!-- config-table {cls._section} -->\n"
        pattern = re.compile(re.escape(begin) + r".*?(?=<!-- end config-table -->)", re.S)
        if not pattern.search(text):
            raise SystemExit(f"no table block for [{cls._section}]: add {begin.strip()} and "
                             "<!-- end config-table --> where its table goes")
        text = pattern.sub(lambda _, cls=cls, begin=begin: begin + reference_table(cls), text)
    return text


def main(argv: list[str]) -> int:
    path = Path(argv[0]) if argv else USAGE
    old = path.read_text(encoding="utf-8")
    new = rewrite(old)
    if new != old:
        atomic_write_text(path, new)
    print(f"{path}: {'rewritten' if new != old else 'up to date'}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
