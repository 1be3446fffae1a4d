"""Reading an image file, with a truncated or corrupt PNG or JPEG found before it is decoded.

libpng and libjpeg report a damaged file on the process's stderr from C code ("libpng error:
Read Error", "Premature end of JPEG file"), a line the CLI cannot keep out of its one-line
errors, and libjpeg then returns the damaged image as if it were whole. So the bytes are checked
first: a PNG chunk by chunk (length, CRC, an ``IEND`` chunk at the end), a JPEG for its
start-of-image and end-of-image markers. A file that passes is decoded from the same bytes
(read once). Damage inside a JPEG's entropy-coded data, with both markers intact, is not found
here (only decoding finds it).
"""

from __future__ import annotations

import zlib
from pathlib import Path

import numpy as np

from omnislam._optional import require
from omnislam.errors import DataError

__all__ = ["damage", "png_size", "read_image"]

_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
_JPEG_START = b"\xff\xd8"
_JPEG_END = b"\xff\xd9"


def _png_damage(data: bytes) -> str | None:
    """Why a PNG file (starting with the signature) is damaged, or None when it is whole."""
    view = memoryview(data)
    at = len(_PNG_SIGNATURE)
    while at + 8 <= len(data):
        length = int.from_bytes(view[at : at + 4], "big")
        kind = bytes(view[at + 4 : at + 8])
        end = at + 12 + length
        if end > len(data):
            break
        if zlib.crc32(view[at + 4 : end - 4]) != int.from_bytes(view[end - 4 : end], "big"):
            name = kind.decode("latin-1")
            return f"corrupt PNG: CRC error in the {name!r} chunk at byte {at}"
        if kind == b"IEND":
            return None
        at = end
    return f"truncated PNG: the file ends at byte {len(data)} before its IEND chunk"


def damage(data: bytes) -> str | None:
    """Why the bytes of a PNG or JPEG file are truncated or corrupt, or None.

    Other formats (and bytes that are no image at all) return None: decoding decides.
    """
    if data.startswith(_PNG_SIGNATURE):
        return _png_damage(data)
    if data.startswith(_JPEG_START) and not data.rstrip(b"\x00").endswith(_JPEG_END):
        return f"truncated JPEG: no end-of-image marker (FF D9) in its {len(data)} bytes"
    return None


def png_size(path: str | Path) -> tuple[int, int]:
    """``(width, height)`` of a PNG file from its header, after checking the whole file
    (:func:`damage`) without decoding it: every image of a folder can be checked at load time.

    Raises:
        DataError: naming the file: unreadable, not a PNG, truncated or corrupt.
    """
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise DataError(f"cannot read image: {exc.strerror or exc}", path) from None
    if not data.startswith(_PNG_SIGNATURE) or data[12:16] != b"IHDR":
        raise DataError("not a PNG file", path)
    problem = _png_damage(data)
    if problem is not None:
        raise DataError(problem, path)
    return int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")


def read_image(path: str | Path, grey: bool = False) -> np.ndarray:
    """Read an image file as OpenCV does, without libpng's or libjpeg's lines on stderr.

    Args:
        path: the image file.
        grey: return one channel instead of three.

    Returns:
        ``(H, W)`` uint8 when ``grey``, else ``(H, W, 3)`` uint8 in OpenCV's BGR order.

    Raises:
        DataError: naming the file: unreadable, a truncated or corrupt PNG or JPEG
            (:func:`damage`), or bytes OpenCV cannot decode.
    """
    cv2 = require("cv2")
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise DataError(f"cannot read image: {exc.strerror or exc}", path) from None
    problem = damage(data)
    if problem is not None:
        raise DataError(problem, path)
    flags = cv2.IMREAD_GRAYSCALE if grey else cv2.IMREAD_COLOR
    image = cv2.imdecode(np.frombuffer(data, np.uint8), flags) if data else None
    if image is None:
        raise DataError("cannot read image: not an image file OpenCV can decode", path)
    return image
