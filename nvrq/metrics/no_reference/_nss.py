"""Natural-scene statistics shared by BRISQUE and NIQE, as the authors' MATLAB releases compute
them (LIVE, UT Austin): MATLAB's ``imresize(I, 0.5)``, the MSCN map and the table searches for
the generalised Gaussian shapes.

Convention: images are float64 (H, W) arrays with values 0-255; pixel (0, 0) is the top-left
corner; a 2-D array's rows are image rows.

- :func:`imresize_half`: MATLAB ``imresize(I, 0.5)`` of a double image, i.e. bicubic
  (Keys, a = -0.5) *with antialiasing*: the kernel is stretched to 8 input pixels
  (``0.5 * cubic(0.5 x)``), each output row of weights normalised to sum 1, borders mirrored
  (``[1 .. n, n .. 1]``, the edge pixel repeated); output size ``ceil(n / 2)``. Separable, 8
  taps per output along each axis. Neither OpenCV's ``INTER_CUBIC``/``INTER_AREA`` nor
  scikit-image's ``rescale`` is this filter.
- :func:`mscn`: ``(I - mu) / (sigma + 1)``, ``mu`` and ``sigma**2 = |w * I**2 - mu**2|`` from
  the 7x7 Gaussian of ``fspecial('gaussian', 7, 7/6)`` (normalised), correlated with zero
  padding (BRISQUE's ``filter2(w, I, 'same')``) or replicated borders (NIQE's
  ``imfilter(I, w, 'replicate')``); a coefficient below :data:`ZERO` (1e-9) in magnitude is 0
  (our one rule: where the exact value is 0 the float residue's sign is rounding).
- :func:`ggd_shape` / :func:`aggd_shape`: the shape nearest to the moment ratio in the table
  ``gam = 0.2:0.001:10`` (9801 values), as the releases' ``min(abs(...))`` / ``min((...).^2)``
  (the first on a tie; the first, 0.2, where the ratio is NaN, as MATLAB's ``min`` of an all-NaN
  vector). A binary search in the monotone table, not a scan.

>>> index, weights = _resize_taps(4)  # 4 -> 2 pixels, 8 taps each (mirrored), weights sum to 1
>>> index.tolist(), np.allclose(weights.sum(axis=1), 1.0)
([[2, 1, 0, 0, 1, 2, 3, 3], [0, 0, 1, 2, 3, 3, 2, 1]], True)
>>> imresize_half(np.full((5, 3), 7.0))   # a constant stays constant; 5 x 3 -> 3 x 2
array([[7., 7.],
       [7., 7.],
       [7., 7.]])
>>> float(aggd_shape(np.array([0.5])).item())  # Laplace, a = 1: Gamma(2)^2 / (Gamma(1) Gamma(3)) = 1/2
1.0
>>> float(ggd_shape(np.array([np.pi / 2])).item())  # Gauss, a = 2: E[x^2] / E[|x|]^2 = pi / 2
2.0
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

__all__ = ["imresize_half", "mscn", "ZERO", "ggd_shape", "aggd_shape", "aggd_stats", "aggd_from_moments",
           "moments", "circular_products", "SHAPES", "WINDOW"]

#: the shape table of both releases, ``0.2:0.001:10`` (MATLAB computes ``0.2 + k * 0.001``)
SHAPES = 0.2 + 0.001 * np.arange(9801)


@lru_cache(maxsize=1)
def _ratio_tables() -> tuple[np.ndarray, np.ndarray]:
    """``(r_aggd, neg_r_ggd)`` over :data:`SHAPES`: Gamma(2/a)^2 / (Gamma(1/a) Gamma(3/a)),
    increasing in a (AGGD), and minus its reciprocal, increasing too (GGD). Made on first use
    (SciPy's gammaln; ``nvrq --help`` imports this module but not SciPy)."""
    from scipy.special import gammaln

    log_r = 2.0 * gammaln(2.0 / SHAPES) - gammaln(1.0 / SHAPES) - gammaln(3.0 / SHAPES)
    return np.exp(log_r), -np.exp(-log_r)


def _gaussian_window() -> np.ndarray:
    """(7,) float64: the separable factor of ``fspecial('gaussian', 7, 7/6)``, sum 1 (its outer
    product is the normalised 2-D window)."""
    x = np.arange(-3, 4, dtype=np.float64)
    w = np.exp(-x * x / (2.0 * (7.0 / 6.0) ** 2))
    return w / w.sum()


#: the 1-D factor of the MSCN window (the 7x7 window is ``np.outer(WINDOW, WINDOW)``)
WINDOW = _gaussian_window()
_BORDERS = {"zero": "BORDER_CONSTANT", "replicate": "BORDER_REPLICATE"}  # OpenCV's names (imported on use)
#: MSCN coefficients smaller in magnitude are 0 (:func:`mscn`): far above double precision's
#: rounding residue where the exact value is 0, far below any value a natural image has
ZERO = 1e-9


def mscn(image: np.ndarray, *, padding: str) -> np.ndarray:
    """MSCN coefficients (H, W) float64 of a float64 grey image (H, W) with values 0-255, ``C = 1``.

    Rule (the one place where ours and the references differ): a coefficient below
    :data:`ZERO` in magnitude is 0. Where the exact value is 0 (a window of one value, the
    middle of a linear ramp) float sums leave a residue (about 1e-13 in double precision) whose
    sign is the implementation's rounding, and that sign moves the pixel and its neighbour
    products between the two sides of the AGGD fits: on images with flat or smooth areas
    (JPEG blocks, saturated or flat-shaded regions) the references' numbers depend on it.

    Parameters
    ----------
    image : (H, W) float64 array.
    padding : {'zero', 'replicate'}
        ``'zero'``: MATLAB ``filter2(w, I, 'same')`` (BRISQUE); ``'replicate'``: ``imfilter(I, w,
        'replicate')`` (NIQE).

    Returns
    -------
    (H, W) float64 array ``(I - mu) / (sigma + 1)``.
    """
    import cv2  # on first use: `nvrq score --help` lists the registry without OpenCV

    border = getattr(cv2, _BORDERS[padding])
    mu = cv2.sepFilter2D(image, cv2.CV_64F, WINDOW, WINDOW, borderType=border)
    second = cv2.sepFilter2D(image * image, cv2.CV_64F, WINDOW, WINDOW, borderType=border)
    m = (image - mu) / (np.sqrt(np.abs(second - mu * mu)) + 1.0)
    m[(m < ZERO) & (m > -ZERO)] = 0.0
    return m


def _cubic(x: np.ndarray) -> np.ndarray:
    """MATLAB ``imresize``'s bicubic kernel (Keys, a = -0.5)."""
    ax = np.abs(x)
    ax2, ax3 = ax * ax, ax * ax * ax
    return ((1.5 * ax3 - 2.5 * ax2 + 1.0) * (ax <= 1)
            + (-0.5 * ax3 + 2.5 * ax2 - 4.0 * ax + 2.0) * ((ax > 1) & (ax <= 2)))


@lru_cache(maxsize=512)
def _resize_taps(n_in: int) -> tuple[np.ndarray, np.ndarray]:
    """``(index (n_out, taps) int64, weight (n_out, taps) float64)``: MATLAB ``imresize``'s
    ``contributions`` for scale 0.5 along one axis (antialiasing; 0-based input indices, the
    mirrored borders folded in; ``n_out = ceil(n_in / 2)``), each row of weights summing to 1.
    Read-only, cached per length."""
    scale, width = 0.5, 4.0 / 0.5
    n_out = math.ceil(n_in * scale)
    u = np.arange(1, n_out + 1) / scale + 0.5 * (1.0 - 1.0 / scale)  # 1-based input coordinates
    left = np.floor(u - width / 2.0)
    ind = left[:, None] + np.arange(math.ceil(width) + 2)[None, :]
    weights = scale * _cubic(scale * (u[:, None] - ind))
    weights /= weights.sum(axis=1, keepdims=True)
    mirror = np.concatenate([np.arange(n_in), np.arange(n_in)[::-1]])
    index = mirror[np.mod(ind.astype(np.int64) - 1, 2 * n_in)]
    used = (weights != 0).any(axis=0)  # MATLAB drops all-zero columns (here the two outer taps)
    index, weights = index[:, used], weights[:, used]
    for arr in (index, weights):
        arr.flags.writeable = False
    return index, weights


def imresize_half(image: np.ndarray) -> np.ndarray:
    """MATLAB ``imresize(image, 0.5)`` of a float64 (H, W) image -> (ceil(H/2), ceil(W/2)) float64
    (bicubic with antialiasing, not rounded; module docstring): rows, then columns (MATLAB's
    order), each output the weighted sum of its 8 taps (in tap order, the same on every
    machine: no BLAS).

    Parameters
    ----------
    image : (H, W) float64 ndarray
        The image to halve.

    Returns
    -------
    (ceil(H/2), ceil(W/2)) float64 ndarray
        The resized image, not rounded.
    """
    rows, wr = _resize_taps(image.shape[0])
    half = np.einsum("ot,otw->ow", wr, image[rows])
    cols, wc = _resize_taps(image.shape[1])
    return np.einsum("ot,hot->ho", wc, half[:, cols])


def _nearest(table: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Index of the entry of the increasing ``table`` nearest to each ``q`` (the lower on a tie;
    0 where ``q`` is NaN)."""
    hi = np.searchsorted(table, q)
    np.minimum(np.maximum(hi, 1, out=hi), len(table) - 1, out=hi)
    lower = np.abs(q - table[hi - 1]) <= np.abs(table[hi] - q)
    idx = hi - lower
    idx[np.isnan(q)] = 0
    return idx


def ggd_shape(rho: np.ndarray) -> np.ndarray:
    """GGD shape (BRISQUE's ``estimateggdparam``): the table shape whose
    ``Gamma(1/a) Gamma(3/a) / Gamma(2/a)^2`` is nearest to ``rho = E[x^2] / E[|x|]^2``.

    Parameters
    ----------
    rho : float or ndarray
        The moment ratio(s) ``E[x^2] / E[|x|]^2``.

    Returns
    -------
    ndarray
        The GGD shape of each ratio, same shape as ``rho``.
    """
    return SHAPES[_nearest(_ratio_tables()[1], -np.asarray(rho, np.float64))]


def aggd_shape(r_norm: np.ndarray) -> np.ndarray:
    """AGGD shape (``estimateaggdparam``): the table shape whose ``Gamma(2/a)^2 / (Gamma(1/a)
    Gamma(3/a))`` is nearest to the normalised moment ratio ``r_norm``.

    Parameters
    ----------
    r_norm : float or ndarray
        The normalised moment ratio(s).

    Returns
    -------
    ndarray
        The AGGD shape of each ratio, same shape as ``r_norm``.
    """
    return SHAPES[_nearest(_ratio_tables()[0], np.asarray(r_norm, np.float64))]


def _axis_parts(n: int, d: int) -> list[tuple[slice, slice]]:
    """``(target, source)`` slices of one axis of length ``n`` for ``np.roll(a, d)[target] =
    a[source]``, ``d`` in {-1, 0, 1}."""
    if d == 0:
        return [(slice(None), slice(None))]
    if d == 1:
        return [(slice(1, None), slice(None, -1)), (slice(0, 1), slice(n - 1, n))]
    return [(slice(None, -1), slice(1, None)), (slice(n - 1, n), slice(0, 1))]


def circular_products(m: np.ndarray, shifts) -> np.ndarray:
    """``(len(shifts) + 1, N)`` float64: the maps ``m`` (..., h, w) and ``m * circshift(m, s)`` for
    each shift ``s = (dy, dx)``, ``|dy|, |dx| <= 1``, shifting the last two axes (MATLAB
    ``circshift``, ``np.roll``), each raveled; written slice by slice, no rolled copies.

    Parameters
    ----------
    m : (..., h, w) float ndarray
        The maps.
    shifts : sequence of (int, int)
        The shifts ``(dy, dx)``, each in {-1, 0, 1}.

    Returns
    -------
    (len(shifts) + 1, N) float64 ndarray
        ``m`` raveled, then each product with its shifted copy raveled (N = ``m.size``).
    """
    h, w = m.shape[-2:]
    out = np.empty((len(shifts) + 1, *m.shape))
    out[0] = m
    for k, (dy, dx) in enumerate(shifts, start=1):
        for ty, sy in _axis_parts(h, dy):
            for tx, sx in _axis_parts(w, dx):
                np.multiply(m[..., ty, tx], m[..., sy, sx], out=out[k][..., ty, tx])
    return out.reshape(len(shifts) + 1, -1)


def moments(x: np.ndarray) -> tuple[np.ndarray, ...]:
    """``(mean_sq, mean_abs, left_sq, right_sq)``, each (n,), of every row of ``x`` (n, m):
    ``mean(x^2)``, ``mean(|x|)`` and the mean squares over ``x < 0`` / ``x > 0`` (MATLAB's
    ``vec(vec < 0)``, ``vec(vec > 0)``: zeros on neither side; NaN for an empty side).

    Parameters
    ----------
    x : (n, m) float64 ndarray
        The rows, each reduced on its own (exact zeros count on neither side).

    Returns
    -------
    tuple of four (n,) float64 ndarrays
        ``(mean_sq, mean_abs, left_sq, right_sq)``.
    """
    m = x.shape[1]
    neg = np.minimum(x, 0.0)
    neg_sq = np.einsum("ij,ij->i", neg, neg)
    sum_sq = np.einsum("ij,ij->i", x, x)
    n_neg = np.count_nonzero(neg, axis=1)
    n_pos = np.count_nonzero(x, axis=1) - n_neg
    sum_abs = x.sum(axis=1) - 2.0 * neg.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return sum_sq / m, sum_abs / m, neg_sq / n_neg, (sum_sq - neg_sq) / n_pos


def aggd_stats(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(alpha, left_std, right_std)``, each (n,), of ``estimateaggdparam`` for every row of
    ``x`` (n, m): ``left_std = sqrt(mean(x[x < 0]^2))``, ``right_std`` over ``x > 0`` (NaN for an
    empty side, as MATLAB's mean of nothing), ``gammahat = left/right``,
    ``rhat = mean(|x|)^2 / mean(x^2)``, ``rhatnorm = rhat (g^3 + 1)(g + 1) / (g^2 + 1)^2`` and
    ``alpha = aggd_shape(rhatnorm)``.

    Parameters
    ----------
    x : (n, m) float64 ndarray
        ``n`` samples of ``m`` coefficients each (e.g. MSCN products), fitted row by row.

    Returns
    -------
    tuple of three (n,) float64 ndarrays
        ``(alpha, left_std, right_std)``: the AGGD shape and the two side deviations.
    """
    return aggd_from_moments(*moments(x))


def aggd_from_moments(mean_sq, mean_abs, left_sq, right_sq) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`aggd_stats` from the :func:`moments` of the rows.

    Parameters
    ----------
    mean_sq, mean_abs : (n,) float64 ndarray
        ``mean(x^2)`` and ``mean(|x|)`` of each row.
    left_sq, right_sq : (n,) float64 ndarray
        Mean squares over ``x < 0`` and ``x > 0`` of each row (NaN for an empty side).

    Returns
    -------
    tuple of three (n,) float64 ndarrays
        ``(alpha, left_std, right_std)``.
    """
    with np.errstate(invalid="ignore", divide="ignore"):
        left, right = np.sqrt(left_sq), np.sqrt(right_sq)
        g = left / right
        r_norm = mean_abs ** 2 / mean_sq * (g ** 3 + 1) * (g + 1) / (g ** 2 + 1) ** 2
    return aggd_shape(r_norm), left, right
