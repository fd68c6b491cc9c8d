"""``piqe``: PIQE (Venkatanath et al. 2015), no reference, training-free; lower is better.

As MATLAB's ``piqe`` (Image Processing Toolbox) computes it, vectorised over blocks:

1. grey: MATLAB ``rgb2gray`` (:func:`~nvrq.metrics.no_reference._common.rgb2gray_matlab`); the crop is
   padded (``'symmetric'``, bottom/right) to whole 16x16 blocks and scaled to
   ``round(255 * I / max(I))``;
2. MSCN ``(I - mu) / (sigma + 1)``, 7x7 Gaussian window (sigma 7/6), replicated borders;
3. per block of the MSCN map: variance ``v`` (sample, n - 1); the block is *active* if ``v > 0.1``;
4. an active block has a *noticeable artifact* if any 6-pixel segment (11 per edge, stride 1)
   of one of its four one-pixel edges has a sample standard deviation below 0.1;
5. it is *noisy* if ``sqrt(v) > 2 beta``, ``beta = |sqrt(v) - r| / max(sqrt(v), r)``, ``r`` the
   ratio of the standard deviation of the two centre columns (8th and 9th) to that of the
   surround (MATLAB's code deletes the 8th column and then the 9th of what is left, i.e. the
   original 10th; kept as it is; ``r = 0`` when undefined);
6. ``PIQE = 100 (sum_active (a (1 - v) + n v) + 1) / (N_active + 1)``, ``a``/``n`` the two flags.

Range [0, 100]; a flat (or all-black) crop scores 100, as MATLAB documents. Our rule: NaN when the
shorter side is below :data:`MIN_SIDE` (less than one block of image content; MATLAB pads anything).

>>> import numpy as np
>>> piqe(np.full((32, 32, 3), 128, np.uint8))  # uniform: no active block, (0 + 1) / (0 + 1)
100.0
"""

from __future__ import annotations

import math

import numpy as np

from nvrq.metrics.no_reference._common import _below_side, _rgb2gray, check_rgb

__all__ = ["piqe", "piqe_blocks", "MIN_SIDE", "BLOCK"]

BLOCK = 16
#: shorter crop side (px) from which PIQE is defined: one whole block of image content
MIN_SIDE = BLOCK
_ACTIVITY, _IMPAIRED, _SEGMENT = 0.1, 0.1, 6


def _normalised(grey: np.ndarray) -> np.ndarray:
    """MSCN map of the padded, rescaled grey crop (H', W') float64, H' and W' multiples of 16."""
    h, w = grey.shape
    x = np.pad(grey, ((0, -h % BLOCK), (0, -w % BLOCK)), mode="symmetric").astype(np.float64)
    peak = x.max()
    x = np.floor(255.0 * x / peak + 0.5)  # MATLAB round (non-negative values)
    import cv2  # on first use (the registry is read by `nvrq score --help`)

    mu = cv2.GaussianBlur(x, (7, 7), 7.0 / 6.0, sigmaY=7.0 / 6.0, borderType=cv2.BORDER_REPLICATE)
    second = cv2.GaussianBlur(x * x, (7, 7), 7.0 / 6.0, sigmaY=7.0 / 6.0, borderType=cv2.BORDER_REPLICATE)
    return (x - mu) / (np.sqrt(np.abs(second - mu * mu)) + 1.0)


def piqe_blocks(render: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """PIQE's block statistics (module docstring).

    Parameters
    ----------
    render : (H, W, 3) uint8
        An RGB crop.

    Returns
    -------
    tuple of four (n,) arrays
        Per 16x16 block, row-major: MSCN variance, and the active, noticeable-artifact and
        noise flags.
    """
    return _piqe_blocks(check_rgb(render))


def _piqe_blocks(render: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`piqe_blocks` without the input check."""
    grey = _rgb2gray(render)
    if grey.max() == 0:  # all black: MATLAB's 0/0 leaves no active block
        n = (-(-grey.shape[0] // BLOCK)) * (-(-grey.shape[1] // BLOCK))
        return np.zeros(n), np.zeros(n, bool), np.zeros(n, bool), np.zeros(n, bool)
    m = _normalised(grey)
    h, w = m.shape
    b = m.reshape(h // BLOCK, BLOCK, w // BLOCK, BLOCK).transpose(0, 2, 1, 3).reshape(-1, BLOCK, BLOCK)
    var = b.reshape(len(b), -1).var(axis=1, ddof=1)
    active = var > _ACTIVITY
    edges = np.stack([b[:, 0, :], b[:, :, -1], b[:, -1, :], b[:, :, 0]], axis=1)  # (n, 4, 16)
    segments = np.lib.stride_tricks.sliding_window_view(edges, _SEGMENT, axis=2)  # (n, 4, 11, 6)
    artifact = (segments.std(axis=3, ddof=1) < _IMPAIRED).any(axis=(1, 2))
    centre = b[:, :, [7, 8]].reshape(len(b), -1)
    surround = b[:, :, [c for c in range(BLOCK) if c not in (7, 9)]].reshape(len(b), -1)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = centre.std(axis=1, ddof=1) / surround.std(axis=1, ddof=1)
        ratio = np.where(np.isnan(ratio), 0.0, ratio)
        sigma = np.sqrt(var)
        beta = np.abs(sigma - ratio) / np.maximum(sigma, ratio)
    noise = sigma > 2.0 * beta
    return var, active, artifact & active, noise & active


def piqe(render: np.ndarray) -> float:
    """PIQE of the render crop, as MATLAB's ``piqe`` (module docstring).

    Parameters
    ----------
    render : (H, W, 3) uint8
        The render crop, used at its own size.

    Returns
    -------
    float
        In [0, 100], lower is better; NaN if the shorter side is below :data:`MIN_SIDE`.

    Raises
    ------
    InputError
        Unless ``render`` is a uint8 (H, W, 3) RGB array.
    """
    return _piqe(check_rgb(render))


def _piqe(render: np.ndarray) -> float:
    """:func:`piqe` without the input check (the scoring core checks once per run)."""
    if _below_side(render, MIN_SIDE):
        return math.nan
    var, active, artifact, noise = _piqe_blocks(render)
    dist = np.sum(artifact * (1.0 - var) + noise * var)
    return float(100.0 * (dist + 1.0) / (active.sum() + 1.0))
