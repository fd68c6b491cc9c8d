"""No-reference metrics (nvrq.metrics.no_reference) against independent numbers: the packages whose models
they use (run here), values a MATLAB port gives, scikit-image, OpenCV's BRISQUE port and
straightforward per-patch loops written from the papers."""

from __future__ import annotations

import math
import warnings

import cv2
import numpy as np
import pytest
import scipy.ndimage
import scipy.special
import skimage.color
import skimage.data
import skimage.measure
from PIL import Image

from nvrq.metrics.no_reference import brisque, entropy, niqe, piqe
from nvrq.metrics.no_reference._common import SKVIDEO_GREY, rgb2gray_matlab
from nvrq.metrics.no_reference.brisque import brisque_features
from nvrq.metrics.no_reference.niqe import load_pristine, niqe_features
from nvrq.metrics.no_reference.piqe import piqe_blocks


@pytest.fixture(scope="module")
def chelsea():
    return skimage.data.chelsea()  # (300, 451, 3) uint8, shipped by scikit-image


@pytest.fixture(scope="module")
def coffee():
    return skimage.data.coffee()  # (400, 600, 3)


def noisy(img, sigma, seed=0):
    rng = np.random.default_rng(seed)
    return np.clip(img + rng.normal(0, sigma, img.shape), 0, 255).astype(np.uint8)


# --- entropy ---------------------------------------------------------------------------------

def test_entropy_hand_worked_and_against_scikit_image(chelsea):
    # 4 pixels of levels 0, 0, 0, 255: p = (3/4, 1/4); -(3/4 log2 3/4 + 1/4 log2 1/4) = 0.811278...
    px = np.zeros((2, 2, 3), np.uint8)
    px[1, 1] = 255
    assert entropy(px) == pytest.approx(-(0.75 * math.log2(0.75) + 0.25 * math.log2(0.25)), abs=1e-12)
    assert entropy(np.full((5, 7, 3), 40, np.uint8)) == 0.0  # one level: 0 bits, never -0.0
    grey = rgb2gray_matlab(chelsea)
    # scikit-image's Shannon entropy counts each distinct value of the grey image (base 2)
    assert entropy(chelsea) == pytest.approx(skimage.measure.shannon_entropy(grey, base=2), abs=1e-12)


def test_matlab_rgb2gray_weights():
    # MATLAB documents rgb2gray as 0.298936021293775 R + 0.587043074451121 G + 0.114020904255103 B,
    # rounded: (200, 100, 50) -> 59.787 + 58.704 + 5.701 = 124.19 -> 124
    assert rgb2gray_matlab(np.array([[[200, 100, 50]]], np.uint8)).tolist() == [[124]]


# --- BRISQUE ---------------------------------------------------------------------------------

def _brisque_package_score(img):
    """The ``brisque`` package's own score of an RGB uint8 image: its feature code, its libsvm
    prediction. (Its ``BRISQUE.score`` stops on NumPy 2 when it converts its (1,)-shaped features
    to float; the same steps are run here with the features flattened first.)"""
    from brisque import BRISQUE

    b = BRISQUE(url=False)
    gray = skimage.color.rgb2gray(img)
    half = cv2.resize(gray, None, fx=0.5, fy=0.5, interpolation=cv2.INTER_CUBIC)
    feats = [b.calculate_brisque_features(g, kernel_size=7, sigma=7 / 6) for g in (gray, half)]
    flat = np.array([float(np.ravel(v)[0]) for v in np.concatenate(feats)])
    return b.calculate_image_quality_score(flat), flat


@pytest.mark.parametrize("name,crop", [("chelsea", None), ("coffee", None), ("chelsea", (60, 140, 90, 200)),
                                       ("coffee", (100, 172, 250, 313))])
def test_brisque_equals_the_brisque_package(name, crop, request):
    img = request.getfixturevalue(name)
    if crop is not None:  # a raw object-sized rectangle (y0, y1, x0, x1)
        img = np.ascontiguousarray(img[crop[0]:crop[1], crop[2]:crop[3]])
    want, want_feats = _brisque_package_score(img)
    # features to 1e-6 relative: the package solves the AGGD shape with scipy.optimize.root
    np.testing.assert_allclose(brisque_features(img), want_feats, rtol=1e-6, atol=1e-9)
    assert brisque(img) == pytest.approx(want, rel=1e-6, abs=1e-6)


def test_brisque_ranks_distortion_and_is_not_clipped(chelsea):
    clean = brisque(chelsea)
    assert clean == pytest.approx(2.870766629424878, rel=1e-6)  # the package on chelsea (above)
    assert brisque(noisy(chelsea, 20)) > clean + 10
    blurred = cv2.GaussianBlur(chelsea, (0, 0), 3)
    assert brisque(blurred) > clean + 10


