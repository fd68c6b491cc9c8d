"""No-reference metrics (nvrq.metrics.no_reference) against independent numbers: the reference
implementations' values stored as fixtures (BRISQUE: PyIQA with the original allmodel; NIQE:
basicsr), the old packages' values as documented differences, values a MATLAB port gives,
scikit-image, and straightforward per-block loops written from the papers."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest
import scipy.special
import skimage.data
import skimage.measure

from nvrq.metrics.no_reference import brisque, entropy, niqe, piqe
from nvrq.metrics.no_reference._common import rgb2gray_matlab
from nvrq.metrics.no_reference._nss import SHAPES, aggd_shape, ggd_shape, imresize_half
from nvrq.metrics.no_reference.brisque import brisque_features, load_model
from nvrq.metrics.no_reference.niqe import load_pristine, niqe_features
from nvrq.metrics.no_reference.piqe import piqe_blocks

sys.path.insert(0, str(Path(__file__).parent))
from nr_images import CASES, case_image, image_sha256  # noqa: E402

DATA = Path(__file__).parent / "data"


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


# --- the shared NSS steps --------------------------------------------------------------------

def test_imresize_half_is_matlabs_bicubic_with_antialiasing():
    # MATLAB imresize(I, 0.5): output i (0-based) centred on input x = 2i + 0.5; the antialiased
    # cubic (width 8) reproduces a linear function exactly away from the mirrored borders
    ramp = np.tile(np.arange(40, dtype=np.float64), (30, 1))
    half = imresize_half(ramp)
    assert half.shape == (15, 20)  # ceil(n / 2)
    np.testing.assert_allclose(half[:, 3:-3], np.tile(2 * np.arange(20) + 0.5, (15, 1))[:, 3:-3], atol=1e-12)
    # the kernel as MATLAB's contributions(): for output 1 (1-based) of a long axis, u = 1.5,
    # taps x = -2..5 (1-based, mirrored: 3 2 1 1 2 3 4 5), weights 0.5 * cubic(0.5 (u - x)), normalised
    u, x = 1.5, np.arange(-3, 7)
    t = np.abs(0.5 * (u - x))
    k = 0.5 * np.where(t <= 1, 1.5 * t**3 - 2.5 * t**2 + 1, np.where(t <= 2, -0.5 * t**3 + 2.5 * t**2 - 4 * t + 2, 0))
    k /= k.sum()
    mirrored = np.where(x < 1, 1 - x, x) - 1  # 0-based
    col = np.random.default_rng(3).random(20) * 255
    assert imresize_half(col[:, None])[0, 0] == pytest.approx(float(k @ col[mirrored]), rel=1e-12)
    # neither OpenCV's cubic nor its area resize is this filter
    img = np.random.default_rng(4).random((32, 32)) * 255
    for interp in (cv2.INTER_CUBIC, cv2.INTER_AREA):
        assert np.abs(cv2.resize(img, (16, 16), interpolation=interp) - imresize_half(img)).max() > 1


def test_shape_table_search_is_matlabs_min_over_the_table():
    # the releases: [~, i] = min(abs(rho - r_gam)) / min((r_gam - rhatnorm).^2), gam = 0.2:0.001:10
    gam = np.arange(9801) * 0.001 + 0.2
    g = scipy.special.gamma
    r_ggd = g(1 / gam) * g(3 / gam) / g(2 / gam) ** 2
    r_aggd = g(2 / gam) ** 2 / (g(1 / gam) * g(3 / gam))
    rng = np.random.default_rng(5)
    rho = np.concatenate([rng.uniform(1.1, 30, 300), [1.0, 100.0, np.nan]])
    r = np.concatenate([rng.uniform(0.1, 0.8, 300), [0.0, 0.9, np.nan]])
    want_g = gam[[np.argmin(np.abs(v - r_ggd)) if np.isfinite(v) else 0 for v in rho]]
    want_a = gam[[np.argmin((r_aggd - v) ** 2) if np.isfinite(v) else 0 for v in r]]
    np.testing.assert_array_equal(ggd_shape(rho), want_g)
    np.testing.assert_array_equal(aggd_shape(r), want_a)
    assert SHAPES[0] == 0.2 and SHAPES[-1] == pytest.approx(10.0)


def test_model_files_are_the_original_releases():
    sv, coefs, gamma, rho, lo, hi = load_model()
    # allmodel's header (libsvm): epsilon-SVR, RBF, gamma 0.05, rho -153.591, 774 support vectors
    assert sv.shape == (774, 36) and coefs.shape == (774,) and (gamma, rho) == (0.05, -153.591)
    assert np.abs(coefs).max() == 1024 and abs(coefs.sum()) < 1e-9  # an SVR's dual sum(a - a*) = 0
    assert np.abs(sv).max() <= 1 + 1e-12  # the training features were scaled to [-1, 1] by allrange
    # allrange as the BRISQUE release (and pyiqa's scale_features) print it: the first and last rows
    assert (lo[0], hi[0]) == (0.338, 10.0) and (lo[35], hi[35]) == (0.001118, 0.370399) and (lo < hi).all()
    mu, cov = load_pristine()
    assert mu.shape == (36,) and cov.shape == (36, 36) and np.array_equal(cov, cov.T)
    assert np.linalg.eigvalsh(cov).min() > 0  # a covariance of 125 images' patches: positive definite
    assert 0.2 <= mu[0] <= 10  # the first feature is an AGGD shape in the table's range


# --- BRISQUE and NIQE against the reference implementations --------------------------------------

def _fixture(name):
    return {r["name"]: r for r in json.loads((DATA / name).read_text(encoding="utf-8"))["cases"]}


@pytest.fixture(scope="module")
def scored():
    """{case name: (image, BRISQUE, NIQE)} for every fixture image, regenerated from skimage.data;
    the images must be the ones the fixtures were computed on (their sha256)."""
    ref = _fixture("nr_reference.json")
    out = {}
    for case in CASES:
        img = case_image(case)
        assert image_sha256(img) == ref[case["name"]]["sha256"], f"{case['name']}: not the fixture's image"
        out[case["name"]] = (img, brisque(img), niqe(img))
    return out


def test_fixtures_cover_photos_degradations_and_small_crops():
    ref = _fixture("nr_reference.json")
    assert len(ref) == len(CASES) == 70
    sides = sorted(min(r["shape"]) for r in ref.values())
    assert sides[0] == 14 and sum(s < 96 for s in sides) >= 20 and sum(96 <= s < 192 for s in sides) >= 10
    assert {r["degradation"] for r in ref.values()} == {"clean", "blur", "noise", "jpeg"}


@pytest.mark.parametrize("metric,col", [(1, "brisque_double"), (2, "niqe_double")])
def test_equal_to_the_reference_implementations_in_double_precision(scored, metric, col):
    # the fixtures: pyiqa 0.1.16's brisque(version='original') with the original allmodel, basicsr
    # 1.4.2's niqe(), run in double precision as MATLAB computes and with ours' one rule (MSCN
    # below 1e-9 is 0), by tests/nvrq/metrics/make_nr_fixtures.py. Acceptance 1e-3 relative; measured
    # 3e-6 for BRISQUE (pyiqa keeps its shape table in float32) and 1e-12 for NIQE.
    ref = _fixture("nr_reference.json")
    defined = 0
    for name, got in scored.items():
        want = ref[name][col]
        if want is None:  # below the metric's minimum size (ours: NaN)
            assert math.isnan(got[metric]), name
            continue
        defined += 1
        assert got[metric] == pytest.approx(want, rel=1e-4 if metric == 1 else 1e-6), name
    assert defined == (70 if metric == 1 else 45)


@pytest.mark.parametrize("metric,col,spread", [(1, "brisque", 0.125), (2, "niqe", 0.058)])
def test_no_farther_from_the_shipped_reference_code_than_its_own_float64_run(scored, metric, col, spread):
    # pyiqa and basicsr as shipped compute the half scale (pyiqa its window too) in float32.
    # Where the float32 residue's sign decides on which side of an AGGD fit an MSCN coefficient
    # falls (flat or smooth areas: JPEG blocks, saturation) that moves their numbers, by up to
    # 12.5 % (BRISQUE) / 5.8 % (NIQE) on these images against the same code in float64. Ours is
    # never farther from the shipped code than that run, and within 1e-3 of it wherever its
    # float32 does not decide (the reference's own two runs agree to 1e-4).
    ref = _fixture("nr_reference.json")
    worst, stable = 0.0, 0
    for name, got in scored.items():
        r = ref[name]
        if r[col] is None:
            continue
        own = abs(r[col] - r[col + "_double"])
        worst = max(worst, own / abs(r[col]))
        assert abs(got[metric] - r[col]) <= own + 1e-4 * abs(r[col]), name
        if own <= 1e-4 * abs(r[col]):
            stable += 1
            assert got[metric] == pytest.approx(r[col], rel=1e-3), name
    assert worst == pytest.approx(spread, abs=0.0005) and stable >= (40 if metric == 1 else 25)


def test_documented_differences_from_the_old_packages(scored):
    # tests/nvrq/metrics/data/nr_old_packages.json: the brisque 0.2.0 package (its own features and
    # re-fitted libsvm model) and scikit-video 1.1.11's niqe (its own pristine model; it refuses
    # images under 193 px) on the same images, as docs/FORMATS.md §4 quotes them
    old = _fixture("nr_old_packages.json")
    d = np.array([scored[n][1] - old[n]["brisque_package"] for n in scored])
    assert np.median(d) == pytest.approx(-5.9, abs=0.05) and np.abs(d).max() == pytest.approx(82.5, abs=0.05)
    ratio = np.array([old[n]["skvideo_niqe"] / scored[n][2] for n in scored if old[n]["skvideo_niqe"]])
    assert len(ratio) == 20 and np.median(ratio) == pytest.approx(2.24, abs=0.005)
    assert (ratio.min(), ratio.max()) == (pytest.approx(1.28, abs=0.005), pytest.approx(9.54, abs=0.005))


# --- BRISQUE and NIQE: our rules -------------------------------------------------------------------

def test_brisque_features_are_the_releases_on_a_loop(chelsea):
    # brisque_feature.m written out map by map (circshift products, MATLAB's vec < 0 / vec > 0)
    grey = rgb2gray_matlab(np.ascontiguousarray(chelsea[40:140, 60:230])).astype(np.float64)
    win = np.outer(*(2 * [np.exp(-np.arange(-3, 4) ** 2 / (2 * (7 / 6) ** 2))]))
    win /= win.sum()
    gam = np.arange(9801) * 0.001 + 0.2
    g = scipy.special.gamma
    feats = []
    for img in (grey, imresize_half(grey)):
        mu = cv2.filter2D(img, -1, win, borderType=cv2.BORDER_CONSTANT)
        sd = np.sqrt(np.abs(cv2.filter2D(img * img, -1, win, borderType=cv2.BORDER_CONSTANT) - mu * mu))
        m = (img - mu) / (sd + 1)
        v = m.ravel()
        rho = np.mean(v * v) / np.mean(np.abs(v)) ** 2
        feats += [gam[np.argmin(np.abs(rho - g(1 / gam) * g(3 / gam) / g(2 / gam) ** 2))], np.mean(v * v)]
        for shift in ((0, 1), (1, 0), (1, 1), (-1, 1)):
            p = (m * np.roll(m, shift, axis=(0, 1))).ravel()
            lsd, rsd = math.sqrt(np.mean(p[p < 0] ** 2)), math.sqrt(np.mean(p[p > 0] ** 2))
            gh = lsd / rsd
            rn = np.mean(np.abs(p)) ** 2 / np.mean(p * p) * (gh**3 + 1) * (gh + 1) / (gh**2 + 1) ** 2
            a = gam[np.argmin((g(2 / gam) ** 2 / (g(1 / gam) * g(3 / gam)) - rn) ** 2)]
            feats += [a, (rsd - lsd) * g(2 / a) / g(1 / a) * math.sqrt(g(1 / a) / g(3 / a)), lsd**2, rsd**2]
    np.testing.assert_allclose(brisque_features(np.ascontiguousarray(chelsea[40:140, 60:230])), feats, rtol=1e-9)


def test_brisque_small_flat_and_undefined_crops_are_nan_never_errors():
    assert math.isnan(brisque(np.full((13, 40, 3), 7, np.uint8)))  # shorter side < 14
    assert np.isfinite(brisque(np.ascontiguousarray(skimage.data.coffee()[:14, :14])))
    # a flat crop: only its border ring (against the zero padding) is non-zero, and the ring's
    # neighbour products are all positive: no negative side to fit, as in the release (NaN)
    assert math.isnan(brisque(np.zeros((40, 40, 3), np.uint8)))
    assert math.isnan(brisque(np.full((40, 40, 3), 7, np.uint8)))
    stripes = np.zeros((40, 40, 3), np.uint8)
    stripes[:, ::2] = 200  # vertical products all >= 0
    assert math.isnan(brisque(stripes))


def test_brisque_ranks_distortion_and_is_not_clipped(coffee):
    clean = brisque(coffee)
    assert brisque(noisy(coffee, 20)) > clean + 5
    assert brisque(cv2.GaussianBlur(coffee, (0, 0), 3)) > clean + 20
    assert brisque(np.random.default_rng(0).integers(0, 256, (64, 64, 3), dtype=np.uint8)) > 60


def test_niqe_features_are_the_releases_on_a_block_loop(chelsea):
    # computefeature.m on each blkproc block of each scale (circshift within the block)
    crop = np.ascontiguousarray(chelsea[:200, 50:350])  # 2 x 3 blocks
    grey = rgb2gray_matlab(crop).astype(np.float64)[:192, :288]
    win = np.outer(*(2 * [np.exp(-np.arange(-3, 4) ** 2 / (2 * (7 / 6) ** 2))]))
    win /= win.sum()
    gam = np.arange(9801) * 0.001 + 0.2
    g = scipy.special.gamma
    table = g(2 / gam) ** 2 / (g(1 / gam) * g(3 / gam))

    def aggd(v):
        v = v.ravel()
        lsd, rsd = math.sqrt(np.mean(v[v < 0] ** 2)), math.sqrt(np.mean(v[v > 0] ** 2))
        gh = lsd / rsd
        rn = np.mean(np.abs(v)) ** 2 / np.mean(v * v) * (gh**3 + 1) * (gh + 1) / (gh**2 + 1) ** 2
        a = gam[np.argmin((table - rn) ** 2)]
        k = math.sqrt(g(1 / a) / g(3 / a))
        return a, lsd * k, rsd * k

    maps = []
    for img in (grey, imresize_half(grey)):
        mu = cv2.filter2D(img, -1, win, borderType=cv2.BORDER_REPLICATE)
        sd = np.sqrt(np.abs(cv2.filter2D(img * img, -1, win, borderType=cv2.BORDER_REPLICATE) - mu * mu))
        maps.append((img - mu) / (sd + 1))
    rows = []
    for i in range(2):
        for j in range(3):
            row = []
            for m, s in ((maps[0], 96), (maps[1], 48)):
                b = m[i * s:(i + 1) * s, j * s:(j + 1) * s]
                a, bl, br = aggd(b)
                row += [a, (bl + br) / 2]
                for shift in ((0, 1), (1, 0), (1, 1), (1, -1)):
                    a, bl, br = aggd(b * np.roll(b, shift, axis=(0, 1)))
                    row += [a, (br - bl) * g(2 / a) / g(1 / a), bl, br]
            rows.append(row)
    np.testing.assert_allclose(niqe_features(crop), rows, rtol=1e-9)
    feats = np.array(rows)
    mu_p, cov_p = load_pristine()
    d = mu_p - feats.mean(axis=0)
    want = math.sqrt(d @ np.linalg.pinv((cov_p + np.cov(feats.T)) / 2) @ d)  # Eq. 10
    assert niqe(crop) == pytest.approx(want, rel=1e-9)


def test_niqe_rules_small_crops_single_block_flat_and_determinism(chelsea):
    assert math.isnan(niqe(np.ascontiguousarray(chelsea[:95, :300])))  # no whole 96x96 block
    one = np.ascontiguousarray(chelsea[100:196, 100:196])
    v = niqe(one)
    # one block: crop covariance 0, i.e. the distance under the pristine covariance alone
    mu_p, cov_p = load_pristine()
    d = mu_p - niqe_features(one)[0]
    assert v == pytest.approx(math.sqrt(d @ np.linalg.pinv(cov_p / 2) @ d), rel=1e-9)
    assert niqe(one) == v  # same number on every call
    assert math.isnan(niqe(np.full((100, 200, 3), 90, np.uint8)))  # flat: every MSCN 0, no fit
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
