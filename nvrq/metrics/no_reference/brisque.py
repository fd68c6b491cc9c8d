"""``brisque``: BRISQUE (Mittal, Moorthy & Bovik 2012), no reference; lower is better.

The model is the original release's (LIVE, UT Austin, ``BRISQUE_release.zip``): ``allmodel``, an
epsilon-SVR with an RBF kernel (gamma 0.05, rho -153.591, 774 support vectors) trained on the
whole LIVE database, and its feature range table ``allrange``; both shipped here as
``models/brisque_allmodel.npz`` (provenance in ``models/SOURCES.md``, LIVE's notice in
``models/LICENSE-LIVE.txt``). The 36 features are computed as the release's ``brisquescore.m`` /
``brisque_feature.m`` compute them, vectorised (helpers in :mod:`nvrq.metrics.no_reference._nss`):

1. grey: MATLAB ``rgb2gray`` of the uint8 crop (:func:`~nvrq.metrics.no_reference._common.rgb2gray_matlab`),
   as double, values 0-255 (the release's input; the luma of ``rgb2ycbcr`` gives other numbers);
2. MSCN ``(I - mu) / (sigma + 1)``, 7x7 Gaussian (sigma 7/6), zero padding
   (``filter2(w, I, 'same')``);
3. ``alpha, sigma^2`` of a generalised Gaussian fit of the MSCN map: ``alpha`` the shape in
   ``0.2:0.001:10`` whose ``Gamma(1/a) Gamma(3/a) / Gamma(2/a)^2`` is nearest to
   ``E[x^2] / E[|x|]^2``, ``sigma^2 = E[x^2]``;
4. per neighbour product of the MSCN map with itself circularly shifted by (0, 1), (1, 0),
   (1, 1) and (-1, 1) (``circshift``), an asymmetric generalised Gaussian fit: ``alpha`` by the
   same table search on the normalised moment ratio, ``sigma_l^2`` / ``sigma_r^2`` the mean
   squares of the negative / positive products, ``eta = (sigma_r - sigma_l) Gamma(2/a) /
   sqrt(Gamma(1/a) Gamma(3/a))``; features ``alpha, eta, sigma_l^2, sigma_r^2``;
5. the same 18 at half scale, MATLAB ``imresize(I, 0.5)`` (bicubic with antialiasing);
6. each feature scaled to [-1, 1] by ``allrange`` (``svm-scale``); score
   ``sum_i c_i exp(-gamma |x_i - x|^2) - rho`` (``svm-predict``; no libsvm needed).

Rules (docs/FORMATS.md §4): the SVR output as it is, not clipped to [0, 100] (a render far from
the LIVE distortions may leave it). The crop is used at its own size; NaN when its shorter side is
below :data:`MIN_SIDE` (our rule: the half-scale crop must hold the 7x7 window) or where a feature
is undefined as in the release (a neighbour-product map with no negative or no positive value:
MATLAB's mean of nothing; e.g. two-level stripes). An MSCN coefficient below 1e-9 in magnitude is 0
(:func:`nvrq.metrics.no_reference._nss.mscn`: where its exact value is 0, a flat window or the middle of
a ramp, the references' float residue has the sign of their rounding).

>>> import numpy as np
>>> rng = np.random.default_rng(0)
>>> noise = rng.integers(0, 256, (64, 64, 3), dtype=np.uint8)   # white noise: far from natural
>>> round(brisque(noise), 3) > 60
True
"""

from __future__ import annotations

import math
from functools import lru_cache
from pathlib import Path

import numpy as np

from nvrq.metrics.no_reference._common import _below_side, _rgb2gray, check_rgb
from nvrq.metrics.no_reference._nss import (
    aggd_from_moments,
    circular_products,
    ggd_shape,
    imresize_half,
    moments,
    mscn,
)

__all__ = ["brisque", "brisque_features", "load_model", "MIN_SIDE", "MODEL_PATH"]

#: shorter crop side (px) from which BRISQUE is defined (ours): the half-scale crop holds 7x7
MIN_SIDE = 14
#: the original release's model and feature ranges (models/SOURCES.md)
MODEL_PATH = Path(__file__).resolve().parent / "models" / "brisque_allmodel.npz"
_SHIFTS = ((0, 1), (1, 0), (1, 1), (-1, 1))


