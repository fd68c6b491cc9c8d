"""Reconstruction artefacts of novel-view renders, applied to crops or whole images.

Layer: nvrq core, synth (synthetic scenes).

Each artefact maps a ``(H, W, 3)`` uint8 image and a strength in [0, 1] (0 = unchanged,
1 = the object is badly broken) to a new image of the same shape. Sizes scale with the
image, so one strength looks alike on a small and a large crop. "Lateral" is the image's
horizontal axis (the direction the virtual camera moved).

- ``blur``: Gaussian blur, sigma up to 4 % of the shorter side.
- ``ghost``: a faint second copy shifted sideways (doubled edges).
- ``floaters``: semi-transparent blobs floating in front of the object.
- ``smear``: texture smeared along the lateral direction (horizontal box filter).
- ``color_shift``: desaturation plus a colour cast.
- ``holes``: dark gaps where the reconstruction has no surface.

>>> import numpy as np
>>> img = np.random.default_rng(0).integers(0, 255, (40, 60, 3), dtype=np.uint8)
>>> bool((apply_artefact(img, "blur", 0.0, rng=np.random.default_rng(1)) == img).all())
True
>>> [apply_artefact(img, a, 0.7, rng=np.random.default_rng(1)).shape for a in ARTEFACTS][0]
(40, 60, 3)
"""

from __future__ import annotations

import cv2
import numpy as np

from data_schema.errors import InputError

__all__ = ["ARTEFACTS", "apply_artefact", "apply_artefacts", "blend_into", "fast_blur"]

ARTEFACTS = ("blur", "ghost", "floaters", "smear", "color_shift", "holes")


def fast_blur(img: np.ndarray, sigma: float) -> np.ndarray:
    """Gaussian blur; large sigmas go through a shrunken copy (area-resize down, blur, linear up).

    Parameters
    ----------
    img : (H, W, C) uint8
        The image.
    sigma : float, pixels
        Gaussian standard deviation; below 0.15 the image is copied unchanged.

    Returns
    -------
    (H, W, C) uint8
    """
    if sigma < 0.15:
        return img.copy()
    if sigma <= 3.0:
        return cv2.GaussianBlur(img, (0, 0), sigma, borderType=cv2.BORDER_REFLECT)
    h, w = img.shape[:2]
    f = 2.0 / sigma
    sw, sh = max(int(round(w * f)), 1), max(int(round(h * f)), 1)
    small = cv2.resize(img, (sw, sh), interpolation=cv2.INTER_AREA)
    small = cv2.GaussianBlur(small, (0, 0), 1.0, borderType=cv2.BORDER_REFLECT)
    out = cv2.resize(small, (w, h), interpolation=cv2.INTER_LINEAR)
    return out.reshape(img.shape)


def _blur(img, s, rng):
    return fast_blur(img, s * 0.04 * min(img.shape[:2]))


def _ghost(img, s, rng):
    h, w = img.shape[:2]
    dx = (1 if rng.random() < 0.5 else -1) * s * 0.14 * w
    dy = rng.uniform(-0.02, 0.02) * s * h
    shifted = cv2.warpAffine(
        img, np.float32([[1, 0, dx], [0, 1, dy]]), (w, h), borderMode=cv2.BORDER_REFLECT
    )
    a = 0.55 * min(s * 2.0, 1.0)
    return cv2.addWeighted(img, 1 - a, shifted, a, 0)


def _floaters(img, s, rng):
    h, w = img.shape[:2]
    over = img.copy()
    alpha = np.zeros((h, w), np.float32)
    n = int(round(1 + 22 * s))
    m = min(h, w)
    for _ in range(n):
        c = (int(rng.uniform(0, w)), int(rng.uniform(0, h)))
        ax = (
            max(int(rng.uniform(0.02, 0.09) * m * (0.5 + s)), 1),
            max(int(rng.uniform(0.02, 0.06) * m * (0.5 + s)), 1),
        )
        ang = float(rng.uniform(0, 180))
        col = tuple(
            float(v)
            for v in rng.uniform(90, 230) * np.array([1.0, 1.0, 1.0]) + rng.normal(0, 20, 3)
        )
        cv2.ellipse(over, c, ax, ang, 0, 360, col, -1, cv2.LINE_AA)
        cv2.ellipse(alpha, c, ax, ang, 0, 360, float(rng.uniform(0.35, 0.8)), -1, cv2.LINE_AA)
    alpha = fast_blur(alpha, max(0.01 * m, 0.5))[..., None] * min(1.0, 0.3 + s)
    return (img * (1 - alpha) + over * alpha).astype(np.uint8)


def _smear(img, s, rng):
    k = int(round(s * 0.25 * img.shape[1]))
    if k < 2:
        return img.copy()
    return cv2.blur(img, (k, 1), borderType=cv2.BORDER_REFLECT)


def _color_shift(img, s, rng):
    # out = (1 - a) * img + a * grey + cast, grey = channel mean: one affine colour transform
    cast = rng.normal(0.0, 1.0, 3)
    cast = cast / max(np.linalg.norm(cast), 1e-6) * 70.0 * s
    a = 0.6 * s
    M = np.full((3, 3), a / 3.0) + np.eye(3) * (1.0 - a)
    return cv2.transform(img, np.hstack([M, cast[:, None]]).astype(np.float32))


