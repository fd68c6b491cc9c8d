"""Issue 38 item 23: a corner at a grazing angle projects to ~1e20 px; its pixel box used to be
cast to int64 ("RuntimeWarning: invalid value encountered in cast", an arbitrary integer)."""

import warnings

import numpy as np
import pytest

from nvrq.geometry.boxes import pixel_box
from nvrq.geometry.cameras import camera_from_model
from nvrq.pairs import view_validity

CAM = camera_from_model({"type": "pinhole", "resolution": [1000, 800],
                         "focal_length": [5000, 5000], "principal_point": [500, 400]})


def _box(z_near):
    """A 1 m cube 5 m ahead, its corners moved so that corner 0 is at (1, 0, z_near)."""
    c = np.array([[sx, sy, 5 + sz] for sx in (0.5, -0.5) for sy in (0.5, -0.5)
                  for sz in (0.5, -0.5)])
    c[0] = [1.0, 0.0, z_near]
    return c[None]


def test_grazing_corner_is_outside_the_image_without_a_cast_warning():
    # u = 500 + 5000 * 1 / 3e-16 = 1.7e19 px (pinhole: u = cx + fx x / z), beyond int64
    # (9.2e18); atan2(1, 3e-16) still rounds below pi / 2, so the corner is projectable
    uv, ok = CAM.project(_box(3e-16)[0])
    assert ok[0] and uv[0, 0] == pytest.approx(5000 / 3e-16, rel=1e-6)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        code, box = view_validity(CAM, _box(3e-16), min_side=2, min_area=4)
    assert code.tolist() == [2] and box.tolist() == [[0, 0, 0, 0]]
    # a 0.2 m cube 10 m ahead keeps its box: nearest corners at u = 500 -+ 5000 * 0.1 / 9.9
    cube = np.array([[sx, sy, 10 + sz] for sx in (0.1, -0.1) for sy in (0.1, -0.1)
                     for sz in (0.1, -0.1)])[None]
    code, box = view_validity(CAM, cube, min_side=2, min_area=4)
    assert code.tolist() == [0] and box[0, 0] == np.floor(500 - 5000 * 0.1 / 9.9)


@pytest.mark.parametrize("bad", [1e20, np.nan, np.inf])
def test_pixel_box_refuses_coordinates_no_integer_box_holds(bad):
    with pytest.raises(ValueError, match="finite"):
        pixel_box(np.array([[[0.0, 0.0], [bad, 5.0]]]))
