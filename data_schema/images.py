"""Image files the toolkit did not write: their size read from the header, checked before any decode.

Layer: data_schema (file formats).

A decoder allocates ``width x height x channels`` bytes before it has read a pixel, so a 1 MB
PNG that claims 30000 x 30000 pixels costs 2.7 GB once decoded (a *decompression bomb*). Every
place that decodes a foreign image (scene images and renders through
:func:`nvrq.crops.read_rgb`, ``nvrq import renders``, the rater app's crops, the KITTI and
drivestudio importers) first calls :func:`check_image`, which reads the header only and
refuses (docs/FORMATS.md §7):

- an image of more than :data:`MAX_IMAGE_PIXELS` pixels;
- an image whose size is not the one expected (``size``: its camera's resolution);
- a PNG or JPEG file cut short (a PNG without its ``IEND`` chunk, a JPEG without its
  end-of-image marker ``FF D9``), which decoders accept with grey or missing rows;
- a file that is not an image.

PNG and JPEG headers are parsed here (a PNG's ``IHDR`` chunk, a JPEG's start-of-frame
segment); other formats are identified by Pillow, which reads their header only.

>>> import struct, tempfile, zlib, pathlib
>>> d = pathlib.Path(tempfile.mkdtemp())
>>> ihdr = struct.pack(">IIBBBBB", 30000, 30000, 8, 2, 0, 0, 0)
>>> chunk = lambda t, b: struct.pack(">I", len(b)) + t + b + struct.pack(">I", zlib.crc32(t + b))
>>> _ = (d / "bomb.png").write_bytes(PNG_SIGNATURE + chunk(b"IHDR", ihdr) + chunk(b"IEND", b""))
>>> image_header(d / "bomb.png")
ImageHeader(width=30000, height=30000, format='png')
>>> check_image(d / "bomb.png")  # doctest: +ELLIPSIS
Traceback (most recent call last):
...
data_schema.errors.InputError: .../bomb.png: expected an image of at most 67108864 pixels (docs/FORMATS.md §7), got 30000x30000 = 900000000 pixels (over the limit)
"""

from __future__ import annotations

import os
import struct
from typing import NamedTuple

from data_schema.errors import InputError

__all__ = ["MAX_IMAGE_PIXELS", "PNG_SIGNATURE", "ImageHeader", "image_header", "check_image"]

#: The most pixels a foreign image may have (8192 x 8192; an 8K camera frame has 33 million):
#: its RGB decode takes 192 MiB at most.
MAX_IMAGE_PIXELS = 8192 * 8192

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
_PNG_END = b"IEND\xaeB`\x82"
#: JPEG start-of-frame markers (C4 is a Huffman table, C8 reserved, CC arithmetic conditioning)
_SOF = frozenset({0xC0, 0xC1, 0xC2, 0xC3, 0xC5, 0xC6, 0xC7, 0xC9, 0xCA, 0xCB, 0xCD, 0xCE, 0xCF})
#: bytes of the file's end searched for the end marker (encoders may pad a few bytes after it)
_TAIL = 64


class ImageHeader(NamedTuple):
    """An image file's size as its header states it: ``width``, ``height`` (pixels) and
    ``format`` (``'png'``, ``'jpeg'`` or Pillow's name of another format, lower case)."""

    width: int
    height: int
    format: str


def _tail(f, size: int) -> bytes:
    f.seek(max(0, size - _TAIL))
    return f.read(_TAIL)


def _png(f, head: bytes, size: int) -> tuple[int, int] | str:
    if len(head) < 24 or head[12:16] != b"IHDR":
        return "a PNG file without its IHDR header"
    w, h = struct.unpack(">II", head[16:24])
    if _PNG_END not in _tail(f, size):
        return "a truncated PNG file (no IEND chunk at its end)"
    return w, h


