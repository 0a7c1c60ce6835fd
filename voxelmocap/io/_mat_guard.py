"""MATLAB ``.mat`` sizes checked before SciPy allocates them.

A ``.mat`` file declares the byte count of every variable and the dimensions of every array, and
SciPy's reader allocates what is declared: a 1.5 MB zlib stream of zeros can declare 1.46 GB of
markers (9.7 GB resident before the reader failed), and a cell array can declare a billion
elements in a few bytes (an object array of 8 GB). :func:`check_mat_sizes` walks the file's
element tags first, without building any array:

* MAT v5: every top-level variable's declared size must fit in the file (uncompressed) or in
  :data:`MAX_MAT_BYTES` once inflated (``miCOMPRESSED``, inflated in bounded pieces, the first
  piece telling the declared size); inside each matrix, recursively, the number of elements of a
  cell, struct or numeric array must fit in the bytes the matrix holds (at least one byte per
  number, eight per cell or field);
* MAT v4: rows × columns × element size must fit in the file.

Anything it cannot parse is left to SciPy's reader (which refuses it); it only refuses what
would make SciPy allocate more than the file can hold.
"""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

from ..errors import InputError

__all__ = ["MAX_MAT_BYTES", "check_mat_sizes"]

#: Most bytes a variable may take once inflated (HumanEva's trials are a few MB).
MAX_MAT_BYTES = 256 << 20

_MI_INT8, _MI_INT32, _MI_UINT32, _MI_MATRIX, _MI_COMPRESSED = 1, 5, 6, 14, 15
_CELL, _STRUCT, _OBJECT, _SPARSE = 1, 2, 3, 5
_DEPTH = 64


class _Stop(Exception):
    """Not a layout this walker knows: leave the file to SciPy."""


def _tag(data: bytes, pos: int, endian: str) -> tuple[int, int, int, int]:
    """``(type, nbytes, start of data, start of the next element)`` of the element at ``pos``."""
    if pos + 8 > len(data):
        raise _Stop
    first, second = struct.unpack(endian + "II", data[pos:pos + 8])
    if first >> 16:  # small data element: type and size packed in 4 bytes, data in the next 4
        return first & 0xFFFF, first >> 16, pos + 4, pos + 8
    end = pos + 8 + second
    if second != 0 and first != _MI_COMPRESSED:
        end += (-second) % 8
    return first, second, pos + 8, end


def _matrix(path, data: bytes, start: int, stop: int, endian: str, depth: int) -> None:
    """Check one miMATRIX's contents ``data[start:stop]`` (module docstring)."""
    if depth > _DEPTH:
        raise InputError(path, f"arrays nested more than {_DEPTH} deep")
    if start == stop:  # an empty matrix
        return
    held = stop - start
    kind, n, body, pos = _tag(data, start, endian)  # array flags
    if kind != _MI_UINT32 or n < 8:
        raise _Stop
    flags = struct.unpack(endian + "I", data[body:body + 4])[0]
    klass = flags & 0xFF
    kind, n, body, pos = _tag(data, pos, endian)  # dimensions
    if kind != _MI_INT32 or n % 4 or n == 0:
        raise _Stop
    dims = struct.unpack(endian + f"{n // 4}i", data[body:body + n])
    count = 1
    for d in dims:
        if d < 0:
            raise InputError(path, f"an array declares a negative dimension {d}")
        count *= d
    per = 8 if klass in (_CELL, _STRUCT, _OBJECT) else 1
    if klass != _SPARSE and count * per > held:
        raise InputError(path, f"an array declares {'x'.join(map(str, dims))} elements in "
                               f"{held} bytes: damaged or forged")
    kind, n, body, pos = _tag(data, pos, endian)  # name
    if klass == _CELL:
        for _ in range(count):
            kind, n, body, pos = _tag(data, pos, endian)
            if kind != _MI_MATRIX or pos > stop:
                raise _Stop
            _matrix(path, data, body, body + n, endian, depth + 1)
    elif klass in (_STRUCT, _OBJECT):
        if klass == _OBJECT:
            kind, n, body, pos = _tag(data, pos, endian)  # class name
        kind, n, body, pos = _tag(data, pos, endian)  # field name length
        if kind != _MI_INT32:
            raise _Stop
        width = struct.unpack(endian + "i", data[body:body + 4])[0]
        kind, n, body, pos = _tag(data, pos, endian)  # field names
        fields = n // width if width > 0 else 0
        if count * fields * 8 > held:
            raise InputError(path, f"a struct array declares {count} x {fields} fields in {held} "
                                   "bytes: damaged or forged")
        for _ in range(count * fields):
            kind, n, body, pos = _tag(data, pos, endian)
            if kind != _MI_MATRIX or pos > stop:
                raise _Stop
            _matrix(path, data, body, body + n, endian, depth + 1)


