"""Nuisances a good object-quality metric should ignore (the stability study, paper Fig. 4).

Layer: nvrq core, metrics support (nuisances of the stability study).

Each function returns the *other* crop of a GT-vs-perturbed pair; the GT crop itself is
``image[y0:y1+1, x0:x1+1]`` of the inclusive box ``[x0, y0, x1, y1]`` (docs/FORMATS.md §3).
``strength`` is in each nuisance's natural unit (see :data:`NUISANCE_STRENGTHS`).

- ``box_jitter``: the box shifted by ``strength`` x its size in a random direction
  (``dx = s w cos(theta)``, ``dy = s h sin(theta)``), re-cut from the full image.
- ``scale_jitter``: the box scaled about its centre by ``1 + s`` or ``1 - s`` (random sign).
- ``occlusion``: another object's crop, resized to cover ``s`` of the box area, pasted into
  a random corner.
- ``exposure``: pixel values times a gain ``1 + s`` or ``1 - s`` (random sign), clipped.
- ``jpeg``: JPEG re-encoding at quality ``100 - s``.
- ``view_shift``: the same track's GT crop ``s`` frames away (built by :mod:`nvrq.stability`).

>>> import numpy as np
>>> box = shifted_box(np.array([10, 10, 29, 19]), 0.1, 0.0, (100, 100))  # 20 x 10 box, theta = 0
>>> box.tolist()  # dx = 0.1 * 20 = 2, dy = 0
[12, 10, 31, 19]
>>> scaled_box(np.array([10, 10, 29, 19]), 1.5, (100, 100)).tolist()  # 30 x 15 about (19.5, 14.5)
[5, 7, 34, 21]
"""

from __future__ import annotations

import math

import cv2
import numpy as np

__all__ = [
    "NUISANCE_STRENGTHS",
    "shifted_box",
    "scaled_box",
    "clamp_box",
    "occlude",
    "expose",
    "jpeg_roundtrip",
]

#: nuisance -> strengths studied (units: box fraction, scale fraction, area fraction, gain
#: change, 100 - JPEG quality, frames apart).
NUISANCE_STRENGTHS: dict[str, tuple[float, ...]] = {
    "box_jitter": (0.02, 0.05, 0.10, 0.20),
    "scale_jitter": (0.05, 0.10, 0.20),
    "occlusion": (0.10, 0.20, 0.30),
    "exposure": (0.10, 0.20, 0.40),
    "jpeg": (10.0, 30.0, 50.0, 70.0),
    "view_shift": (1.0, 2.0),
}


