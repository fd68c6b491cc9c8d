"""Weight-free full-reference pixel metrics on raw crops (docs/FORMATS.md §4).

Every function takes ``gt`` and ``render``: uint8 RGB crops of equal shape (H, W, 3) --
the render crop already bicubic-resized to the GT crop's size -- and returns a float.
Pixel values are 0-255 (``data_range = 255``); nothing is rescaled or inferred.

- :func:`psnr` -- over all three channels; ``inf`` for identical crops (as scikit-image).
- :func:`ssim` -- Wang et al. 2004: 11x11 Gaussian window, sigma 1.5, K1 0.01, K2 0.03,
  population covariances, computed per RGB channel and averaged; equals
  ``skimage.metrics.structural_similarity(gt, render, channel_axis=-1, data_range=255,
  gaussian_weights=True, sigma=1.5, use_sample_covariance=False)``. NaN if a side < 11.
- :func:`ms_ssim` -- Wang et al. 2003 on the scales the crop holds: scale ``j`` (``j = 1`` the
  crop itself) is reached by ``j - 1`` 2x2 mean downsamplings (an odd last row/column is
  dropped); ``M`` = the number of scales whose shorter side still fits the 11-pixel window,
  at most 5 (``M = min(5, 1 + floor(log2(side / 11)))``: 1 for sides 11-21, 2 for 22-43
  (so every crop from 30 px up has at least two), 3 for 44-87, 4 for 88-175, 5 from 176).
  Weights: the first ``M`` of (0.0448, 0.2856, 0.3001, 0.2363, 0.1333) rescaled to the sum
  of all five as published (1.0001); contrast-structure means at scales ``1..M-1``, full
  SSIM at scale ``M``; negative terms clipped to 0; per RGB channel, then averaged. From
  176 px this is exactly the original 5-scale MS-SSIM; below 22 px it is :func:`ssim`'s
  per-channel means (each clipped at 0) raised to 1.0001 and averaged; NaN if a side < 11.
- :func:`gmsd` -- Xue et al. 2014 (lower is better): luma Y = 0.299 R + 0.587 G + 0.114 B,
  2x2 mean + downsample by 2, Prewitt gradients (/3, zero padding), c = 170, the sample
  standard deviation of the similarity map; 0 for identical crops.
- :func:`mse`, :func:`mae` -- mean squared / absolute error over all values.

>>> import numpy as np
>>> a = np.zeros((16, 16, 3), np.uint8); b = a.copy(); b[0, 0, 0] = 255
>>> round(psnr(a, b), 4)  # 10 log10(255^2 / (255^2 / 768)) = 10 log10(768)
28.8536
>>> ssim(a, a), gmsd(a, a), mse(a, b)
(1.0, 0.0, 84.66796875)
"""

from __future__ import annotations

import math

import numpy as np

from data_schema.errors import InputError

__all__ = [
    "psnr", "ssim", "ms_ssim", "ms_ssim_scales", "gmsd", "mse", "mae", "MS_SSIM_WEIGHTS",
    "SSIM_MIN_SIDE", "GMSD_MIN_SIDE",
]

DATA_RANGE = 255.0
_K1, _K2, _WIN, _SIGMA = 0.01, 0.03, 11, 1.5
#: shorter crop side (px) from which SSIM and MS-SSIM are defined: the Gaussian window's
SSIM_MIN_SIDE = _WIN
#: shorter crop side (px) from which GMSD is defined (a gradient needs two pixels)
GMSD_MIN_SIDE = 2
MS_SSIM_WEIGHTS = (0.0448, 0.2856, 0.3001, 0.2363, 0.1333)


def _check(gt: np.ndarray, render: np.ndarray) -> None:
    """:class:`InputError` naming ``gt`` or ``render`` unless they are (H, W, 3) crops of one shape.

    >>> _check(np.zeros((4, 4, 3)), np.zeros((4, 5, 3)))
    Traceback (most recent call last):
    ...
    data_schema.errors.InputError: render: expected a crop of the GT crop's shape (4, 4, 3) (resized to it), got (4, 5, 3)
    """
    if gt.ndim != 3 or gt.shape[2] != 3:
        raise InputError(param="gt", expected="an (H, W, 3) RGB crop", got=str(gt.shape))
    if render.shape != gt.shape:
        raise InputError(param="render", expected=f"a crop of the GT crop's shape {gt.shape} (resized to it)", got=str(render.shape))


