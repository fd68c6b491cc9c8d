"""``brisque``: BRISQUE (Mittal, Moorthy & Bovik 2012), no reference; lower is better.

The model is the LIVE-trained epsilon-SVR (RBF kernel) that the ``brisque`` package ships
(``brisque/models/svm.txt`` and its feature ranges ``normalize.pickle``), read from the installed
package, never copied here. The 36 features are computed exactly as that package computes the
features its model was trained on (``BRISQUE.score``), vectorised:

1. grey: scikit-image ``rgb2gray`` of the crop scaled to [0, 1] (weights
   :data:`~nvrq.metrics.no_reference._common.SKIMAGE_GREY`);
2. MSCN coefficients ``(I - mu) / (sigma + 1/255)``, ``mu`` and ``sigma`` from a 7x7 Gaussian
   window (sigma 7/6, normalised), zero padding (``scipy.signal.convolve2d(..., 'same')``),
   ``sigma = sqrt(|mu^2 - (w * I^2)|)``;
3. an asymmetric generalised Gaussian fit of the MSCN map and of its four neighbour products
   (horizontal, vertical, main and secondary diagonal; the overlapping part only): shape
   ``alpha`` solving ``Gamma(2/a)^2 / (Gamma(1/a) Gamma(3/a)) = R_hat`` (the package solves it
   with ``scipy.optimize.root``; here vectorised, to 1e-12, on [0.2, 10], the original
   release's search range, clamped there when no shape fits), left/right variances
   over ``x < 0`` / ``x >= 0`` and the mean ``(s_r - s_l) Gamma(2/a)/Gamma(1/a) sqrt(Gamma(1/a)/Gamma(3/a))``;
   features ``alpha, (s_l^2 + s_r^2)/2`` for the MSCN map, ``alpha, mean, s_l^2, s_r^2`` per product;
4. the same at half scale (``cv2.resize(fx=0.5, fy=0.5, INTER_CUBIC)``);
5. features scaled to [-1, 1] by the model's ranges; score ``sum_i c_i exp(-gamma |x - sv_i|^2) - rho``.

Rules (docs/FORMATS.md §4): the SVR output is reported as it is -- not clipped to [0, 100], so a
render far from the LIVE distortions may score below 0 or above 100. The crop is used at its own
size (no resize); NaN when its shorter side is below :data:`MIN_SIDE` (the half-scale image must
hold the 7x7 window) or when it is all black (every MSCN coefficient 0: the fit is undefined; a
uniform grey crop does get a value, its borders contrast with the zero padding). Where no shape
fits a map (e.g. two-level synthetic content; the package's solver then returns a non-converged
number) alpha is clamped to [0.2, 10], and a side of a map without values (no negative products)
has variance 0 (the package would give NaN features there), so such crops still get a value. OpenCV's
``cv2.quality.QualityBRISQUE`` is a different port (reflected borders, features of a different
training) and gives different numbers; this metric is the ``brisque`` package's.
"""

from __future__ import annotations

import math
import pickle
from functools import lru_cache

import cv2
import numpy as np
from scipy.special import digamma, gammaln

from data_schema.errors import InputError
from nvrq.metrics.no_reference._common import SKIMAGE_GREY, check_rgb, package_data

__all__ = ["brisque", "brisque_features", "load_model", "MIN_SIDE"]

#: shorter crop side (px) from which BRISQUE is defined: the half-scale crop holds 7x7
MIN_SIDE = 14
_WINDOW = 7
_SIGMA = 7.0 / 6.0
_C = 1.0 / 255.0
_ALPHA_MIN, _ALPHA_MAX = 0.2, 10.0


def _kernel() -> np.ndarray:
    y, x = np.indices((_WINDOW, _WINDOW)) - _WINDOW // 2
    k = np.exp(-(x * x + y * y) / (2.0 * _SIGMA ** 2))
    return k / k.sum()


_KERNEL = _kernel()


def _mscn(grey: np.ndarray) -> np.ndarray:
    """MSCN map (h, w) float64 of a grey image in [0, 1]: zero padding, ``C = 1/255``."""
    mu = cv2.filter2D(grey, cv2.CV_64F, _KERNEL, borderType=cv2.BORDER_CONSTANT)
    second = cv2.filter2D(grey * grey, cv2.CV_64F, _KERNEL, borderType=cv2.BORDER_CONSTANT)
    return (grey - mu) / (np.sqrt(np.abs(mu * mu - second)) + _C)


def _log_phi(alpha: np.ndarray) -> np.ndarray:
    return 2.0 * gammaln(2.0 / alpha) - gammaln(1.0 / alpha) - gammaln(3.0 / alpha)


_LOG_A = np.linspace(math.log(_ALPHA_MIN), math.log(_ALPHA_MAX), 4097)
_LOG_PHI = _log_phi(np.exp(_LOG_A))


def _solve_alpha(r: np.ndarray) -> np.ndarray:
    """``alpha`` with ``Gamma(2/a)^2 / (Gamma(1/a) Gamma(3/a)) = r`` (increasing in ``a``) on
    [0.2, 10], the original release's search range, clamped to it where ``r`` lies beyond; NaN
    where ``r`` is NaN (a flat map). A table in log alpha, interpolated, then two Newton steps
    (error below 1e-12)."""
    target = np.log(r)
    log_a = np.interp(target, _LOG_PHI, _LOG_A)  # clamps at the ends
    inside = (target > _LOG_PHI[0]) & (target < _LOG_PHI[-1])
    for _ in range(2):
        a = np.exp(log_a)
        slope = -(4 * digamma(2 / a) - digamma(1 / a) - 3 * digamma(3 / a)) / a
        log_a = np.where(inside, log_a - (_log_phi(a) - target) / slope, log_a)
    return np.where(np.isnan(r), np.nan, np.exp(log_a))


