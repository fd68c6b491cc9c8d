"""The images of the no-reference reference fixtures (``tests/nvrq/metrics/data/nr_reference.json``,
``nr_old_packages.json``): photographs that scikit-image ships, degraded and cropped. They are
regenerated here, never stored; each fixture row keeps the sha256 of its image, so a
regeneration that differs (another codec or filter build) fails on the hash, not on a metric.

Recipe: ``photo`` from :mod:`skimage.data` (uint8 RGB); ``degradation`` of the whole photo --
``clean``; ``blur``: Gaussian, sigma 1.5 px (``scipy.ndimage.gaussian_filter``, nearest
borders), rounded; ``noise``: additive white Gaussian noise, sigma 10 grey levels, NumPy's
PCG64 seeded by the CRC-32 of ``'PHOTO/noise'`` (so every crop of a photo cuts the same noisy
image), rounded and clipped; ``jpeg``: Pillow's JPEG at
quality 20, decoded -- then the crop ``(y0, x0, h, w)`` (none: the whole photo). The crop sizes
sit around the metrics' limits: BRISQUE's 14 px, NIQE's one 96x96 block (96-191 px) and two
blocks.

Used by ``tests/nvrq/metrics/test_no_reference.py`` and ``tests/nvrq/metrics/make_nr_fixtures.py`` (which
runs outside the project, so this module imports only NumPy, SciPy, scikit-image and Pillow).
"""

from __future__ import annotations

import hashlib
import io
import zlib
from functools import lru_cache

import numpy as np

__all__ = ["PHOTOS", "DEGRADATIONS", "CASES", "case_image", "image_sha256"]

PHOTOS = ("astronaut", "chelsea", "coffee", "rocket", "immunohistochemistry")
DEGRADATIONS = ("clean", "blur", "noise", "jpeg")
#: (h, w) of the crops cut from each photo, at the offset ``(37, 41)``
_CROP_SIZES = ((14, 14), (14, 33), (21, 18), (30, 47), (57, 80), (96, 96), (96, 121), (100, 200),
               (150, 170), (192, 260))
_OFFSET = (37, 41)


def _cases() -> list[dict]:
    cases = [{"name": f"{p}/{d}", "photo": p, "degradation": d, "crop": None}
             for p in PHOTOS for d in DEGRADATIONS]
    k = 0
    for p in PHOTOS:
        for h, w in _CROP_SIZES:
            d = DEGRADATIONS[k % len(DEGRADATIONS)]
            k += 1
            cases.append({"name": f"{p}/{d}/{h}x{w}", "photo": p, "degradation": d,
                          "crop": [_OFFSET[0], _OFFSET[1], h, w]})
    return cases


#: every fixture case: ``{"name", "photo", "degradation", "crop"}`` (70: 20 whole photos, 50 crops)
CASES = _cases()


def _degrade(img: np.ndarray, degradation: str, name: str) -> np.ndarray:
    if degradation == "clean":
        return img
    if degradation == "blur":
        import scipy.ndimage

        out = scipy.ndimage.gaussian_filter(img.astype(np.float64), sigma=(1.5, 1.5, 0), mode="nearest")
        return np.clip(np.rint(out), 0, 255).astype(np.uint8)
    if degradation == "noise":
        rng = np.random.default_rng(zlib.crc32(name.encode()))
        out = img + rng.normal(0.0, 10.0, img.shape)
        return np.clip(np.rint(out), 0, 255).astype(np.uint8)
    if degradation == "jpeg":
        from PIL import Image

        buf = io.BytesIO()
        Image.fromarray(img).save(buf, format="JPEG", quality=20)
        return np.asarray(Image.open(io.BytesIO(buf.getvalue())).convert("RGB"))
    raise ValueError(f"unknown degradation {degradation!r}")


@lru_cache(maxsize=8)
def _photo(photo: str, degradation: str) -> np.ndarray:
    import skimage.data

    img = np.ascontiguousarray(getattr(skimage.data, photo)()[:, :, :3])
    img = _degrade(img, degradation, f"{photo}/{degradation}")
    img.flags.writeable = False
    return img


def case_image(case: dict) -> np.ndarray:
    """The uint8 (H, W, 3) RGB image of one of :data:`CASES` (a new array)."""
    img = _photo(case["photo"], case["degradation"])
    if case["crop"] is not None:
        y0, x0, h, w = case["crop"]
        img = img[y0:y0 + h, x0:x0 + w]
    return np.ascontiguousarray(img)


def image_sha256(img: np.ndarray) -> str:
    """sha256 of the image's shape and bytes (C order)."""
    return hashlib.sha256(repr(img.shape).encode() + np.ascontiguousarray(img).tobytes()).hexdigest()
