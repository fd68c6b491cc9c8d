"""Image headers read without decoding (data_schema.images): sizes against Pillow's and OpenCV's
decodes, files cut short, the pixel limit."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from PIL import Image

from data_schema.errors import InputError
from data_schema.images import MAX_IMAGE_PIXELS, check_image, image_header


def _noise(h, w):
    return np.random.default_rng(h * 7 + w).integers(0, 256, (h, w, 3), dtype=np.uint8)


@pytest.mark.parametrize("suffix,kw", [(".png", {}), (".jpg", {}), (".jpg", {"progressive": True}),
                                       (".jpg", {"exif": True}), (".bmp", {}), (".webp", {})])
@pytest.mark.parametrize("w,h", [(1, 1), (640, 480), (97, 1203)])
def test_header_size_is_the_decoded_size(tmp_path, suffix, kw, w, h):
    path = tmp_path / f"x{suffix}"
    img = Image.fromarray(_noise(h, w))
    if kw.get("exif"):  # an APP1 segment before the frame header
        exif = Image.Exif()
        exif[0x010E] = "a description " * 50
        img.save(path, exif=exif)
    else:
        img.save(path, progressive=kw.get("progressive", False)) if suffix == ".jpg" else img.save(path)
    head = image_header(path)
    decoded = cv2.imread(str(path), cv2.IMREAD_COLOR)  # the reference: OpenCV's full decode
    assert (head.width, head.height) == (decoded.shape[1], decoded.shape[0]) == (w, h)
    assert head.format == {".jpg": "jpeg", ".png": "png", ".bmp": "bmp", ".webp": "webp"}[suffix]


@pytest.mark.parametrize("suffix,why", [(".png", "a truncated PNG file"), (".jpg", "a truncated JPEG file")])
@pytest.mark.parametrize("keep", [0.5, 0.99, 0.02])
def test_a_file_cut_short_is_refused(tmp_path, suffix, why, keep):
    data = cv2.imencode(suffix, _noise(120, 160))[1].tobytes()
    path = tmp_path / f"x{suffix}"
    path.write_bytes(data)
    assert image_header(path).width == 160
    path.write_bytes(data[: int(len(data) * keep)])
    with pytest.raises(InputError, match=why):
        image_header(path)


def test_not_an_image_and_no_file(tmp_path):
    (tmp_path / "x.png").write_bytes(b"hello")
    with pytest.raises(InputError, match="an undecodable file"):
        image_header(tmp_path / "x.png")
    with pytest.raises(InputError, match="no such file"):
        image_header(tmp_path / "y.png")


def test_pixel_limit_and_expected_size(tmp_path):
    path = tmp_path / "x.png"
    cv2.imwrite(str(path), _noise(30, 40))
    assert check_image(path, size=(40, 30)).height == 30
    with pytest.raises(InputError, match=r"camera front's size 41x30, got 40x30"):
        check_image(path, size=(41, 30), of="camera front")
    with pytest.raises(InputError, match=r"at most 1199 pixels .*got 40x30 = 1200 pixels"):
        check_image(path, max_pixels=1199)
    assert MAX_IMAGE_PIXELS == 8192 * 8192  # the documented limit (docs/FORMATS.md §7)
