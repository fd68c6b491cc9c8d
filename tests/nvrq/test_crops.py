"""Crops: colour order, inclusive boxes, centred black padding, bicubic resize."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from data_schema.errors import InputError
from nvrq.crops import cut_box, encoder_input, pad_to_square, read_rgb, resize_to

from .conftest import write_rgb


def test_read_rgb_returns_the_files_rgb_order(tmp_path):
    # Pillow writes the array as R, G, B; read_rgb must give back exactly that array
    # (cv2.imread alone would return it with channels reversed).
    rgb = np.zeros((4, 6, 3), np.uint8)
    rgb[:, :3] = (255, 0, 0)  # pure red left half
    rgb[:, 3:] = (0, 0, 255)  # pure blue right half
    write_rgb(tmp_path / "x.png", rgb)
    out = read_rgb(tmp_path / "x.png")
    np.testing.assert_array_equal(out, rgb)
    assert out[0, 0].tolist() == [255, 0, 0]
    np.testing.assert_array_equal(cv2.imread(str(tmp_path / "x.png"))[..., ::-1], out)


def test_read_rgb_missing_file_is_input_error(tmp_path):
    with pytest.raises(InputError, match="no such file"):
        read_rgb(tmp_path / "nope.png")


def test_cut_box_is_inclusive():
    img = np.arange(10 * 8 * 3).reshape(10, 8, 3)
    crop = cut_box(img, (2, 3, 4, 7))  # x0=2..4 (3 columns), y0=3..7 (5 rows), docs/FORMATS.md §3
    assert crop.shape == (5, 3, 3)
    assert crop[0, 0, 0] == img[3, 2, 0] and crop[-1, -1, 0] == img[7, 4, 0]


@pytest.mark.parametrize("box", [(0, 0, 8, 2), (-1, 0, 3, 3), (3, 0, 2, 2), (0, 0, 2, 10)])
def test_cut_box_outside_image_raises(box):
    with pytest.raises(InputError):
        cut_box(np.zeros((10, 8, 3), np.uint8), box)


def test_pad_to_square_centres_content_with_black():
    crop = np.full((2, 6, 3), 200, np.uint8)
    sq = pad_to_square(crop)
    # hand-worked: S = 6, top pad (6 - 2) // 2 = 2 rows, bottom 2 rows
    assert sq.shape == (6, 6, 3)
    assert sq[:, 0, 0].tolist() == [0, 0, 200, 200, 0, 0]
    tall = pad_to_square(np.full((5, 2, 3), 9, np.uint8))  # left pad (5-2)//2 = 1, right 2
    assert tall[0, :, 0].tolist() == [0, 9, 9, 0, 0]


def test_encoder_input_is_bicubic_of_padded_square():
    rng = np.random.default_rng(0)
    crop = rng.integers(0, 256, (30, 50, 3), dtype=np.uint8)
    out = encoder_input(crop, 224)
    padded = np.zeros((50, 50, 3), np.uint8)
    padded[10:40] = crop
    np.testing.assert_array_equal(out, cv2.resize(padded, (224, 224), interpolation=cv2.INTER_CUBIC))
    assert out[:40].mean() < 1 and out[-40:].mean() < 1  # black bands above and below


def test_resize_to_gt_size():
    r = np.zeros((10, 20, 3), np.uint8)
    assert resize_to(r, 15, 7).shape == (15, 7, 3)
    assert resize_to(r, 10, 20) is r