def clamp_box(box: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """Move an inclusive box (4,) inside an image of ``size (W, H)`` keeping its size when it fits.

    Parameters
    ----------
    box : (4,) int
        ``[x0, y0, x1, y1]``, inclusive pixels.
    size : (int, int)
        ``(W, H)`` of the image, pixels.

    Returns
    -------
    (4,) int64
        The moved box, inclusive pixels.
    """
    W, H = size
    x0, y0, x1, y1 = (int(v) for v in box)
    w, h = min(x1 - x0 + 1, W), min(y1 - y0 + 1, H)
    x0 = min(max(x0, 0), W - w)
    y0 = min(max(y0, 0), H - h)
    return np.array([x0, y0, x0 + w - 1, y0 + h - 1], np.int64)


def shifted_box(
    box: np.ndarray, fraction: float, theta: float, size: tuple[int, int]
) -> np.ndarray:
    """Inclusive ``box`` (4,) shifted by ``fraction`` of its width/height along angle ``theta``.

    Parameters
    ----------
    box : (4,) int
        ``[x0, y0, x1, y1]``, inclusive pixels.
    fraction : float
        Shift as a fraction of the box's width (x) and height (y).
    theta : float, radians
        Direction of the shift (0: +u, pi/2: +v).
    size : (int, int)
        ``(W, H)`` of the image, pixels.

    Returns
    -------
    (4,) int64
        Inclusive pixels, clamped into the image (:func:`clamp_box`).
    """
    w, h = box[2] - box[0] + 1, box[3] - box[1] + 1
    dx = int(round(fraction * w * math.cos(theta)))
    dy = int(round(fraction * h * math.sin(theta)))
    return clamp_box(np.asarray(box) + np.array([dx, dy, dx, dy]), size)


def scaled_box(box: np.ndarray, factor: float, size: tuple[int, int]) -> np.ndarray:
    """Inclusive ``box`` (4,) scaled by ``factor`` about its centre (sides rounded, at least 2 px).

    Parameters
    ----------
    box : (4,) int
        The object's box ``[x0, y0, x1, y1]``, inclusive pixels; its centre stays put.
    factor : float
        Scale of both sides (1.2: 20 % wider and taller).
    size : (int, int)
        Image ``(W, H)``, pixels.

    Returns
    -------
    (4,) int64
        The scaled box, moved back inside the image where it sticks out (:func:`clamp_box`).
    """
    cx, cy = (box[0] + box[2]) / 2.0, (box[1] + box[3]) / 2.0
    w = max(int(round((box[2] - box[0] + 1) * factor)), 2)
    h = max(int(round((box[3] - box[1] + 1) * factor)), 2)
    x0, y0 = int(math.floor(cx - (w - 1) / 2.0)), int(math.floor(cy - (h - 1) / 2.0))
    return clamp_box(np.array([x0, y0, x0 + w - 1, y0 + h - 1]), size)


def occlude(crop: np.ndarray, occluder: np.ndarray, area: float, corner: int) -> np.ndarray:
    """``crop (H, W, 3)`` with ``occluder`` resized to ``sqrt(area) H x sqrt(area) W`` pasted in
    corner ``corner`` (0 top-left, 1 top-right, 2 bottom-left, 3 bottom-right).

    Parameters
    ----------
    crop : (H, W, 3) uint8
        RGB crop.
    occluder : (h, w, 3) uint8
        RGB patch to paste.
    area : float
        Occluded fraction of the crop, in (0, 1].
    corner : int
        ``{0, 1, 2, 3}``: top-left, top-right, bottom-left, bottom-right.

    Returns
    -------
    (H, W, 3) uint8
        A new crop.
    """
    h, w = crop.shape[:2]
    oh, ow = max(int(round(h * math.sqrt(area))), 1), max(int(round(w * math.sqrt(area))), 1)
    y = 0 if corner in (0, 1) else h - oh
    x = 0 if corner in (0, 2) else w - ow
    out = crop.copy()
    out[y : y + oh, x : x + ow] = cv2.resize(occluder, (ow, oh), interpolation=cv2.INTER_AREA)
    return out


def expose(crop: np.ndarray, gain: float) -> np.ndarray:
    """Exposure change: ``clip(round(crop * gain), 0, 255)`` as uint8.

    Parameters
    ----------
    crop : (H, W, 3) uint8
        The crop to brighten (``gain > 1``) or darken (``gain < 1``).
    gain : float
        Factor on every channel value.

    Returns
    -------
    (H, W, 3) uint8
        The scaled values, rounded and saturated at 0 and 255.
    """
    return np.clip(np.rint(crop.astype(np.float32) * gain), 0, 255).astype(np.uint8)


def jpeg_roundtrip(crop: np.ndarray, quality: int) -> np.ndarray:
    """Encode ``crop`` (RGB) as JPEG at ``quality`` with OpenCV and decode it again (RGB).

    Parameters
    ----------
    crop : (H, W, 3) uint8
        RGB crop (sent to OpenCV as BGR).
    quality : int
        JPEG quality, 0-100 (``cv2.IMWRITE_JPEG_QUALITY``).

    Returns
    -------
    (H, W, 3) uint8
        The decoded crop, RGB, with the compression artefacts.
    """
    ok, buf = cv2.imencode(
        ".jpg", np.ascontiguousarray(crop[..., ::-1]), [cv2.IMWRITE_JPEG_QUALITY, int(quality)]
    )
    if not ok:
        raise ValueError("JPEG encoding failed")
    return cv2.imdecode(buf, cv2.IMREAD_COLOR)[..., ::-1].copy()
