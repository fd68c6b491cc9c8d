"""Display crops of a study: cut once, padded to a shared square, resized to display size.

Boxes are cut with :func:`nvrq.crops.cut_box` (inclusive pixel indices, docs/FORMATS.md §3)
and padded with :func:`nvrq.crops.pad_to_square`, the scorer's own functions. Images stay BGR
uint8 from ``cv2.imread`` to ``cv2.imwrite`` (both use BGR), so colours are saved unchanged.

Both crops of an item are centred on black squares of the *same* side (the largest side of
the two crops), then resized to ``size`` x ``size``; so the object keeps its relative scale
and both images appear equally large on screen.

>>> import numpy as np
>>> a = np.full((10, 20, 3), 255, np.uint8); b = np.full((4, 4, 3), 255, np.uint8)
>>> pa, pb = pad_pair(a, b, size=40)
>>> pa.shape, pb.shape                 # common square of side 20 -> 40
((40, 40, 3), (40, 40, 3))
>>> int(pa[0, 20, 0]), int(pa[20, 20, 0])   # rows 0..9 of 40 are padding (black)
(0, 255)
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from data_schema.errors import InputError
from data_schema.tables import inside_scene
from nvrq.crops import pad_to_square

__all__ = ["pad_pair", "pad_group", "broken_render", "read_bgr", "write_image", "opaque_ids",
           "ImageCache"]


def read_bgr(path: Path, *, where: str, field: str) -> np.ndarray:
    """Read a colour image as BGR uint8 (H, W, 3); InputError naming ``where``/``field``."""
    if not Path(path).is_file():  # checked first: OpenCV would print a [ WARN ] line
        raise InputError(where, field, "an existing image file", f"{path} (not found)")
    img = cv2.imread(str(path), cv2.IMREAD_COLOR)
    if img is None:
        raise InputError(where, field, "a readable image file", str(path))
    return img


def pad_pair(ref: np.ndarray, ren: np.ndarray, *, size: int) -> tuple[np.ndarray, np.ndarray]:
    """Both crops on a common black square, resized to (size, size, 3) each."""
    a, b = pad_group((ref, ren), size=size)
    return a, b


def pad_group(crops, *, size: int) -> list[np.ndarray]:
    """Every crop (h_i, w_i, 3) centred on one black square (the largest side of all of
    them, so all keep one scale), resized to (size, size, 3): area averaging when shrinking,
    bicubic when enlarging."""
    side = max(max(c.shape[:2]) for c in crops)
    interp = cv2.INTER_AREA if side > size else cv2.INTER_CUBIC
    return [cv2.resize(pad_to_square(c, side=side), (size, size), interpolation=interp)
            for c in crops]


def broken_render(crop: np.ndarray, *, rng: np.random.Generator) -> np.ndarray:
    """A severely broken copy of ``crop`` (h, w, 3) uint8 for a gold "bad" item.

    Heavy Gaussian blur (sigma = 15% of the longer side), Gaussian noise (sigma 40 grey
    levels) and three black holes of a quarter of the side each.
    """
    h, w = crop.shape[:2]
    sigma = max(2.0, 0.15 * max(h, w))
    out = cv2.GaussianBlur(crop, (0, 0), sigmaX=sigma, sigmaY=sigma).astype(np.float32)
    out += rng.normal(0.0, 40.0, size=out.shape).astype(np.float32)
    out = np.clip(out, 0, 255).astype(np.uint8)
    hh, hw = max(1, h // 4), max(1, w // 4)
    for _ in range(3):
        y, x = int(rng.integers(0, h - hh + 1)), int(rng.integers(0, w - hw + 1))
        out[y:y + hh, x:x + hw] = 0
    return out


def write_image(path: Path, img: np.ndarray, *, fmt: str) -> None:
    """Write a BGR uint8 image as ``fmt`` in {'jpg', 'png'} (JPEG quality 95)."""
    params = [cv2.IMWRITE_JPEG_QUALITY, 95] if fmt == "jpg" else [cv2.IMWRITE_PNG_COMPRESSION, 3]
    ok, buf = cv2.imencode("." + fmt, img, params)
    if not ok:
        raise OSError(f"could not encode {path}")
    path.write_bytes(buf.tobytes())


def opaque_ids(rng: np.random.Generator, n: int) -> list[str]:
    """``n`` distinct 16-hex-digit crop file names (seeded, so a rebuild names crops the same).

    Parameters
    ----------
    rng : numpy.random.Generator
        The study's generator (8 bytes drawn per id).
    n : int
        How many.

    Returns
    -------
    list of str
    """
    ids: list[str] = []
    seen: set[str] = set()
    while len(ids) < n:
        s = rng.bytes(8).hex()
        if s not in seen:
            seen.add(s)
            ids.append(s)
    return ids


class ImageCache:
    """Images of a pairs table read once each (the last 64 kept), their paths checked by the
    scene-folder rule of :func:`data_schema.tables.inside_scene`.

    ``image(r, column)`` is the BGR image (:func:`read_bgr`) in ``column`` (``gt_path`` or
    ``render_path``) of the pairs record ``r`` (with the ``_root`` scene folder and ``_row``
    line columns of :func:`annotate.study.build_study`'s table); errors name ``where``.
    """

    def __init__(self, where: str):
        self.where, self.cache = where, {}

    def path(self, r, column: str) -> str:
        """The checked path of the image in ``column`` of pairs row ``r``."""
        field = f"line {int(r['_row'])}: column {column!r}"
        return inside_scene(r["_root"], r[column], where=self.where, field=field)

    def __call__(self, r, column: str) -> np.ndarray:
        field = f"line {int(r['_row'])}: column {column!r}"
        path = self.path(r, column)
        if path not in self.cache:
            if len(self.cache) > 64:
                self.cache.clear()
            self.cache[path] = read_bgr(Path(path), where=self.where, field=field)
        return self.cache[path]