def _jpeg(f, size: int) -> tuple[int, int] | str:
    f.seek(2)
    while True:
        b = f.read(1)
        while b == b"\xff":  # fill bytes before a marker
            b = f.read(1)
        if not b:
            return "a truncated JPEG file (no frame header)"
        marker = b[0]
        if marker == 0x01 or 0xD0 <= marker <= 0xD7:
            continue  # markers without a length
        length = f.read(2)
        if len(length) < 2:
            return "a truncated JPEG file (no frame header)"
        n = struct.unpack(">H", length)[0]
        if marker in _SOF:
            seg = f.read(5)
            if len(seg) < 5:
                return "a truncated JPEG file (no frame header)"
            h, w = struct.unpack(">HH", seg[1:5])
            break
        if marker in (0xD9, 0xDA) or n < 2:
            return "a JPEG file without a frame header"
        f.seek(n - 2, os.SEEK_CUR)
        if f.tell() >= size:
            return "a truncated JPEG file (no frame header)"
    if b"\xff\xd9" not in _tail(f, size):
        return "a truncated JPEG file (no end-of-image marker)"
    return w, h


def _other(path: str) -> tuple[int, int, str] | str:
    import warnings

    from PIL import Image, UnidentifiedImageError

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)
            with Image.open(path) as im:  # the header only
                return im.size[0], im.size[1], (im.format or "unknown").lower()
    except Image.DecompressionBombError:
        return "an image of more pixels than Pillow opens"
    except (UnidentifiedImageError, OSError, ValueError):
        return "an undecodable file"


def image_header(path: str | os.PathLike) -> ImageHeader:
    """The size ``path``'s header states, read without decoding a pixel.

    Parameters
    ----------
    path : str or PathLike
        An image file.

    Returns
    -------
    ImageHeader

    Raises
    ------
    InputError
        No such file, not an image, a PNG or JPEG file cut short (module docstring), or a
        header stating no pixels; ``got`` says which.
    """
    path = os.fspath(path)
    try:
        with open(path, "rb") as f:
            size = os.fstat(f.fileno()).st_size
            head = f.read(32)
            if head.startswith(PNG_SIGNATURE):
                fmt, found = "png", _png(f, head, size)
            elif head.startswith(b"\xff\xd8"):
                fmt, found = "jpeg", _jpeg(f, size)
            else:
                fmt, found = None, None
    except FileNotFoundError:
        raise InputError(path, None, "a readable image file", "no such file") from None
    except (IsADirectoryError, PermissionError) as exc:
        raise InputError(path, None, "a readable image file", exc.strerror) from None
    if fmt is None:
        found = _other(path)
        if not isinstance(found, str):
            w, h, fmt = found
            found = w, h
    if isinstance(found, str):
        raise InputError(path, None, "a readable image file", found)
    w, h = found
    if w <= 0 or h <= 0:
        raise InputError(path, None, "a readable image file", f"a header of {w}x{h} pixels")
    return ImageHeader(int(w), int(h), fmt)


def check_image(path: str | os.PathLike, *, size: tuple[int, int] | None = None,
                max_pixels: int = MAX_IMAGE_PIXELS, of: str = "its camera") -> ImageHeader:
    """``path``'s header (:func:`image_header`) once it is an image of at most ``max_pixels``
    pixels and, with ``size``, of exactly that size: the check before every decode of a
    foreign image (module docstring).

    Parameters
    ----------
    path : str or PathLike
        The image file.
    size : (int, int), optional
        The expected ``(width, height)``, e.g. the camera's resolution.
    max_pixels : int, optional
        The pixel limit (default :data:`MAX_IMAGE_PIXELS`).
    of : str, optional
        Whose size ``size`` is, for the error (``"camera front"``).

    Returns
    -------
    ImageHeader

    Raises
    ------
    InputError
        The file's error (:func:`image_header`), too many pixels or another size; the
        error names the file.
    """
    head = image_header(path)
    w, h = head.width, head.height
    if size is not None and (w, h) != (int(size[0]), int(size[1])):
        raise InputError(os.fspath(path), None, f"an image of {of}'s size {int(size[0])}x{int(size[1])}", f"{w}x{h}")
    if w * h > max_pixels:
        raise InputError(os.fspath(path), None, f"an image of at most {max_pixels} pixels (docs/FORMATS.md §7)",
                         f"{w}x{h} = {w * h} pixels (over the limit)")
    return head