def test_brisque_features_agree_with_opencvs_port(coffee):
    # OpenCV's cv2.quality BRISQUE is an independent C++ port (reflected borders, zero-filled
    # neighbour shifts, its own grey and shape search): on a natural photograph its shape
    # parameters (alpha of the MSCN map and of the 4 products, both scales) agree within 3 %
    # and the MSCN variances within 3 %; the small mean features differ more, by construction.
    ours = brisque_features(coffee)
    cvf = np.ravel(cv2.quality.QualityBRISQUE_computeFeatures(cv2.cvtColor(coffee, cv2.COLOR_RGB2BGR)))
    shapes = [0, 2, 6, 10, 14, 18, 20, 24, 28, 32]
    np.testing.assert_allclose(ours[shapes], cvf[shapes], rtol=0.03)
    np.testing.assert_allclose(ours[[1, 19]], cvf[[1, 19]], rtol=0.03)


def test_brisque_small_and_flat_crops_are_nan_never_errors():
    assert math.isnan(brisque(np.full((13, 40, 3), 7, np.uint8)))  # shorter side < 14
    assert math.isnan(brisque(np.zeros((40, 40, 3), np.uint8)))  # all black: MSCN all 0, no fit
    # a uniform grey crop is not flat for BRISQUE: the zero padding makes its borders contrast
    assert np.isfinite(brisque(np.full((40, 40, 3), 7, np.uint8)))
    two_level = np.zeros((40, 40, 3), np.uint8)
    two_level[:, ::2] = 200  # stripes: no AGGD shape fits, no negative vertical products: finite
    assert np.isfinite(brisque(two_level))


# --- NIQE ------------------------------------------------------------------------------------

