"""Image files checked from their bytes, without decoding: size, type, and that they are whole.

A numbered-image folder is a video whose every frame is a file, and any of them may be empty,
truncated, of another size, or declare a size no decoder should allocate (a PNG of 60 000 ×
60 000 pixels is 10 GB decoded; OpenCV refuses it with an assertion). :func:`check_image` reads
one file's bytes and parses its container, so that ``info`` checks every frame of a folder
cheaply (no pixel is decoded) and a frame is refused, naming it, before a decoder sees it:

* PNG: the signature, the ``IHDR`` size, every chunk's length and CRC-32, and the ``IEND`` chunk;
* JPEG: the ``SOI`` marker, the size of the first start-of-frame segment, and the ``EOI`` marker
  at the end (a truncated file lacks it);
* BMP: the ``BM`` signature, the size of the ``BITMAPINFOHEADER`` family, and a file size that
  holds the declared pixel array;
* other formats (TIFF): not empty; their size is taken from the decoded first frame.

>>> import numpy as np, cv2, tempfile, pathlib
>>> path = pathlib.Path(tempfile.mkdtemp()) / "a.png"
>>> _ = cv2.imwrite(str(path), np.zeros((48, 64, 3), np.uint8))
>>> check_image(path)
(64, 48)
"""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

from ..errors import InputError

__all__ = ["MAX_PIXELS", "MAX_SIDE", "check_image"]

#: Largest image side accepted (pixels).
MAX_SIDE = 32768
#: Most pixels an image may have (OpenCV's own default limit is 2**30).
MAX_PIXELS = 1 << 28

_PNG = b"\x89PNG\r\n\x1a\n"


def _size_ok(path, w: int, h: int) -> tuple[int, int]:
    if not (0 < w <= MAX_SIDE and 0 < h <= MAX_SIDE and w * h <= MAX_PIXELS):
        raise InputError(path, f"declares an image of {w}x{h} pixels (at most {MAX_SIDE} a side "
                               f"and {MAX_PIXELS // 1_000_000} megapixels are read)")
    return w, h


def _png(path, data: bytes) -> tuple[int, int]:
    pos, size, ended = 8, None, False
    while pos < len(data):
        if pos + 12 > len(data):
            raise InputError(path, "truncated PNG (a chunk is cut off)")
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        end = pos + 12 + length
        if end > len(data):
            raise InputError(path, f"truncated PNG (chunk {kind!r} needs {length} bytes)")
        body = data[pos + 8:end - 4]
        if zlib.crc32(kind + body) != struct.unpack(">I", data[end - 4:end])[0]:
            raise InputError(path, f"corrupt PNG (chunk {kind!r} fails its CRC)")
        if size is None:
            if kind != b"IHDR" or length != 13:
                raise InputError(path, "corrupt PNG (no IHDR chunk first)")
            size = _size_ok(path, *struct.unpack(">II", body[:8]))
        if kind == b"IEND":
            ended = True
            break
        pos = end
    if size is None or not ended:
        raise InputError(path, "truncated PNG (no IEND chunk)")
    return size


_SOF = {0xC0, 0xC1, 0xC2, 0xC3, 0xC5, 0xC6, 0xC7, 0xC9, 0xCA, 0xCB, 0xCD, 0xCE, 0xCF}


def _jpeg(path, data: bytes) -> tuple[int, int]:
    # FF D9 appears in a JPEG only as an end-of-image marker (entropy-coded FF bytes are
    # followed by 00); some writers pad after it.
    if b"\xff\xd9" not in data[-4096:]:
        raise InputError(path, "truncated JPEG (no end-of-image marker)")
    pos = 2
    while pos + 4 <= len(data):
        if data[pos] != 0xFF:
            raise InputError(path, "corrupt JPEG (a segment does not start with a marker)")
        marker = data[pos + 1]
        if marker == 0xFF:  # fill byte
            pos += 1
            continue
        if marker in (0x01, *range(0xD0, 0xD8)):  # markers without a length
            pos += 2
            continue
        length = struct.unpack(">H", data[pos + 2:pos + 4])[0]
        if marker in _SOF:
            if pos + 9 > len(data):
                break
            h, w = struct.unpack(">HH", data[pos + 5:pos + 9])
            return _size_ok(path, w, h)
        if marker == 0xDA or length < 2:  # start of scan before a frame header
            break
        pos += 2 + length
    raise InputError(path, "corrupt JPEG (no frame header)")


def _bmp(path, data: bytes) -> tuple[int, int]:
    if len(data) < 30:
        raise InputError(path, "truncated BMP header")
    offset, header = struct.unpack("<I", data[10:14])[0], struct.unpack("<I", data[14:18])[0]
    if header < 40 or len(data) < 14 + header:
        raise InputError(path, "unsupported or truncated BMP header")
    w, h, _, bits = struct.unpack("<iiHH", data[18:30])
    w, h = _size_ok(path, w, abs(h))
    compression = struct.unpack("<I", data[30:34])[0]
    if compression == 0 and offset + ((w * bits + 31) // 32) * 4 * h > len(data):
        raise InputError(path, f"truncated BMP (its {w}x{h} pixels need more bytes than the file "
                               "holds)")
    return w, h


def check_image(path) -> tuple[int, int] | None:
    """The ``(W, H)`` an image file declares, checked as the module docstring says.

    Returns None for a format whose header is not parsed here (TIFF).

    Raises
    ------
    InputError
        The file cannot be read, is empty or not a regular file, is truncated or corrupt, or
        declares an image larger than :data:`MAX_SIDE` / :data:`MAX_PIXELS`.
    """
    path = Path(path)
    try:
        if not path.is_file():
            raise InputError(path, "is not a regular file")
        data = path.read_bytes()
    except OSError as exc:
        raise InputError(path, f"cannot read ({exc.strerror or exc.__class__.__name__})") from None
    if not data:
        raise InputError(path, "empty image file")
    if data.startswith(_PNG):
        return _png(path, data)
    if data.startswith(b"\xff\xd8"):
        return _jpeg(path, data)
    if data.startswith(b"BM"):
        return _bmp(path, data)
    if data[:4] in (b"II*\0", b"MM\0*"):
        return None
    raise InputError(path, "not a PNG, JPEG, BMP or TIFF image")
