"""Hypothesis strategies shared by the reader fuzz tests."""

from __future__ import annotations

from hypothesis import strategies as st

from voxelmocap.errors import InputError


@st.composite
def mutated(draw, seed: bytes):
    """``seed`` with 1–6 random byte flips, insertions, deletions or a truncation."""
    data = bytearray(seed)
    for _ in range(draw(st.integers(1, 6))):
        op = draw(st.sampled_from(["flip", "insert", "delete", "truncate"]))
        pos = draw(st.integers(0, max(len(data) - 1, 0)))
        if op == "flip" and data:
            data[pos] = draw(st.integers(0, 255))
        elif op == "insert":
            data[pos:pos] = draw(st.binary(min_size=1, max_size=8))
        elif op == "delete":
            del data[pos:pos + draw(st.integers(1, 16))]
        else:
            del data[pos:]
    return bytes(data)


def check_parses_or_one_line(path, call) -> None:
    """``call()`` returns, or raises :class:`InputError` naming ``path`` in one line; any other
    exception propagates (it would reach a user as a traceback) and fails the test."""
    try:
        call()
    except InputError as exc:
        message = str(exc)
        assert message.startswith(str(path)), message
        assert "\n" not in message, message
