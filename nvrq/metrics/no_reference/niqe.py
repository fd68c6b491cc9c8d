"""``niqe``: NIQE (Mittal, Soundararajan & Bovik 2013), no reference, no training on opinions;
lower is better.

The pristine model is the original release's (LIVE, UT Austin, ``niqe_release.zip``,
``modelparameters.mat``: the mean (36,) and covariance (36, 36) of the features of 96x96 patches
of 125 pristine images), shipped here as ``models/niqe_pristine.npz`` (provenance in
``models/SOURCES.md``, LIVE's notice in ``models/LICENSE-LIVE.txt``). The features are computed
as the release's ``computequality.m`` / ``computefeature.m`` compute them, vectorised over
blocks (helpers in :mod:`nvrq.metrics.no_reference._nss`):

1. grey: MATLAB ``rgb2gray`` (:func:`~nvrq.metrics.no_reference._common.rgb2gray_matlab`) as double,
   values 0-255, cut to whole 96x96 blocks (bottom/right remainder dropped);
2. MSCN ``(I - mu) / (sigma + 1)``, 7x7 Gaussian (sigma 7/6), replicated borders
   (``imfilter(I, w, 'replicate')``);
3. per block (``blkproc``), an asymmetric generalised Gaussian fit of the MSCN block and of its
   four neighbour products with itself circularly shifted (within the block) by (0, 1), (1, 0),
   (1, 1) and (1, -1): ``alpha`` the shape in ``0.2:0.001:10`` nearest to the normalised moment
   ratio, ``beta_l, beta_r = sigma_l, sigma_r * sqrt(Gamma(1/a) / Gamma(3/a))``; features
   ``alpha, (beta_l + beta_r) / 2`` for the block, ``alpha, (beta_r - beta_l) Gamma(2/a) /
   Gamma(1/a), beta_l, beta_r`` per product;
4. the same 18 at half scale (MATLAB ``imresize(I, 0.5)``, bicubic with antialiasing; 48x48
   blocks), beside the first 18 of the same block;
5. the crop's model: ``mu`` the ``nanmean`` of the block features, ``Sigma`` their ``nancov``
   (blocks with an undefined feature dropped); ``NIQE = sqrt((mu_p - mu)^T pinv((Sigma_p +
   Sigma) / 2) (mu_p - mu))``.

Rules (docs/FORMATS.md §4): every whole block, in order (nothing sampled), so a crop always gives
the same number. NaN when a side is below :data:`PATCH` (no whole block) or no block has defined
features. With fewer than two blocks whose 36 features are all defined (e.g. a 96-191 px crop:
one block) the crop covariance is taken as 0 (ours: the references have none -- NumPy's
covariance of one row is NaN, and MATLAB's ``nancov`` of one row treats it as a vector and
returns one variance). An MSCN coefficient below 1e-9 in magnitude is 0
(:func:`nvrq.metrics.no_reference._nss.mscn`).

>>> import numpy as np
>>> flat = np.full((96, 96, 3), 128, np.uint8)   # one block, all MSCN 0: no AGGD fit
>>> niqe(flat)
nan
"""

from __future__ import annotations

import math
from functools import lru_cache
from pathlib import Path

import numpy as np

from nvrq.metrics.no_reference._common import _below_side, _rgb2gray, check_rgb
from nvrq.metrics.no_reference._nss import aggd_stats, circular_products, imresize_half, mscn

__all__ = ["niqe", "niqe_features", "load_pristine", "PATCH", "MODEL_PATH"]

#: NIQE block side (px): a crop needs one whole block
PATCH = 96
#: the original release's pristine model (models/SOURCES.md)
MODEL_PATH = Path(__file__).resolve().parent / "models" / "niqe_pristine.npz"
_SHIFTS = ((0, 1), (1, 0), (1, 1), (1, -1))