def _scale_features(grey: np.ndarray) -> np.ndarray:
    """The 18 features (18,) of one scale of a float64 grey image (H, W) with values 0-255."""
    from scipy.special import gammaln  # on first use: `nvrq --help` imports this module

    maps = circular_products(mscn(grey, padding="zero"), _SHIFTS)  # the MSCN map, its 4 products
    mean_sq, mean_abs, left_sq, right_sq = moments(maps)
    with np.errstate(invalid="ignore", divide="ignore"):
        alpha0 = ggd_shape(mean_sq[:1] / mean_abs[:1] ** 2)[0]  # NaN (all 0): the first, 0.2
    alpha, left, right = aggd_from_moments(mean_sq[1:], mean_abs[1:], left_sq[1:], right_sq[1:])
    eta = (right - left) * np.exp(gammaln(2.0 / alpha) - 0.5 * (gammaln(1.0 / alpha) + gammaln(3.0 / alpha)))
    out = np.empty(18)
    out[0], out[1] = alpha0, mean_sq[0]
    out[2::4], out[3::4], out[4::4], out[5::4] = alpha, eta, left_sq[1:], right_sq[1:]
    return out


def brisque_features(render: np.ndarray) -> np.ndarray:
    """The 36 unscaled BRISQUE features of a crop (module docstring).

    Parameters
    ----------
    render : (H, W, 3) uint8 RGB array
        The crop at its own size (MATLAB ``rgb2gray``, rounded, as the release takes it; not the luma of ``rgb2ycbcr``).

    Returns
    -------
    (36,) float64 array
        18 features at full scale, then 18 at half scale (MATLAB ``imresize(0.5)``); NaN where
        undefined.
    """
    return _brisque_features(check_rgb(render))


def _brisque_features(render: np.ndarray) -> np.ndarray:
    """:func:`brisque_features` without the input check."""
    grey = _rgb2gray(render).astype(np.float64)
    return np.concatenate([_scale_features(grey), _scale_features(imresize_half(grey))])


@lru_cache(maxsize=1)
def load_model() -> tuple[np.ndarray, np.ndarray, float, float, np.ndarray, np.ndarray]:
    """``(support_vectors (774, 36), coefs (774,), gamma, rho, feature_min (36,), feature_max
    (36,))`` of the original release's ``allmodel`` / ``allrange`` (:data:`MODEL_PATH`).

    Returns
    -------
    tuple
        ``(support_vectors, coefs, gamma, rho, feature_min, feature_max)``: (774, 36) and
        (774,) arrays, two floats, two (36,) arrays.
    """
    with np.load(MODEL_PATH) as z:
        return (z["support_vectors"], z["coefs"], float(z["gamma"]), float(z["rho"]),
                z["feature_min"], z["feature_max"])


def brisque(render: np.ndarray) -> float:
    """BRISQUE of a uint8 (H, W, 3) RGB crop at its own size.

    Parameters
    ----------
    render : (H, W, 3) uint8 RGB array.

    Returns
    -------
    float
        The SVR score, lower is better, not clipped; NaN if the shorter side is below
        :data:`MIN_SIDE` or a feature is undefined (module docstring).

    Raises
    ------
    data_schema.errors.InputError
        From :func:`~nvrq.metrics.no_reference._common.check_rgb`.
    """
    return _brisque(check_rgb(render))


def _brisque(render: np.ndarray) -> float:
    """:func:`brisque` without the input check (the scoring core checks once per run)."""
    if _below_side(render, MIN_SIDE):
        return math.nan
    feats = _brisque_features(render)
    if not np.all(np.isfinite(feats)):
        return math.nan
    sv, coefs, gamma, rho, lo, hi = load_model()
    x = -1.0 + 2.0 * (feats - lo) / (hi - lo)
    d2 = np.einsum("ij,ij->i", sv - x, sv - x)  # |x_i - x|^2 per support vector
    return float(coefs @ np.exp(-gamma * d2) - rho)
