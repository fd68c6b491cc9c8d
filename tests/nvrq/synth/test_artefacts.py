"""Artefact functions against OpenCV / SciPy references and their stated formulas."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from scipy.ndimage import uniform_filter1d

from data_schema.errors import InputError
from nvrq.synth.artefacts import ARTEFACTS, apply_artefact, apply_artefacts
from nvrq.synth.degradation import severity, strengths


def _image(h=96, w=120):
    yy, xx = np.mgrid[0:h, 0:w]
    img = np.zeros((h, w, 3), np.uint8)
    img[..., 0] = ((xx // 8 + yy // 8) % 2) * 200 + 20
    img[..., 1] = (xx * 2) % 256
    img[..., 2] = (yy * 2) % 256
    return img


def test_zero_strength_is_identity_and_bad_input_raises():
    img = _image()
    for name in ARTEFACTS:
        out = apply_artefact(img, name, 0.0, rng=np.random.default_rng(0))
        assert out is not img and (out == img).all()
    with pytest.raises(InputError, match="name"):
        apply_artefact(img, "sparkle", 0.5, rng=np.random.default_rng(0))
    with pytest.raises(InputError, match="strength"):
        apply_artefact(img, "blur", 1.5, rng=np.random.default_rng(0))


def test_blur_is_the_stated_gaussian():
    img = _image()
    s = 0.5  # sigma = 0.04 * s * min(H, W) = 0.04 * 0.5 * 96 = 1.92 px
    ref = cv2.GaussianBlur(img, (0, 0), 1.92, borderType=cv2.BORDER_REFLECT)
    out = apply_artefact(img, "blur", s, rng=np.random.default_rng(0))
    assert np.abs(out.astype(int) - ref).max() <= 1


def test_smear_is_a_lateral_box_filter():
    img = _image()
    s = 0.5  # kernel = round(0.25 * s * W) = round(15.0) = 15 px, horizontal only
    ref = uniform_filter1d(img.astype(np.float64), size=15, axis=1, mode="reflect")
    out = apply_artefact(img, "smear", s, rng=np.random.default_rng(0))
    assert np.abs(out - ref).max() <= 1.0
    # nothing moves vertically: each column of a horizontally constant image is unchanged
    flat = np.repeat(_image()[:, :1], 120, axis=1)
    assert (apply_artefact(flat, "smear", 0.9, rng=np.random.default_rng(0)) == flat).all()


def test_colour_shift_has_the_stated_cast():
    grey = np.full((40, 40, 3), 128, np.uint8)  # desaturation is a no-op on grey
    for s in (0.25, 0.5, 1.0):
        out = apply_artefact(grey, "color_shift", s, rng=np.random.default_rng(3))
        shift = out.reshape(-1, 3).mean(0) - 128
        assert abs(np.linalg.norm(shift) - 70 * s) < 1.5  # |cast| = 70 * strength


@pytest.mark.parametrize("name", ARTEFACTS)
def test_damage_grows_with_strength(name):
    # a non-periodic image (a periodic one makes a shifted ghost coincide with itself)
    small = np.random.default_rng(1).integers(0, 256, (12, 15, 3)).astype(np.uint8)
    img = cv2.resize(small, (120, 96), interpolation=cv2.INTER_CUBIC)
    diffs = [
        np.abs(
            apply_artefact(img, name, s, rng=np.random.default_rng(5)).astype(float) - img
        ).mean()
        for s in (0.1, 0.4, 0.9)
    ]
    assert diffs[0] < diffs[1] < diffs[2]


def test_chain_and_severity_model():
    img = _image()
    out = apply_artefacts(img, {"blur": 0.3, "holes": 0.5}, rng=np.random.default_rng(0))
    assert out.shape == img.shape and (out != img).any()
    # severity: 0 m gives s0 = 0.02 + 0.05 * (1 - coverage); grows with |offset|;
    # an object seen in few training views (low coverage) breaks down earlier
    y = np.array([0.0, 1.0, 2.0, 3.0])
    well, few = (
        severity(y, np.full(4, 15.0), coverage=0.9),
        severity(y, np.full(4, 15.0), coverage=0.15),
    )
    np.testing.assert_allclose(well[0], 0.025)
    assert np.all(np.diff(well) > 0) and np.all(few[1:] > well[1:] + 0.1)
    st = strengths(well, np.array([1.0, 0.25, 0.5, 1.0, 0.3, 0.7]))
    np.testing.assert_allclose(st[:, 0], well)
    assert (st <= well[:, None] + 1e-12).all()
