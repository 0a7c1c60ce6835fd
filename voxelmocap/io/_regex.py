"""Regular expressions written by users (anipose's ``cam_regex``), matched without hanging.

Python's ``re`` backtracks: ``^(a+)+$`` on forty ``a`` and one ``b`` takes longer than the age of
the universe, and a project's ``config.toml`` is user input. :func:`user_regex` refuses, in one
line naming the file, the patterns whose matching can blow up on a file name:

* a repeat (``*``, ``+``, ``{n,}``, ``{n,m}`` with m > 1) whose body holds another repeat or an
  alternation (``(a+)+``, ``(a|aa)*``: exponential);
* more than :data:`MAX_UNBOUNDED` unbounded repeats in all (``a*a*a*a*b``: a power of the name's
  length per repeat);
* back-references (matching with them is NP-hard in general);
* patterns longer than :data:`MAX_PATTERN` characters.

What remains matches a name of at most 255 characters in well under a second. As a last guard,
:func:`bounded_search` stops a search after :data:`TIME_LIMIT_S` seconds when it runs in the
main thread (``re`` checks for signals while it backtracks) and refuses the pattern.

>>> user_regex(r"-cam([A-Z])", "config.toml").search("walk-camB").group(1)
'B'
"""

from __future__ import annotations

import contextlib
import re
import signal
import threading

from ..errors import InputError

try:  # Python ≥ 3.11
    import re._constants as _sre_constants
    import re._parser as _sre_parse
except ImportError:  # pragma: no cover - Python 3.10
    import sre_constants as _sre_constants
    import sre_parse as _sre_parse

__all__ = ["MAX_PATTERN", "MAX_UNBOUNDED", "TIME_LIMIT_S", "bounded_search", "user_regex"]

#: Longest pattern accepted (characters).
MAX_PATTERN = 200
#: Most unbounded repeats (``*``, ``+``, ``{n,}``) a pattern may hold.
MAX_UNBOUNDED = 3
#: Longest a search may run before the pattern is refused (seconds; main thread only).
TIME_LIMIT_S = 1.0

_REPEATS = {_sre_constants.MAX_REPEAT, _sre_constants.MIN_REPEAT}
if hasattr(_sre_constants, "POSSESSIVE_REPEAT"):
    _REPEATS.add(_sre_constants.POSSESSIVE_REPEAT)
_MAXREPEAT = _sre_constants.MAXREPEAT


def _children(op, av):
    """The sub-patterns of one parsed node."""
    name = str(op)
    if op in _REPEATS:
        return [av[2]]
    if name == "SUBPATTERN":
        return [av[-1]]
    if name == "BRANCH":
        return list(av[1])
    if name in ("ASSERT", "ASSERT_NOT"):
        return [av[1]]
    if name == "ATOMIC_GROUP":
        return [av]
    if name == "GROUPREF_EXISTS":
        return [p for p in av[1:] if p is not None]
    return []


def _walk(pattern):
    """Every (op, av) node of a parsed pattern, depth first."""
    for op, av in pattern:
        yield op, av
        for child in _children(op, av):
            yield from _walk(child)


def _problem(parsed) -> str | None:
    unbounded = 0
    for op, av in _walk(parsed):
        name = str(op)
        if name in ("GROUPREF", "GROUPREF_EXISTS", "GROUPREF_IGNORE", "GROUPREF_LOC_IGNORE",
                    "GROUPREF_UNI_IGNORE"):
            return "back-references are not accepted"
        if op in _REPEATS:
            _, high, body = av
            if high == _MAXREPEAT:
                unbounded += 1
            if high > 1 and any((o in _REPEATS and a[1] > 1) or str(o) == "BRANCH"
                                for o, a in _walk(body)):
                return ("a repeated group holds another repeat or an alternation (nested "
                        "quantifiers backtrack exponentially, e.g. '(a+)+')")
    if unbounded > MAX_UNBOUNDED:
        return (f"{unbounded} unbounded repeats (*, +, {{n,}}); at most {MAX_UNBOUNDED} are "
                "accepted (each multiplies the matching time by the name's length)")
    return None


def user_regex(pattern, source, what: str = "cam_regex") -> re.Pattern:
    """Compile a user's regular expression, refusing one that can take forever (module doc).

    Parameters
    ----------
    pattern : object
        The value read from the user's file.
    source : str or os.PathLike
        The file, named in errors.
    what : str
        The setting's name, for messages.

    Raises
    ------
    InputError
        Not a string, too long, not a regular expression, or one whose matching can blow up.
    """
    if not isinstance(pattern, str):
        raise InputError(source, f"{what} must be a string (a regular expression), got "
                                 f"{pattern!r:.60}")
    if len(pattern) > MAX_PATTERN:
        raise InputError(source, f"{what} is {len(pattern)} characters long; at most "
                                 f"{MAX_PATTERN} are accepted")
    try:
        compiled = re.compile(pattern)
        parsed = _sre_parse.parse(pattern)
    except (re.error, RecursionError, OverflowError) as exc:
        raise InputError(source, f"{what} {pattern!r} is not a regular expression "
                                 f"({' '.join(str(exc).split())[:80]})") from None
    problem = _problem(parsed)
    if problem:
        raise InputError(source, f"{what} {pattern!r}: {problem}")
    return compiled


class _TooSlow(Exception):
    pass


def bounded_search(regex: re.Pattern, text: str, source, what: str = "cam_regex"):
    """``regex.search(text)``, refused (:class:`InputError` naming ``source``) when it runs
    longer than :data:`TIME_LIMIT_S` seconds; unbounded outside the main thread, where no
    signal can stop it (:func:`user_regex` has refused what could take that long)."""
    if threading.current_thread() is not threading.main_thread() or \
            signal.getsignal(signal.SIGALRM) not in (signal.SIG_DFL, None):
        return regex.search(text)

    def stop(signum, frame):
        raise _TooSlow

    previous = signal.signal(signal.SIGALRM, stop)
    try:
        signal.setitimer(signal.ITIMER_REAL, TIME_LIMIT_S)
        try:
            return regex.search(text)
        finally:
            signal.setitimer(signal.ITIMER_REAL, 0)
    except _TooSlow:
        raise InputError(source, f"{what} {regex.pattern!r} took more than {TIME_LIMIT_S:g} s "
                                 f"to match {text[:40]!r}: simplify it") from None
    finally:
        with contextlib.suppress(ValueError):
            signal.signal(signal.SIGALRM, previous)