def mse(gt: np.ndarray, render: np.ndarray) -> float:
    """Mean squared error over all H*W*3 values (0-255 scale).

    Parameters
    ----------
    gt, render : (H, W, 3) uint8
        RGB crops of one shape (the render crop resized to the GT crop's).

    Returns
    -------
    float
        In [0, 255^2]; 0 for identical crops.

    Raises
    ------
    InputError
        Naming ``gt`` or ``render`` for crops of other shapes.
    """
    _check(gt, render)
    return _mse(gt, render)


def _mse(gt: np.ndarray, render: np.ndarray) -> float:
    """:func:`mse` without the input check (the scoring core checks once per run)."""
    d = gt.astype(np.float64) - render.astype(np.float64)
    return float(np.mean(d * d))


def mae(gt: np.ndarray, render: np.ndarray) -> float:
    """Mean absolute error over all H*W*3 values (0-255 scale).

    Parameters
    ----------
    gt, render : (H, W, 3) uint8
        The GT crop and the render crop at its size.

    Returns
    -------
    float
        In [0, 255]; lower is better.

    Raises
    ------
    InputError
        When ``render``'s shape is not ``gt``'s (H, W, 3).
    """
    _check(gt, render)
    return _mae(gt, render)


def _mae(gt: np.ndarray, render: np.ndarray) -> float:
    """:func:`mae` without the input check."""
    return float(np.mean(np.abs(gt.astype(np.float64) - render.astype(np.float64))))


def psnr(gt: np.ndarray, render: np.ndarray) -> float:
    """PSNR in dB, ``10 log10(255^2 / mse)`` over all three channels.

    Parameters
    ----------
    gt, render : (H, W, 3) uint8
        Equal-shape RGB crops, values 0-255 (``data_range`` 255).

    Returns
    -------
    float
        ``inf`` when the crops are identical (as scikit-image).

    Raises
    ------
    InputError
        As :func:`mse`, before any arithmetic.
    """
    _check(gt, render)
    return _psnr(gt, render)


def _psnr(gt: np.ndarray, render: np.ndarray) -> float:
    """:func:`psnr` without the input check."""
    err = _mse(gt, render)
    return math.inf if err == 0 else float(10.0 * np.log10(DATA_RANGE ** 2 / err))


def _blur(x: np.ndarray) -> np.ndarray:
    """11x11 Gaussian (sigma 1.5) of (H, W, C) float64, mirror border ('reflect' as SciPy)."""
    import cv2  # on first use (the registry is read by `nvrq score --help`)

    return cv2.GaussianBlur(x, (_WIN, _WIN), _SIGMA, sigmaY=_SIGMA, borderType=cv2.BORDER_REFLECT)


