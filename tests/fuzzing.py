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


def refusal(call) -> str | None:
    """None when ``call()`` parses; the :class:`InputError` message when it refuses the input.

    Any other exception propagates: it would reach a user as a traceback, and fails the test.
    """
    try:
        call()
    except InputError as exc:
        return str(exc)
    return None


def is_one_line_about(message: str | None, path) -> bool:
    """Whether a refusal (or a parse, None) is the one-line error that names ``path``."""
    return message is None or (message.startswith(str(path)) and "\n" not in message)