def _inflate(path, stream: bytes) -> bytes:
    """A compressed variable, inflated in pieces; refused once past :data:`MAX_MAT_BYTES`."""
    inflater = zlib.decompressobj()
    try:
        head = inflater.decompress(stream, 8)
        if len(head) == 8:
            declared = struct.unpack("<II", head)[1]  # refused on its word, before inflating
            if declared > MAX_MAT_BYTES:
                raise InputError(path, f"a compressed variable declares {declared / 1e6:.0f} MB "
                                       f"(at most {MAX_MAT_BYTES / 1e6:.0f} MB are read)")
        pieces, total = [head], len(head)
        rest = inflater.unconsumed_tail
        # past the stream's end zlib keeps trailing bytes as a tail no call consumes: stop there
        while rest and not inflater.eof:
            piece = inflater.decompress(rest, 1 << 20)
            total += len(piece)
            if total > MAX_MAT_BYTES + 16:
                raise InputError(path, f"a compressed variable inflates to more than "
                                       f"{MAX_MAT_BYTES / 1e6:.0f} MB")
            pieces.append(piece)
            rest = inflater.unconsumed_tail
        return b"".join(pieces)
    except zlib.error:
        raise _Stop from None


def check_mat_sizes(path) -> None:
    """Refuse a ``.mat`` file that declares more than it holds (module docstring).

    Raises
    ------
    InputError
        Naming the file: a declared size larger than the file (or than :data:`MAX_MAT_BYTES`
        inflated), or array dimensions the bytes cannot hold.
    """
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError:
        return  # SciPy's reader says why
    try:
        if len(data) >= 128 and data[124:126] in (b"\x00\x01", b"\x01\x00") \
                and data[126:128] in (b"IM", b"MI"):
            _check_v5(path, data, "<" if data[126:128] == b"IM" else ">")
        else:
            _check_v4(path, data)
    except InputError:
        raise
    except (_Stop, struct.error, IndexError, ValueError, OverflowError, RecursionError):
        return  # not a layout walked here: SciPy's reader refuses it


def _check_v5(path, data: bytes, endian: str) -> None:
    pos = 128
    while pos < len(data):
        kind, n, body, end = _tag(data, pos, endian)
        if kind == _MI_COMPRESSED:
            inner = _inflate(path, data[body:body + n])
            ikind, m, ibody, _ = _tag(inner, 0, "<" if endian == "<" else ">")
            if ikind == _MI_MATRIX:
                _matrix(path, inner, ibody, min(ibody + m, len(inner)), endian, 0)
        elif kind == _MI_MATRIX:
            if body + n > len(data):
                raise InputError(path, f"a variable declares {n} bytes but the file holds "
                                       f"{len(data) - body} after it")
            _matrix(path, data, body, body + n, endian, 0)
        pos = end


def _check_v4(path, data: bytes) -> None:
    if len(data) < 20:
        raise _Stop
    for endian in ("<", ">"):
        mopt, rows, cols, imag, namlen = struct.unpack(endian + "5i", data[:20])
        if 0 <= mopt < 5000 and rows >= 0 and cols >= 0 and imag in (0, 1) and 0 < namlen < 256:
            size = {0: 8, 1: 4, 2: 4, 3: 2, 4: 2, 5: 1}.get((mopt // 10) % 10, 8)
            if rows * cols * size * (1 + imag) > len(data):
                raise InputError(path, f"a MAT v4 variable declares {rows}x{cols} values, more "
                                       "than the file holds")
            return
