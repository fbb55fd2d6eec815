"""Pictures a person gives hila (a photo as a scene, an uploaded sheet), read safely.

A small file can decode to a huge image (a 48 kB PNG of 20000 x 20000 pixels takes 1.2 GB), so
the size is read from the file's header and checked against :data:`MAX_PIXELS` BEFORE anything
is decoded (issue 32).  PNG, JPEG, BMP, PPM/PGM and TIFF are taken: each says its size in its
header; anything else is refused without being decoded.

- :func:`image_size`    (width, height) from the header, without decoding
- :func:`decode_image`  the BGR image, refused by its header when too large or not a picture
- :func:`read_picture`  a picture file, read within the file limits and decoded as above
"""

from __future__ import annotations

import struct

import numpy as np

from .errors import InputError
from .fileio import read_bytes

#: the most pixels a picture may have: a 48-megapixel phone photo fits (8000 x 6000);
#: decoding it takes 3 bytes a pixel, 150 MB
MAX_PIXELS = 50_000_000

_PNG = b"\x89PNG\r\n\x1a\n"
#: JPEG start-of-frame markers (baseline, progressive, lossless, ...): not DHT (C4), JPG (C8), DAC (CC)
_SOF = {0xC0, 0xC1, 0xC2, 0xC3, 0xC5, 0xC6, 0xC7, 0xC9, 0xCA, 0xCB, 0xCD, 0xCE, 0xCF}


def _jpeg_size(data: bytes) -> tuple[int, int] | None:
    i = 2
    while i + 4 <= len(data):
        if data[i] != 0xFF:
            return None
        marker = data[i + 1]
        if marker == 0xFF:  # fill byte
            i += 1
            continue
        if marker in (0xD8, 0x01) or 0xD0 <= marker <= 0xD7:  # no length
            i += 2
            continue
        (length,) = struct.unpack(">H", data[i + 2:i + 4])
        if marker in _SOF:
            if i + 9 > len(data):
                return None
            height, width = struct.unpack(">HH", data[i + 5:i + 9])
            return width, height
        i += 2 + length
    return None


def _tiff_size(data: bytes) -> tuple[int, int] | None:
    order = "<" if data[:2] == b"II" else ">"
    (ifd,) = struct.unpack(order + "I", data[4:8])
    if ifd + 2 > len(data):
        return None
    (count,) = struct.unpack(order + "H", data[ifd:ifd + 2])
    found = {}
    for k in range(count):
        entry = data[ifd + 2 + 12 * k:ifd + 14 + 12 * k]
        if len(entry) < 12:
            return None
        tag, kind = struct.unpack(order + "HH", entry[:4])
        if tag in (256, 257):  # ImageWidth, ImageLength: SHORT (3) or LONG (4)
            found[tag] = struct.unpack(order + ("H" if kind == 3 else "I"), entry[8:10] if kind == 3 else entry[8:12])[0]
    return (found[256], found[257]) if len(found) == 2 else None


def _ppm_size(data: bytes) -> tuple[int, int] | None:
    words: list[bytes] = []
    for line in data[:256].split(b"\n"):
        words += line.split(b"#")[0].split()
        if len(words) >= 3:
            break
    return (int(words[1]), int(words[2])) if len(words) >= 3 and words[1].isdigit() and words[2].isdigit() else None


def image_size(data: bytes) -> tuple[int, int] | None:
    """``(width, height)`` read from a PNG, JPEG, BMP, PPM/PGM or TIFF header, or None when
    ``data`` is none of them (or its header is cut short)."""
    if data[:8] == _PNG and len(data) >= 24 and data[12:16] == b"IHDR":
        return struct.unpack(">II", data[16:24])
    if data[:2] == b"\xff\xd8":
        return _jpeg_size(data)
    if data[:2] == b"BM" and len(data) >= 26:
        width, height = struct.unpack("<ii", data[18:26])
        return abs(width), abs(height)  # a negative height: rows stored top-down
    if data[:2] in (b"P5", b"P6"):
        return _ppm_size(data)
    if data[:4] in (b"II*\x00", b"MM\x00*") and len(data) >= 8:
        return _tiff_size(data)
    return None


def decode_image(data: bytes, what: str = "picture", max_pixels: int = MAX_PIXELS) -> np.ndarray:
    """The BGR image in ``data`` (PNG or JPEG), its size checked by the header before decoding.

    Raises
    ------
    InputError
        Not a PNG or JPEG, a header that does not match the pixels, or more than ``max_pixels``.
    """
    # lazy: loads cv2, which importing this module does not
    import cv2

    size = image_size(data)
    if size is None:
        raise InputError(f"unreadable {what}: not a PNG, JPEG, BMP, PPM or TIFF picture (or one cut short)")
    width, height = size
    if width * height > max_pixels:
        raise InputError(f"{what} too large: {width} x {height} pixels, more than the {max_pixels:,} hila reads",
                         hint="scale the picture down (a few megapixels is plenty for a scene)")
    image = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)
    if image is None or sorted(image.shape[:2]) != sorted((height, width)):  # EXIF may turn a JPEG
        raise InputError(f"unreadable {what}: damaged (its header says {width} x {height} pixels; it does not "
                         "decode to that)")
    return image


def read_picture(path, what: str = "picture", max_pixels: int = MAX_PIXELS) -> np.ndarray:
    """The BGR image in the file ``path`` (:func:`decode_image`), the file read within
    :func:`~hila_lang.core.fileio.read_bytes`'s limits; errors name the file."""
    try:
        return decode_image(read_bytes(path, what), what, max_pixels)
    except InputError as exc:
        exc.file = exc.file or str(path)
        raise