def _block_features(m: np.ndarray, side: int) -> np.ndarray:
    """(n_blocks, 18) features of the ``side`` x ``side`` blocks of the MSCN map ``m`` (whose
    sides are multiples of ``side``), blocks in row-major order."""
    from scipy.special import gammaln  # on first use: `nvrq --help` imports this module

    h, w = m.shape
    b = m.reshape(h // side, side, w // side, side).transpose(0, 2, 1, 3).reshape(-1, side, side)
    n = len(b)
    maps = circular_products(b, _SHIFTS).reshape(5 * n, -1)  # per block: itself, its 4 products
    alpha, left, right = aggd_stats(maps)
    k = np.exp(0.5 * (gammaln(1.0 / alpha) - gammaln(3.0 / alpha)))
    alpha, bl, br = (v.reshape(5, n) for v in (alpha, left * k, right * k))
    ratio = np.exp(gammaln(2.0 / alpha[1:]) - gammaln(1.0 / alpha[1:]))
    cols = [alpha[0], (bl[0] + br[0]) / 2.0]
    for j in range(4):
        cols += [alpha[j + 1], (br[j + 1] - bl[j + 1]) * ratio[j], bl[j + 1], br[j + 1]]
    return np.stack(cols, axis=1)


def niqe_features(render: np.ndarray) -> np.ndarray:
    """The NIQE features of every whole 96x96 block of a crop (module docstring).

    Parameters
    ----------
    render : (H, W, 3) uint8 RGB array
        The crop, both sides at least :data:`PATCH` (grey by MATLAB ``rgb2gray``).

    Returns
    -------
    (n_blocks, 36) float64 array
        One row per block (row-major): 18 features at full scale, then 18 at half scale (MATLAB
        ``imresize(0.5)``); NaN where undefined.
    """
    return _niqe_features(check_rgb(render))


def _niqe_features(render: np.ndarray) -> np.ndarray:
    """:func:`niqe_features` without the input check."""
    grey = _rgb2gray(render).astype(np.float64)
    h, w = grey.shape
    grey = np.ascontiguousarray(grey[:h - h % PATCH, :w - w % PATCH])
    return np.hstack([_block_features(mscn(grey, padding="replicate"), PATCH),
                      _block_features(mscn(imresize_half(grey), padding="replicate"), PATCH // 2)])


@lru_cache(maxsize=1)
def load_pristine() -> tuple[np.ndarray, np.ndarray]:
    """``(mu (36,), cov (36, 36))`` of the original release's pristine model (:data:`MODEL_PATH`).

    Returns
    -------
    tuple of ndarray
        ``(mu, cov)``: the (36,) mean and (36, 36) covariance of the pristine features.
    """
    with np.load(MODEL_PATH) as z:
        return z["mu"], z["cov"]


def niqe(render: np.ndarray) -> float:
    """NIQE: the distance of a crop's block statistics to the pristine model (module docstring).

    Parameters
    ----------
    render : (H, W, 3) uint8 RGB array
        The crop at its own size (grey by MATLAB ``rgb2gray``; every whole 96x96 block).

    Returns
    -------
    float
        Lower is better. NaN when a side is below :data:`PATCH` or no block has defined features.

    Raises
    ------
    data_schema.errors.InputError
        ``render`` is not a uint8 (H, W, 3) array.
    """
    return _niqe(check_rgb(render))


def _niqe(render: np.ndarray) -> float:
    """:func:`niqe` without the input check (the scoring core checks once per run)."""
    if _below_side(render, PATCH):
        return math.nan
    feats = _niqe_features(render)
    mu_p, cov_p = load_pristine()
    with np.errstate(invalid="ignore"):
        defined = ~np.isnan(feats)
        counts = defined.sum(axis=0)
        if not counts.all():
            return math.nan
        mu = np.where(defined, feats, 0.0).sum(axis=0) / counts  # nanmean
    whole = feats[defined.all(axis=1)]
    cov = np.cov(whole, rowvar=False) if len(whole) > 1 else np.zeros_like(cov_p)
    d = mu_p - mu
    value = float(d @ np.linalg.pinv((cov_p + cov) / 2.0) @ d)
    return math.sqrt(value) if value >= 0 else math.nan