def _products(m: np.ndarray) -> list[np.ndarray]:
    """The MSCN map and its horizontal, vertical, main- and secondary-diagonal neighbour products."""
    return [m, m[:, :-1] * m[:, 1:], m[:-1, :] * m[1:, :], m[:-1, :-1] * m[1:, 1:],
            m[1:, :-1] * m[:-1, 1:]]


def _scale_features(grey: np.ndarray) -> np.ndarray:
    """The 18 features (2 for the MSCN map, 4 per product) of one scale."""
    maps = _products(_mscn(grey))
    stats = np.empty((len(maps), 5))
    for k, x in enumerate(maps):
        x2 = x * x
        neg = x < 0
        stats[k] = np.abs(x).sum(), x2.sum(), x2[neg].sum(), neg.sum(), x.size
    sum_abs, sum_sq, sum_neg_sq, n_neg, n = stats.T
    with np.errstate(invalid="ignore", divide="ignore"):
        mean_abs, mean_sq = sum_abs / n, sum_sq / n
        left_sq = sum_neg_sq / np.maximum(n_neg, 1)  # a side without values: variance 0
        right_sq = (sum_sq - sum_neg_sq) / np.maximum(n - n_neg, 1)
        gamma = np.sqrt(left_sq) / np.sqrt(right_sq)  # inf without positive values
        r_hat = mean_abs ** 2 / mean_sq
        factor = (gamma ** 3 + 1) * (gamma + 1) / (gamma ** 2 + 1) ** 2
        big_r = r_hat * np.where(np.isinf(gamma), 1.0, factor)  # its limit as gamma -> inf
    alpha = _solve_alpha(big_r)
    s_l, s_r = np.sqrt(left_sq), np.sqrt(right_sq)
    mean = (s_r - s_l) * np.exp(0.5 * (gammaln(1 / alpha) - gammaln(3 / alpha))
                                + gammaln(2 / alpha) - gammaln(1 / alpha))
    first = [alpha[0], (left_sq[0] + right_sq[0]) / 2.0]
    rest = np.stack([alpha[1:], mean[1:], left_sq[1:], right_sq[1:]], axis=1).ravel()
    return np.concatenate([first, rest])


def brisque_features(render: np.ndarray) -> np.ndarray:
    """The BRISQUE features before the model's scaling (module docstring, steps 1-4).

    Parameters
    ----------
    render : (H, W, 3) uint8
        A crop, RGB, at its own size.

    Returns
    -------
    (36,) float64
        18 at full scale, then 18 at half scale.
    """
    grey = check_rgb(render).astype(np.float64) @ (np.asarray(SKIMAGE_GREY) / 255.0)
    half = cv2.resize(grey, None, fx=0.5, fy=0.5, interpolation=cv2.INTER_CUBIC)
    return np.concatenate([_scale_features(grey), _scale_features(half)])


@lru_cache(maxsize=1)
def load_model() -> tuple[np.ndarray, np.ndarray, float, float, np.ndarray, np.ndarray]:
    """The ``brisque`` package's model (a libsvm text model and a pickle of the ranges), read once.

    Returns
    -------
    tuple
        ``(support_vectors (n, 36), coefs (n,), gamma, rho, feature_min (36,), feature_max (36,))``.

    Raises
    ------
    InputError
        When the ``brisque`` package or its model files are missing.
    """
    svm_path = package_data("brisque", "models", "svm.txt", what="its BRISQUE model")
    norm_path = package_data("brisque", "models", "normalize.pickle", what="its BRISQUE feature ranges")
    header: dict[str, str] = {}
    coefs, rows = [], []
    with open(svm_path) as f:
        for line in f:
            if line.strip() == "SV":
                break
            key, _, value = line.strip().partition(" ")
            header[key] = value
        for line in f:
            parts = line.split()
            if not parts:
                continue
            coefs.append(float(parts[0]))
            row = np.zeros(36)
            for item in parts[1:]:
                idx, _, val = item.partition(":")
                row[int(idx) - 1] = float(val)
            rows.append(row)
    if header.get("svm_type") != "epsilon_svr" or header.get("kernel_type") != "rbf":
        raise InputError(svm_path, "svm_type/kernel_type", "an epsilon_svr model with an rbf kernel",
                         f"{header.get('svm_type')}/{header.get('kernel_type')}")
    with open(norm_path, "rb") as f:
        ranges = pickle.load(f)  # the installed package's own file
    lo = np.asarray(ranges["min_"], np.float64).ravel()
    hi = np.asarray(ranges["max_"], np.float64).ravel()
    return (np.asarray(rows), np.asarray(coefs), float(header["gamma"]), float(header["rho"]), lo, hi)


def brisque(render: np.ndarray) -> float:
    """BRISQUE of the render crop at its own size (module docstring).

    Parameters
    ----------
    render : (H, W, 3) uint8
        The raw render crop (no GT: a no-reference metric).

    Returns
    -------
    float
        Lower is better; not clipped. NaN if the shorter side is below :data:`MIN_SIDE` or the
        crop is all black.

    Raises
    ------
    InputError
        Naming ``render`` unless it is a uint8 (H, W, 3) array.
    """
    if min(check_rgb(render).shape[:2]) < MIN_SIDE:
        return math.nan
    feats = brisque_features(render)
    if not np.all(np.isfinite(feats)):
        return math.nan
    sv, coefs, gamma, rho, lo, hi = load_model()
    x = -1.0 + 2.0 * (feats - lo) / (hi - lo)
    d2 = np.sum((sv - x) ** 2, axis=1)
    return float(coefs @ np.exp(-gamma * d2) - rho)
