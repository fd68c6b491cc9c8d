"""What the no-reference metrics share: the input check and MATLAB's grey conversion.

All four follow their MATLAB originals (docs/FORMATS.md §4), so all four see the crop through
MATLAB's ``rgb2gray`` (:func:`rgb2gray_matlab`).

>>> import numpy as np
>>> px = np.array([[[255, 0, 0], [0, 255, 0], [0, 0, 255], [10, 20, 30]]], np.uint8)
>>> rgb2gray_matlab(px).tolist()  # round(0.298936 * 255) = 76, ...; 10*.2989+20*.5870+30*.1140 = 18.15
[[76, 150, 29, 18]]
"""

from __future__ import annotations

import numpy as np

from data_schema.errors import InputError

__all__ = ["rgb2gray_matlab", "check_rgb", "MATLAB_GREY"]

#: MATLAB ``rgb2gray`` (the NTSC luma of ``rgb2ntsc``, as MATLAB documents it to 15 digits)
MATLAB_GREY = (0.298936021293775, 0.587043074451121, 0.114020904255103)


def check_rgb(crop: np.ndarray) -> np.ndarray:
    """``crop`` as given, or :class:`InputError` (a ValueError) naming the metric functions'
    parameter ``render`` unless it is a uint8 (H, W, 3) RGB array.

    Parameters
    ----------
    crop : (H, W, 3) uint8 ndarray
        The RGB crop to check.

    Returns
    -------
    (H, W, 3) uint8 ndarray
        ``crop`` as an array.

    >>> check_rgb(np.zeros((2, 2), np.float32))
    Traceback (most recent call last):
    ...
    data_schema.errors.InputError: render: expected a uint8 (H, W, 3) RGB crop, got float32 (2, 2)
    """
    crop = np.asarray(crop)
    if crop.ndim != 3 or crop.shape[2] != 3 or crop.dtype != np.uint8:
        raise InputError(param="render", expected="a uint8 (H, W, 3) RGB crop", got=f"{crop.dtype} {crop.shape}")
    return crop


def _below_side(render: np.ndarray, side: int) -> bool:
    """Whether the crop ``render`` (H, W, 3) has a side shorter than ``side`` px: the
    no-reference metrics are NaN for such crops (no input check: the scoring core checks once
    per run)."""
    return min(render.shape[:2]) < side


def rgb2gray_matlab(crop: np.ndarray) -> np.ndarray:
    """MATLAB ``rgb2gray`` of a uint8 (H, W, 3) RGB crop -> uint8 (H, W): the weighted sum
    :data:`MATLAB_GREY`, rounded half away from zero (values are non-negative).

    Parameters
    ----------
    crop : (H, W, 3) uint8 ndarray
        The RGB crop.

    Returns
    -------
    (H, W) uint8 ndarray
        The grey image.
    """
    return _rgb2gray(check_rgb(crop))


def _rgb2gray(crop: np.ndarray) -> np.ndarray:
    """:func:`rgb2gray_matlab` without the input check."""
    grey = crop.astype(np.float64) @ np.asarray(MATLAB_GREY)
    return np.floor(grey + 0.5).clip(0, 255).astype(np.uint8)

