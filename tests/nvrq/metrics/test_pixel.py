"""Pixel metrics against scikit-image and the published formulas."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.signal import convolve2d
from skimage.metrics import mean_squared_error, peak_signal_noise_ratio, structural_similarity
from skimage.transform import downscale_local_mean

from nvrq.metrics import column_info, direction
from nvrq.metrics import pixel as P

from ..conftest import smooth_image


def _pair(seed, h, w, noise=12.0):
    rng = np.random.default_rng(seed)
    gt = smooth_image(rng, h, w)
    r = np.clip(gt + rng.normal(0, noise, gt.shape), 0, 255).astype(np.uint8)
    return gt, r


@pytest.mark.parametrize("shape", [(11, 11), (31, 47), (64, 40)])
def test_psnr_ssim_mse_equal_scikit_image(shape):
    gt, r = _pair(0, *shape)
    assert P.psnr(gt, r) == pytest.approx(peak_signal_noise_ratio(gt, r, data_range=255), abs=1e-9)
    ref = structural_similarity(gt, r, channel_axis=-1, data_range=255, gaussian_weights=True,
                                sigma=1.5, use_sample_covariance=False)
    assert P.ssim(gt, r) == pytest.approx(ref, abs=1e-7)
    assert P.mse(gt, r) == pytest.approx(mean_squared_error(gt, r), abs=1e-9)
    assert P.mae(gt, r) == pytest.approx(np.abs(gt.astype(float) - r).mean())


def test_identical_and_degenerate_crops():
    gt, _ = _pair(1, 40, 40)
    assert P.psnr(gt, gt) == math.inf and P.ssim(gt, gt) == pytest.approx(1.0)
    assert P.gmsd(gt, gt) == 0.0
    assert math.isnan(P.ssim(gt[:10], gt[:10]))  # shorter side < 11: window does not fit


def test_gmsd_matches_matlab_reference_formula():
    # Xue et al. 2014 GMSD.m, re-derived with SciPy's convolve2d. MATLAB's conv2(..., 'same')
    # keeps full-convolution rows/cols ceil((k-1)/2) onwards: for the 2x2 mean that is
    # full[1:, 1:] (SciPy's 'same' would start at 0); for the 3x3 Prewitt both agree.
    gt, r = _pair(2, 45, 58, noise=20)

    def ref(a, b):
        y1 = a.astype(float) @ [0.299, 0.587, 0.114]
        y2 = b.astype(float) @ [0.299, 0.587, 0.114]
        ave = np.ones((2, 2)) / 4
        y1 = convolve2d(y1, ave, mode="full")[1:, 1:][::2, ::2]
        y2 = convolve2d(y2, ave, mode="full")[1:, 1:][::2, ::2]
        dx = np.array([[1, 0, -1]] * 3) / 3
        g1 = np.hypot(convolve2d(y1, dx, mode="same"), convolve2d(y1, dx.T, mode="same"))
        g2 = np.hypot(convolve2d(y2, dx, mode="same"), convolve2d(y2, dx.T, mode="same"))
        q = (2 * g1 * g2 + 170) / (g1 ** 2 + g2 ** 2 + 170)
        return np.std(q, ddof=1)  # MATLAB std2

    assert P.gmsd(gt, r) == pytest.approx(ref(gt, r), rel=1e-9)
    assert P.gmsd(gt, r) > P.gmsd(gt, _pair(2, 45, 58, noise=5)[1])


def _ssim_means_skimage(x: np.ndarray, y: np.ndarray, *, contrast_only: bool) -> float:
    """scikit-image's mean SSIM of one channel (float64, data range 255); ``contrast_only``
    makes K1 so large that the luminance term is 1 to ~1e-12, leaving the mean of c*s."""
    return structural_similarity(x, y, data_range=255, gaussian_weights=True, sigma=1.5,
                                 use_sample_covariance=False, K1=1e6 if contrast_only else 0.01)


def _ms_ssim_reference(gt: np.ndarray, r: np.ndarray, n_scales: int) -> float:
    """Wang et al. 2003, eq. 7, composed from scikit-image SSIM per scale and channel, with
    scikit-image's 2x2 block mean as the downsampling (odd last row/column dropped first)."""
    w = np.array([0.0448, 0.2856, 0.3001, 0.2363, 0.1333])  # the paper's weights
    w_m = w[:n_scales] * w.sum() / w[:n_scales].sum()
    per_channel = []
    for c in range(3):
        x, y = gt[..., c].astype(np.float64), r[..., c].astype(np.float64)
        value = 1.0
        for j in range(n_scales):
            last = j == n_scales - 1
            term = _ssim_means_skimage(x, y, contrast_only=not last)
            value *= max(term, 0.0) ** w_m[j]
            h, wd = (x.shape[0] // 2) * 2, (x.shape[1] // 2) * 2
            x, y = downscale_local_mean(x[:h, :wd], (2, 2)), downscale_local_mean(y[:h, :wd], (2, 2))
        per_channel.append(value)
    return float(np.mean(per_channel))


@pytest.mark.parametrize(("shape", "n_scales"), [
    ((180, 200), 5),   # large: the original 5-scale MS-SSIM
    ((30, 41), 2),     # the smallest pair crop (min side 30): two scales
    ((60, 90), 3),
    ((100, 120), 4),
    ((15, 20), 1),     # one scale: plain SSIM
])
def test_ms_ssim_equals_scikit_image_ssim_composed_per_scale(shape, n_scales):
    gt, r = _pair(3, *shape, noise=10)
    assert P.ms_ssim_scales(min(shape)) == n_scales
    assert P.ms_ssim(gt, r) == pytest.approx(_ms_ssim_reference(gt, r, n_scales), rel=1e-9)


def test_ms_ssim_of_constant_crops_is_the_coarsest_luminance_term_hand_worked():
    # constant crops have zero variance, so every c*s term is c2/c2 = 1 and MS-SSIM is the
    # luminance term l = (2*100*120 + c1) / (100^2 + 120^2 + c1), c1 = (0.01*255)^2 = 6.5025,
    # = 24006.5025 / 24406.5025 = 0.98361092..., raised to the last scale's weight:
    # 30 px -> 2 scales, weight 0.2856 * 1.0001 / (0.0448 + 0.2856) = 0.86449322;
    # 200 px -> 5 scales, weight 0.1333 (the published one).
    l_term = 24006.5025 / 24406.5025
    for side, weight in ((30, 0.2856 * 1.0001 / 0.3304), (200, 0.1333)):
        gt = np.full((side, side, 3), 100, np.uint8)
        r = np.full((side, side, 3), 120, np.uint8)
        assert P.ms_ssim(gt, r) == pytest.approx(l_term**weight, rel=1e-12)


def test_ms_ssim_is_defined_from_11_px_and_falls_with_noise():
    gt, r = _pair(3, 40, 52, noise=10)
    _, r2 = _pair(3, 40, 52, noise=30)
    assert P.ms_ssim(gt, gt) == pytest.approx(1.0)
    assert 0 < P.ms_ssim(gt, r2) < P.ms_ssim(gt, r) < 1
    assert np.isfinite(P.ms_ssim(gt[:11, :11], r[:11, :11]))
    assert math.isnan(P.ms_ssim(gt[:10], r[:10]))


def test_registry_directions():
    assert direction("psnr") is True and direction("gmsd") is False and direction("mse") is False
    assert column_info("ssim").fn is P.ssim and not column_info("psnr").needs_encoder