def _ssim_cs_maps(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """SSIM and contrast-structure maps (h, w, C) over the valid region (border of 5 cut)."""
    c1, c2 = (_K1 * DATA_RANGE) ** 2, (_K2 * DATA_RANGE) ** 2
    ux, uy = _blur(x), _blur(y)
    vx = _blur(x * x) - ux * ux
    vy = _blur(y * y) - uy * uy
    vxy = _blur(x * y) - ux * uy
    cs = (2 * vxy + c2) / (vx + vy + c2)
    s = (2 * ux * uy + c1) / (ux * ux + uy * uy + c1) * cs
    p = (_WIN - 1) // 2
    return s[p:-p, p:-p], cs[p:-p, p:-p]


def ssim(gt: np.ndarray, render: np.ndarray) -> float:
    """Mean SSIM (module docstring: scikit-image's with Gaussian weights), per RGB channel,
    then averaged.

    Parameters
    ----------
    gt, render : (H, W, 3) uint8
        Crops of one shape; both sides at least :data:`SSIM_MIN_SIDE` for a value.

    Returns
    -------
    float
        In [-1, 1]; NaN if a crop side is < 11 pixels.

    Raises
    ------
    InputError
        Naming ``render`` when its shape is not ``gt``'s (resizing is the caller's job).
    """
    _check(gt, render)
    return _ssim(gt, render)


def _ssim(gt: np.ndarray, render: np.ndarray) -> float:
    """:func:`ssim` without the input check."""
    if min(gt.shape[:2]) < _WIN:
        return math.nan
    s, _ = _ssim_cs_maps(gt.astype(np.float64), render.astype(np.float64))
    return float(s.reshape(-1, 3).mean(axis=0).mean())


def _half(x: np.ndarray) -> np.ndarray:
    h, w = (x.shape[0] // 2) * 2, (x.shape[1] // 2) * 2
    x = x[:h, :w]
    return 0.25 * (x[0::2, 0::2] + x[1::2, 0::2] + x[0::2, 1::2] + x[1::2, 1::2])


def ms_ssim_scales(side: int) -> int:
    """Scales MS-SSIM uses for a crop whose shorter side is ``side``.

    Parameters
    ----------
    side : int
        The shorter crop side in pixels.

    Returns
    -------
    int
        ``M`` in 0..5: 0 below 11 px (module docstring).

    >>> [ms_ssim_scales(s) for s in (10, 11, 21, 22, 30, 44, 88, 175, 176, 1000)]
    [0, 1, 1, 2, 2, 3, 4, 4, 5, 5]
    """
    m = 0
    while m < len(MS_SSIM_WEIGHTS) and side // 2**m >= _WIN:
        m += 1
    return m


def ms_ssim(gt: np.ndarray, render: np.ndarray) -> float:
    """Multi-scale SSIM on the scales the crop holds (module docstring).

    Parameters
    ----------
    gt, render : (H, W, 3) uint8
        Crops of one shape; :func:`ms_ssim_scales` of the shorter side sets the scales.

    Returns
    -------
    float
        In [0, 1]; NaN below 11 px.

    Raises
    ------
    InputError
        As :func:`mse`.
    """
    _check(gt, render)
    return _ms_ssim(gt, render)


def _ms_ssim(gt: np.ndarray, render: np.ndarray) -> float:
    """:func:`ms_ssim` without the input check."""
    n_scales = ms_ssim_scales(min(gt.shape[:2]))
    if n_scales == 0:
        return math.nan
    x, y = gt.astype(np.float64), render.astype(np.float64)
    w = np.asarray(MS_SSIM_WEIGHTS[:n_scales])
    w = w * (sum(MS_SSIM_WEIGHTS) / w.sum())  # the published sum (1.0001) at every M
    terms = []
    for level in range(len(w)):
        s, cs = _ssim_cs_maps(x, y)
        if level == len(w) - 1:
            terms.append(s.reshape(-1, 3).mean(axis=0))
        else:
            terms.append(cs.reshape(-1, 3).mean(axis=0))
            x, y = _half(x), _half(y)
    per_channel = np.prod(np.maximum(np.stack(terms), 0.0) ** w[:, None], axis=0)  # (3,)
    return float(per_channel.mean())


def _luma(img: np.ndarray) -> np.ndarray:
    return img.astype(np.float64) @ np.array([0.299, 0.587, 0.114])


def _gradient_magnitude(y: np.ndarray) -> np.ndarray:
    # 2x2 mean ('same' conv with zero padding beyond the last row/column), every 2nd pixel
    p = np.pad(y, ((0, 1), (0, 1)))
    ave = 0.25 * (p[:-1, :-1] + p[1:, :-1] + p[:-1, 1:] + p[1:, 1:])
    d = ave[0::2, 0::2]
    dx = np.array([[1.0, 0.0, -1.0]] * 3) / 3.0
    import cv2

    gx = cv2.filter2D(d, cv2.CV_64F, dx, borderType=cv2.BORDER_CONSTANT)
    gy = cv2.filter2D(d, cv2.CV_64F, dx.T.copy(), borderType=cv2.BORDER_CONSTANT)
    return np.sqrt(gx * gx + gy * gy)


def gmsd(gt: np.ndarray, render: np.ndarray) -> float:
    """Gradient magnitude similarity deviation, Xue et al. 2014 (module docstring).

    Parameters
    ----------
    gt, render : (H, W, 3) uint8
        Crops of one shape, both sides at least :data:`GMSD_MIN_SIDE`.

    Returns
    -------
    float
        Lower is better; 0 for identical crops, NaN for a smaller crop.

    Raises
    ------
    InputError
        For a ``gt`` that is not (H, W, 3), or a ``render`` of another shape.
    """
    _check(gt, render)
    return _gmsd(gt, render)


def _gmsd(gt: np.ndarray, render: np.ndarray) -> float:
    """:func:`gmsd` without the input check."""
    if min(gt.shape[:2]) < GMSD_MIN_SIDE:
        return math.nan
    m1, m2 = _gradient_magnitude(_luma(gt)), _gradient_magnitude(_luma(render))
    c = 170.0
    gms = (2 * m1 * m2 + c) / (m1 * m1 + m2 * m2 + c)
    return float(np.std(gms, ddof=1)) if gms.size > 1 else math.nan
