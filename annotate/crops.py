"""Display crops of a study: cut once, padded to a shared square, resized to display size.

Layer: annotate (rating study).

Boxes are cut with :func:`nvrq.crops.cut_box` (inclusive pixel indices, docs/FORMATS.md §3)
and padded with :func:`nvrq.crops.pad_to_square`, the scorer's own functions. Images stay BGR
uint8 from ``cv2.imread`` to ``cv2.imwrite`` (both use BGR), so colours are saved unchanged.

Both crops of an item are centred on black squares of the *same* side (the largest side of
the two crops), then resized to ``size`` x ``size``; so the object keeps its relative scale
and both images appear equally large on screen.

Gold and repeats must not be told from real items by their files (docs/FORMATS.md §8,
"served crops"). :class:`CropWriter` writes every crop of a study: each one dithered
(:func:`dither`: a random sixteenth of its colour values moved by one grey level), no two
files alike in their bytes; a gold item's made-up crop (the GT copy, the broken render) is
matched in file size to a ren/ref size ratio drawn from the study's real items
(:meth:`CropWriter.matched`). A gold copy and a repeat are cut with their boxes moved by a
few pixels (:func:`draw_shift`, :func:`shift_box`), so their pixels match no other crop.

>>> import numpy as np
>>> a = np.full((10, 20, 3), 255, np.uint8); b = np.full((4, 4, 3), 255, np.uint8)
>>> pa, pb = pad_pair(a, b, size=40)
>>> pa.shape, pb.shape                 # common square of side 20 -> 40
((40, 40, 3), (40, 40, 3))
>>> int(pa[0, 20, 0]), int(pa[20, 20, 0])   # rows 0..9 of 40 are padding (black)
(0, 255)
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np

from data_schema.errors import InputError
from data_schema.images import check_image
from data_schema.tables import inside_scene
from nvrq.crops import pad_to_square

__all__ = ["pad_pair", "pad_group", "broken_render", "read_bgr", "write_image", "opaque_ids",
           "ImageCache", "dither", "encode", "draw_shift", "shift_box", "soften", "CropWriter",
           "DITHER_SHARE", "JPEG_QUALITIES", "MAX_SHIFT", "MAX_GOLD_BLUR", "MAX_BAD_NOISE"]

#: JPEG qualities a written crop is encoded with (one drawn per crop; the quantisation
#: tables then differ between crops, the look does not)
JPEG_QUALITIES = (93, 94, 95, 96)
#: share of a written crop's colour values moved by one grey level (:func:`dither`)
DITHER_SHARE = 1 / 16
#: largest move of a gold copy's or a repeat's box, as a share of the box's longer side
MAX_SHIFT = 0.08
#: largest Gaussian blur (sigma, display pixels) of a gold copy when matching a file size
MAX_GOLD_BLUR = 1.5
#: largest noise (sigma, grey levels) of a broken render when matching a file size
MAX_BAD_NOISE = 80.0


def read_bgr(path: Path, *, where: str, field: str) -> np.ndarray:
    """Read a colour image as BGR uint8 (H, W, 3); InputError naming ``where``/``field``.

    Parameters
    ----------
    path : Path
        The image file (any format OpenCV reads, decoded to colour).
    where : str
        The table whose row names the image, for the error message.
    field : str
        The field named in errors (e.g. ``'row 3: gt_path'``).

    Returns
    -------
    (H, W, 3) uint8
        BGR.
    """
    if not Path(path).is_file():  # checked first: OpenCV would print a [ WARN ] line
        raise InputError(where, field, "an existing image file", f"{path} (not found)")
    try:  # the header before any decode (a decompression bomb, a file cut short)
        check_image(path)
    except InputError as exc:
        raise InputError(where, field, exc.expected, f"{path}: {exc.got}") from None
    img = cv2.imread(str(path), cv2.IMREAD_COLOR)
    if img is None:
        raise InputError(where, field, "a readable image file", str(path))
    return img


def pad_pair(ref: np.ndarray, ren: np.ndarray, *, size: int) -> tuple[np.ndarray, np.ndarray]:
    """Both crops on a common black square, resized to (size, size, 3) each.

    Parameters
    ----------
    ref, ren : (h, w, 3) uint8
        Reference and render crops, BGR.
    size : int
        Display side, pixels.

    Returns
    -------
    ref, ren : (size, size, 3) uint8
    """
    a, b = pad_group((ref, ren), size=size)
    return a, b


def pad_group(crops, *, size: int) -> list[np.ndarray]:
    """Every crop (h_i, w_i, 3) centred on one black square (the largest side of all of
    them, so all keep one scale), resized to (size, size, 3): area averaging when shrinking,
    bicubic when enlarging.

    Parameters
    ----------
    crops : sequence of (h_i, w_i, 3) uint8
        Crops, BGR.
    size : int
        Display side, pixels.

    Returns
    -------
    list of (size, size, 3) uint8
    """
    side = max(max(c.shape[:2]) for c in crops)
    interp = cv2.INTER_AREA if side > size else cv2.INTER_CUBIC
    return [cv2.resize(pad_to_square(c, side=side), (size, size), interpolation=interp)
            for c in crops]


def broken_render(crop: np.ndarray, *, rng: np.random.Generator, noise: float = 40.0) -> np.ndarray:
    """A severely broken copy of ``crop`` (h, w, 3) uint8 for a gold "bad" item.

    Three black holes of a quarter of the side each, then a heavy Gaussian blur (sigma = 15%
    of the longer side: the holes become dark smears) and Gaussian noise (sigma ``noise`` grey
    levels; :meth:`CropWriter.matched` chooses it to match a real render's file size).

    Parameters
    ----------
    crop : (h, w, 3) uint8
        The crop, BGR.
    rng : numpy.random.Generator
        Source of the holes and the noise.
    noise : float, optional
        Standard deviation of the noise, grey levels.

    Returns
    -------
    (h, w, 3) uint8
    """
    h, w = crop.shape[:2]
    out = crop.copy()
    hh, hw = max(1, h // 4), max(1, w // 4)
    for _ in range(3):
        y, x = int(rng.integers(0, h - hh + 1)), int(rng.integers(0, w - hw + 1))
        out[y:y + hh, x:x + hw] = 0
    sigma = max(2.0, 0.15 * max(h, w))
    out = cv2.GaussianBlur(out, (0, 0), sigmaX=sigma, sigmaY=sigma).astype(np.float32)
    out += rng.normal(0.0, 1.0, size=out.shape).astype(np.float32) * np.float32(noise)
    return np.clip(out, 0, 255).astype(np.uint8)


def encode(img: np.ndarray, *, fmt: str, quality: int = 95) -> bytes:
    """A BGR uint8 image encoded as ``fmt`` in {'jpg', 'png'} (JPEG: ``quality``).

    Parameters
    ----------
    img : (H, W, 3) uint8
        BGR image.
    fmt : str
        ``{'jpg', 'png'}``.
    quality : int, optional
        JPEG quality, 0-100.

    Returns
    -------
    bytes
        The file's content.
    """
    params = [cv2.IMWRITE_JPEG_QUALITY, int(quality)] if fmt == "jpg" else [cv2.IMWRITE_PNG_COMPRESSION, 3]
    ok, buf = cv2.imencode("." + fmt, img, params)
    if not ok:
        raise OSError(f"could not encode a {img.shape} image as {fmt}")
    return buf.tobytes()


def write_image(path: Path, img: np.ndarray, *, fmt: str, quality: int = 95) -> bytes:
    """Write a BGR uint8 image as ``fmt`` in {'jpg', 'png'} (:func:`encode`); the bytes.

    Parameters
    ----------
    path : Path
        The file to write (replaced when it exists); its suffix is not checked against ``fmt``.
    img : (H, W, 3) uint8
        BGR image.
    fmt : str
        The encoding, ``'jpg'`` or ``'png'``.
    quality : int, optional
        JPEG quality 0-100, passed to :func:`encode`.

    Returns
    -------
    bytes
        The bytes written.
    """
    data = encode(img, fmt=fmt, quality=quality)
    path.write_bytes(data)
    return data


def dither(img: np.ndarray, *, rng: np.random.Generator, share: float = DITHER_SHARE) -> np.ndarray:
    """A copy of ``img`` (uint8, any shape) with a random ``share`` (in steps of 1/128) of its
    values moved one grey level up or down (clipped to 0..255): invisible, but no two dithered
    copies of one image are alike.

    Parameters
    ----------
    img : uint8 array, any shape
        The image.
    rng : numpy.random.Generator
        Chooses the values moved and their direction.
    share : float, optional
        Fraction of values moved, in [0, 1].

    Returns
    -------
    uint8 array
        Same shape as ``img``.

    >>> img = np.full((32, 32, 3), 100, np.uint8)
    >>> d = dither(img, rng=np.random.default_rng(0))
    >>> int(np.abs(d.astype(int) - img).max()), 0.03 < float(np.mean(d != img)) < 0.1
    (1, True)
    """
    n = np.uint8(round(share * 128))  # one random byte per value: < n down, n..2n-1 up
    r = np.frombuffer(rng.bytes(img.size), np.uint8).reshape(img.shape)
    up, down = ((r - n) < n).view(np.uint8), (r < n).view(np.uint8)
    return cv2.subtract(cv2.add(img, up), down)  # saturating: 0 and 255 stay in range


def draw_shift(rng: np.random.Generator, box) -> tuple[int, int]:
    """A random move ``(dx, dy)`` in pixels, not both 0, each at most :data:`MAX_SHIFT` of the
    inclusive box ``[x0, y0, x1, y1]``'s longer side (at least 1 pixel).

    Parameters
    ----------
    rng : numpy.random.Generator
        Source of the move.
    box : (4,) int
        ``[x0, y0, x1, y1]``, inclusive pixels.

    Returns
    -------
    (int, int)
        ``(dx, dy)`` in pixels.

    >>> dx, dy = draw_shift(np.random.default_rng(0), [0, 0, 99, 49])
    >>> max(abs(dx), abs(dy)) <= 8 and (dx, dy) != (0, 0)
    True
    """
    x0, y0, x1, y1 = (int(v) for v in box)
    m = max(1, int(round(MAX_SHIFT * max(x1 - x0 + 1, y1 - y0 + 1))))
    while True:
        dx, dy = (int(v) for v in rng.integers(-m, m + 1, size=2))
        if dx or dy:
            return dx, dy


def shift_box(box, shift: tuple[int, int], shape) -> list[int]:
    """The inclusive box ``[x0, y0, x1, y1]`` moved by ``shift = (dx, dy)``, each part cut
    back so that the box stays inside an image of ``shape`` (H, W, ...); its size is kept.

    Parameters
    ----------
    box : (4,) int
        ``[x0, y0, x1, y1]``, inclusive pixels.
    shift : (int, int)
        ``(dx, dy)`` in pixels.
    shape : tuple
        Image shape ``(H, W, ...)``.

    Returns
    -------
    list of int
        The moved box, inclusive pixels.

    >>> shift_box([2, 2, 5, 5], (3, -4), (8, 10))
    [5, 0, 8, 3]
    """
    x0, y0, x1, y1 = (int(v) for v in box)
    h, w = shape[:2]
    dx = int(np.clip(shift[0], -x0, max(-x0, w - 1 - x1)))
    dy = int(np.clip(shift[1], -y0, max(-y0, h - 1 - y1)))
    return [x0 + dx, y0 + dy, x1 + dx, y1 + dy]


def soften(crop: np.ndarray, sigma_display: float, *, side: int, size: int) -> np.ndarray:
    """``crop`` blurred by ``sigma_display`` pixels of the ``size`` x ``size`` display (its
    square of ``side`` camera pixels is resized to it); 0 returns it unchanged.

    Parameters
    ----------
    crop : (h, w, 3) uint8
        The crop, BGR.
    sigma_display : float, display pixels
        Blur standard deviation as seen on the display.
    side : int, pixels
        Side of the padded square the crop sits on, camera pixels.
    size : int, pixels
        Display side.

    Returns
    -------
    (h, w, 3) uint8
    """
    if sigma_display <= 0:
        return crop
    sigma = sigma_display * side / size
    return cv2.GaussianBlur(crop, (0, 0), sigmaX=sigma, sigmaY=sigma)


class CropWriter:
    """Writes the display crops of a study into the new ``folder`` as ``fmt`` (module
    docstring).

    Every crop is :func:`dither`-ed with ``rng`` (the study's generator, so a rebuild with
    the same seed writes the same bytes), encoded (JPEG: with a quality drawn from
    :data:`JPEG_QUALITIES`) and written only if no crop of the study has the same bytes
    (else dithered again). :meth:`note_real` records the render/reference file size ratio of
    a real item; :meth:`matched` picks a gold item's made-up crop (and JPEG quality) whose
    file is as large as one of those ratios says. ``groups`` (``{name: count}``, e.g. the
    number of good and of bad gold items) spreads the ratios of each group's items over the
    real ones: the i-th item of a group of n takes a ratio at a random quantile within one
    of n equal strata, each stratum once, in a random order (Latin hypercube sampling), so a
    handful of gold items follows the real items' size distribution closely.

    Parameters
    ----------
    folder : Path
        The new crops folder.
    fmt : str
        ``{'jpg', 'png'}``.
    rng : numpy.random.Generator
        The study's generator.
    groups : dict, optional
        ``{name: count}`` of gold item groups.
    """

    def __init__(self, folder: Path, *, fmt: str, rng: np.random.Generator,
                 groups: dict[str, int] | None = None):
        self.folder, self.fmt, self.rng = Path(folder), fmt, rng
        self.folder.mkdir()
        self.seen: set[bytes] = set()
        self.ratios: list[float] = []
        self.strata = {g: (n, rng.permutation(n).tolist()) for g, n in (groups or {}).items() if n}

    def write(self, name: str, img: np.ndarray, *, quality: int | None = None) -> int:
        """Write ``img`` (BGR uint8) dithered as ``folder/name`` (JPEG: with ``quality``, else
        one drawn from :data:`JPEG_QUALITIES`); its file size in bytes."""
        if quality is None:
            quality = JPEG_QUALITIES[int(self.rng.integers(len(JPEG_QUALITIES)))]
        while True:
            data = write_image(self.folder / name, dither(img, rng=self.rng), fmt=self.fmt,
                               quality=quality)
            digest = hashlib.sha256(data).digest()
            if digest not in self.seen:
                self.seen.add(digest)
                return len(data)

    def note_real(self, ref_bytes: int, ren_bytes: int) -> None:
        """Record a real item's render/reference file size ratio."""
        self.ratios.append(ren_bytes / ref_bytes)

    def target_ratio(self, group: str | None = None) -> float:
        """A render/reference size ratio drawn from the real items noted so far (1 before
        any): at a quantile within the next stratum of ``group`` (class docstring), or at a
        uniform random quantile."""
        u = float(self.rng.random())
        if group in self.strata and self.strata[group][1]:
            n, order = self.strata[group]
            u = (order.pop() + u) / n
        return float(np.quantile(self.ratios, u)) if self.ratios else 1.0

    def matched(self, make: Callable[[float], np.ndarray], ref_bytes: int, *, lo: float,
                hi: float, group: str | None = None, steps: int = 8) -> tuple[np.ndarray, int]:
        """``(make(p), quality)`` for the ``p`` in ``[lo, hi]`` whose dithered file is nearest
        to ``ref_bytes`` times :meth:`target_ratio` (of ``group``), by bisection on ``p`` (the
        file size must change monotonically with it); JPEG: at a quality drawn from
        :data:`JPEG_QUALITIES` as for any crop, or, when that misses the size by more than 5%,
        at the quality that meets it best. Pass the quality on to :meth:`write`."""
        target, seed = self.target_ratio(group) * ref_bytes, int(self.rng.integers(2**63))
        best = None
        first = int(self.rng.integers(len(JPEG_QUALITIES)))  # as drawn for a real crop ...
        for q in (JPEG_QUALITIES[first:] + JPEG_QUALITIES[:first]) if self.fmt == "jpg" else (95,):
            def size(p: float, q=q) -> int:
                img = dither(make(p), rng=np.random.default_rng(seed))
                return len(encode(img, fmt=self.fmt, quality=q))

            p = _bisect(size, target, lo, hi, steps)
            miss = abs(size(p) - target)
            if best is None or miss < best[0]:
                best = (miss, p, q)
            if miss <= 0.05 * target:  # ... unless another quality meets the size better
                break
        return make(best[1]), best[2]


    def gold(self, crops, j: int, ref_bytes: int, *, size: int,
             broken_seed: int | None = None) -> tuple[np.ndarray, int]:
        """The display crop ``j`` of ``crops`` (camera crops (h_i, w_i, 3) shown on one square,
        :func:`pad_group`; ``crops[j]`` a copy cut from the GT image) for a gold item, and its
        JPEG quality (:meth:`matched` against the reference's ``ref_bytes``): blurred by at
        most :data:`MAX_GOLD_BLUR` display pixels (group ``'good'``), or with ``broken_seed``
        :func:`broken_render`-ed with noise up to :data:`MAX_BAD_NOISE` (group ``'bad'``)."""
        side = max(max(c.shape[:2]) for c in crops)

        def make(p: float) -> np.ndarray:
            shown = list(crops)
            shown[j] = (soften(crops[j], p, side=side, size=size) if broken_seed is None else
                        broken_render(crops[j], rng=np.random.default_rng(broken_seed), noise=p))
            return pad_group(shown, size=size)[j]

        if broken_seed is None:
            return self.matched(make, ref_bytes, lo=0.0, hi=MAX_GOLD_BLUR, group="good")
        return self.matched(make, ref_bytes, lo=0.0, hi=MAX_BAD_NOISE, group="bad")


def _bisect(size: Callable[[float], int], target: float, lo: float, hi: float, steps: int) -> float:
    """The ``p`` in ``[lo, hi]`` whose ``size(p)`` (monotonic in ``p``) is nearest ``target``."""
    s_lo, s_hi = size(lo), size(hi)
    rising = s_hi >= s_lo
    if (target <= s_lo) == rising or (target >= s_hi) == rising:  # beyond an end: that end
        return lo if abs(s_lo - target) <= abs(s_hi - target) else hi
    a, b = lo, hi
    for _ in range(steps):
        mid = (a + b) / 2
        if (size(mid) < target) == rising:
            a = mid
        else:
            b = mid
    return (a + b) / 2


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

    Parameters
    ----------
    where : str
        The table named in errors.
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
