"""Pixel metrics against scikit-image and the published formulas."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest
from scipy.signal import convolve2d
from skimage.metrics import mean_squared_error, peak_signal_noise_ratio, structural_similarity

from nvrq import pixel_metrics as P
from nvrq.metrics import direction, metric_info

from .conftest import smooth_image


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


def test_ms_ssim_defined_only_for_big_crops_and_falls_with_noise():
    gt, r = _pair(3, 180, 200, noise=10)
    _, r2 = _pair(3, 180, 200, noise=30)
    assert P.ms_ssim(gt, gt) == pytest.approx(1.0)
    assert 0 < P.ms_ssim(gt, r2) < P.ms_ssim(gt, r) < 1
    assert math.isnan(P.ms_ssim(gt[:175], r[:175]))
    # scale 1 of MS-SSIM uses the same SSIM as ssim(): with all weight on the first scale's
    # cs it must equal scikit-image's contrast-structure mean -- checked indirectly: a
    # brightness shift leaves cs terms intact, so MS-SSIM stays far above SSIM's luminance drop.
    bright = np.clip(gt.astype(int) + 60, 0, 255).astype(np.uint8)
    assert P.ms_ssim(gt, bright) > P.ssim(gt, bright) - 1e-9


def test_registry_directions():
    assert direction("psnr") is True and direction("gmsd") is False and direction("mse") is False
    assert metric_info("ssim").fn is P.ssim and not metric_info("psnr").needs_encoder


def test_render_resized_to_gt_size_in_scoring(tiny_scene):
    # score_pairs cuts both crops and bicubic-resizes the render crop to the GT size; redo it
    # by hand with OpenCV + scikit-image for one pair whose boxes differ in size.
    from nvrq.scoring import score_pairs

    root, pairs = tiny_scene
    pairs = pairs.iloc[[4]].copy()
    pairs["r_x1"] += 7  # render box 7 px wider than the GT box
    res = score_pairs(pairs, metrics=["psnr", "ssim"], progress=False)
    row = pairs.iloc[0]
    gt_img = cv2.cvtColor(cv2.imread(str(root / row.gt_path)), cv2.COLOR_BGR2RGB)
    r_img = cv2.cvtColor(cv2.imread(str(root / row.render_path)), cv2.COLOR_BGR2RGB)
    gt = gt_img[row.gt_y0:row.gt_y1 + 1, row.gt_x0:row.gt_x1 + 1]
    rc = r_img[row.r_y0:row.r_y1 + 1, row.r_x0:row.r_x1 + 1]
    rc = cv2.resize(rc, (gt.shape[1], gt.shape[0]), interpolation=cv2.INTER_CUBIC)
    assert res.table["psnr"].iloc[0] == pytest.approx(peak_signal_noise_ratio(gt, rc, data_range=255))
    assert res.table["ssim"].iloc[0] == pytest.approx(structural_similarity(
        gt, rc, channel_axis=-1, data_range=255, gaussian_weights=True, sigma=1.5,
        use_sample_covariance=False), abs=1e-7)