def _niqe_loop(img_rgb):
    """NIQE written out per patch from Mittal et al. 2013 with scikit-video's conventions (its
    model's): grey, 96-px patches, half scale, MSCN, AGGD by table search, pinv distance."""
    grey = (img_rgb.astype(np.float64) @ np.array(SKVIDEO_GREY)).astype(np.float32)
    h, w = (s - s % 96 for s in grey.shape)
    grey = np.ascontiguousarray(grey[:h, :w])
    half = np.asarray(Image.fromarray(grey).resize((w // 2, h // 2), Image.Resampling.BICUBIC), np.float32)
    gam = np.arange(0.2, 10, 0.001)
    table = scipy.special.gamma(2 / gam) ** 2 / (scipy.special.gamma(1 / gam) * scipy.special.gamma(3 / gam))
    win = np.exp(-0.5 * np.arange(-3, 4) ** 2 / np.float32(np.float32(7 / 6) ** 2))
    win /= win.sum()

    def mscn(x):
        blur = lambda y: scipy.ndimage.correlate1d(scipy.ndimage.correlate1d(y, win, 0, mode="constant"),  # noqa: E731
                                                   win, 1, mode="constant")
        mu = blur(x)
        return ((x - mu) / (np.sqrt(np.abs(blur(x * x) - mu * mu)) + 1)).astype(np.float32)

    def aggd(x):
        x = x.ravel().astype(np.float64)
        left = math.sqrt(np.mean(x[x < 0] ** 2))
        right = math.sqrt(np.mean(x[x >= 0] ** 2))
        g = left / right
        r = np.mean(np.abs(x)) ** 2 / np.mean(x * x) * (g ** 3 + 1) * (g + 1) / (g ** 2 + 1) ** 2
        a = gam[np.argmin((table - r) ** 2)]
        k = math.sqrt(math.gamma(1 / a) / math.gamma(3 / a))
        return a, (k * right - k * left) * math.gamma(2 / a) / math.gamma(1 / a), k * left, k * right

    rows = []
    m1, m2 = mscn(grey), mscn(half)
    for i in range(0, h, 96):
        for j in range(0, w, 96):
            row = []
            for m in (m1[i:i + 96, j:j + 96], m2[i // 2:i // 2 + 48, j // 2:j // 2 + 48]):
                a, _, bl, br = aggd(m)
                row += [a, (bl + br) / 2]
                for k, shifted in enumerate([np.roll(m, 1, 1), np.roll(m, 1, 0), np.roll(np.roll(m, 1, 0), 1, 1),
                                             np.roll(np.roll(m, 1, 0), -1, 1)]):
                    a, n, bl, br = aggd(shifted * m)
                    row += [a, n, bl, br if k < 2 else bl]
            rows.append(row)
    feats = np.array(rows)
    mu_p, cov_p = load_pristine()
    d = feats.mean(0) - mu_p
    cov = (cov_p + np.cov(feats.T)) / 2
    return math.sqrt(d @ np.linalg.pinv(cov) @ d), feats


def test_niqe_equals_a_per_patch_loop(chelsea):
    crop = np.ascontiguousarray(chelsea[:200, 50:350])  # 2 x 3 patches
    want, want_feats = _niqe_loop(crop)
    np.testing.assert_allclose(niqe_features(crop), want_feats, rtol=1e-4, atol=1e-5)
    assert niqe(crop) == pytest.approx(want, rel=1e-4)


def test_niqe_equals_scikit_videos_own_function(coffee, monkeypatch):
    # scikit-video's niqe() itself, with the two APIs it uses that NumPy 2 / SciPy removed put back
    # (np.int; scipy.misc.imresize(img, 0.5, 'bicubic', mode='F') was PIL's bicubic resize)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # scipy.misc is deprecated
        import scipy.misc

    def imresize(arr, size, interp="bicubic", mode=None):
        im = Image.fromarray(np.asarray(arr, np.float32))
        return np.asarray(im.resize(tuple((np.array(im.size) * size).astype(int)), Image.Resampling.BICUBIC),
                          np.float32)

    monkeypatch.setattr(np, "int", int, raising=False)
    monkeypatch.setattr(scipy.misc, "imresize", imresize, raising=False)
    from skvideo.measure import niqe as skvideo_niqe

    grey = (coffee.astype(np.float64) @ np.array(SKVIDEO_GREY)).astype(np.float32)
    assert niqe(coffee) == pytest.approx(float(skvideo_niqe(grey)[0]), rel=1e-3)


def test_niqe_rules_small_crops_single_patch_and_determinism(chelsea):
    assert math.isnan(niqe(np.ascontiguousarray(chelsea[:95, :300])))  # no whole 96x96 patch
    one = np.ascontiguousarray(chelsea[100:196, 100:196])
    v = niqe(one)
    assert np.isfinite(v) and niqe(one) == v  # one patch: crop covariance 0; same number each run
    assert niqe(noisy(chelsea, 25)) > niqe(chelsea)


# --- PIQE ------------------------------------------------------------------------------------

def _piqe_loop(img_rgb):
    """PIQE block by block (Venkatanath et al. 2015, steps as MATLAB's piqe)."""
    g = rgb2gray_matlab(img_rgb).astype(np.float64)
    h, w = g.shape
    g = np.pad(g, ((0, -h % 16), (0, -w % 16)), mode="symmetric")
    g = np.round(255 * g / g.max())
    mu = cv2.GaussianBlur(g, (7, 7), 7 / 6, borderType=cv2.BORDER_REPLICATE)
    sd = np.sqrt(np.abs(cv2.GaussianBlur(g * g, (7, 7), 7 / 6, borderType=cv2.BORDER_REPLICATE) - mu * mu))
    m = (g - mu) / (sd + 1)
    total, active = 0.0, 0
    for i in range(0, m.shape[0], 16):
        for j in range(0, m.shape[1], 16):
            b = m[i:i + 16, j:j + 16]
            v = np.var(b, ddof=1)
            if v <= 0.1:
                continue
            active += 1
            edges = [b[0], b[:, 15], b[15], b[:, 0]]
            art = any(np.std(e[k:k + 6], ddof=1) < 0.1 for e in edges for k in range(11))
            centre = np.concatenate([b[:, 7], b[:, 8]])
            surround = np.delete(np.delete(b, 7, axis=1), 8, axis=1)  # MATLAB deletes col 8, then col 9 of the rest
            r = np.std(centre, ddof=1) / np.std(surround, ddof=1)
            r = 0.0 if np.isnan(r) else r
            s = math.sqrt(v)
            beta = abs(s - r) / max(s, r)
            total += art * (1 - v) + (s > 2 * beta) * v
    return 100 * (total + 1) / (active + 1)


def test_piqe_values_of_a_matlab_port(chelsea, coffee):
    # pypiqe 1.2 (a line-by-line Python port of MATLAB's piqe) run once on the MATLAB-rgb2gray
    # grey images gave these values (its cv2 colour conversion bypassed by passing grey)
    assert piqe(chelsea) == pytest.approx(34.016980728125205, rel=1e-9)
    assert piqe(coffee) == pytest.approx(27.719668321593144, rel=1e-9)
    crop = np.ascontiguousarray(chelsea[17:92, 33:94])  # 75 x 61: padded to 80 x 64
    assert piqe(crop) == pytest.approx(18.995812805046963, rel=1e-9)


def test_piqe_equals_a_block_loop(coffee):
    for img in (np.ascontiguousarray(coffee[50:133, 80:190]), noisy(coffee[:160, :200], 30)):
        assert piqe(img) == pytest.approx(_piqe_loop(img), rel=1e-12)


def test_piqe_uniform_is_100_and_small_is_nan():
    assert piqe(np.full((40, 50, 3), 90, np.uint8)) == 100.0  # MATLAB: uniform image -> 100
    assert piqe(np.zeros((40, 50, 3), np.uint8)) == 100.0  # all black (0/0 in MATLAB): no active block
    assert math.isnan(piqe(np.full((15, 50, 3), 90, np.uint8)))
    var, active, art, noise = piqe_blocks(np.full((32, 48, 3), 90, np.uint8))
    assert var.shape == (6,) and not active.any()