def _holes(img, s, rng):
    h, w = img.shape[:2]
    mask = np.zeros((h, w), np.float32)
    m = min(h, w)
    for _ in range(int(round(1 + 5 * s))):
        c = (int(rng.uniform(0.1, 0.9) * w), int(rng.uniform(0.1, 0.9) * h))
        ax = (
            max(int(rng.uniform(0.05, 0.2) * m * (0.2 + s)), 1),
            max(int(rng.uniform(0.05, 0.2) * m * (0.2 + s)), 1),
        )
        cv2.ellipse(mask, c, ax, float(rng.uniform(0, 180)), 0, 360, 1.0, -1, cv2.LINE_AA)
    mask = fast_blur(mask, max(0.01 * m, 0.5))[..., None] * min(1.0, 0.4 + s)
    fill = fast_blur(img, max(0.08 * m, 1.0)).astype(np.float32) * 0.25
    return (img * (1 - mask) + fill * mask).astype(np.uint8)


_FUNCS = {
    "blur": _blur,
    "ghost": _ghost,
    "floaters": _floaters,
    "smear": _smear,
    "color_shift": _color_shift,
    "holes": _holes,
}


def apply_artefact(
    image: np.ndarray, name: str, strength: float, *, rng: np.random.Generator
) -> np.ndarray:
    """One artefact ``name`` in :data:`ARTEFACTS` at ``strength`` in [0, 1] on ``image (H, W, 3)`` uint8.

    Returns a new array; strength 0 returns an exact copy.

    Parameters
    ----------
    image : (H, W, 3) uint8
        The image.
    name : str
        One of :data:`ARTEFACTS`.
    strength : float
        In [0, 1]; 0 leaves the image unchanged.
    rng : numpy.random.Generator
        Source of the artefact's randomness.

    Returns
    -------
    (H, W, 3) uint8
        A new image.
    """
    if name not in _FUNCS:
        raise InputError("artefact", "name", f"one of {', '.join(ARTEFACTS)}", repr(name))
    s = float(strength)
    if not 0.0 <= s <= 1.0:
        raise InputError("artefact", "strength", "a number in [0, 1]", s)
    img = np.ascontiguousarray(image)
    if img.ndim != 3 or img.shape[2] != 3 or img.dtype != np.uint8:
        raise InputError(
            "artefact", "image", "an (H, W, 3) uint8 array", f"{img.dtype} {img.shape}"
        )
    if s == 0.0 or min(img.shape[:2]) < 2:
        return img.copy()
    return _FUNCS[name](img, s, rng)


def apply_artefacts(image: np.ndarray, strengths, *, rng: np.random.Generator) -> np.ndarray:
    """All artefacts in the order of :data:`ARTEFACTS`; ``strengths`` (6,) or a name -> strength dict.

    Parameters
    ----------
    image : (H, W, 3) uint8
        The image.
    strengths : (6,) float or dict
        One strength in [0, 1] per artefact, in the order of :data:`ARTEFACTS`, or by name.
    rng : numpy.random.Generator
        Source of the artefacts' randomness.

    Returns
    -------
    (H, W, 3) uint8
        A new image.
    """
    if isinstance(strengths, dict):
        strengths = [float(strengths.get(a, 0.0)) for a in ARTEFACTS]
    order = ("color_shift", "smear", "blur", "ghost", "floaters", "holes")
    out = image
    for name in order:
        s = float(strengths[ARTEFACTS.index(name)])
        if s > 0.005:
            out = apply_artefact(out, name, min(s, 1.0), rng=rng)
    return out if out is not image else image.copy()


def blend_into(
    image: np.ndarray,
    ids: np.ndarray,
    k: int,
    box,
    strengths,
    severity: float,
    *,
    rng: np.random.Generator,
) -> None:
    """Degrade actor ``k`` in ``image (H, W, 3)`` in place, where ``ids (H, W) == k``.

    ``box`` [x0, y0, x1, y1] (exclusive end) bounds the actor's pixels; the damaged region
    spills a little beyond the silhouette as severity grows (ghosts and floaters do).

    Parameters
    ----------
    image : (H, W, 3) uint8
        The view, changed in place.
    ids : (H, W) int
        Object-id buffer (actor index, -1 none).
    k : int
        The actor to degrade.
    box : (4,) int
        ``[x0, y0, x1, y1]`` pixels, exclusive end.
    strengths : (6,) float
        Artefact strengths in [0, 1], in the order of :data:`ARTEFACTS`.
    severity : float
        The actor's severity in [0, 1] (how far the damage spills).
    rng : numpy.random.Generator
        Source of the artefacts' randomness.
    """
    H, W = ids.shape
    x0, y0, x1, y1 = box
    pad = int(0.12 * max(x1 - x0, y1 - y0) * (0.3 + severity)) + 2
    xa, ya, xb, yb = max(x0 - pad, 0), max(y0 - pad, 0), min(x1 + pad, W), min(y1 + pad, H)
    crop = image[ya:yb, xa:xb]
    mask = (ids[ya:yb, xa:xb] == k).astype(np.float32)
    if not mask.any():
        return
    r = 1 + int(pad * min(1.0, severity * 1.5))
    mask = np.minimum(fast_blur(mask, max(r / 2, 0.7)) * 2.5, 1.0)[..., None]
    damaged = apply_artefacts(crop, strengths, rng=rng).astype(np.float32)
    f = crop.astype(np.float32)
    crop[:] = (f + (damaged - f) * mask).astype(np.uint8)
