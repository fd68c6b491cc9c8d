"""GT/novel-view pairs: a hand-worked box, the drop reasons, and property tests for every camera model."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from data_schema.scene import CameraCalib, Scene, Track
from nvrq.geometry.boxes import box_corners
from nvrq.geometry.poses import pose7_to_matrix
from nvrq.pairs import DROP_REASONS, PairStats, make_pairs

# camera frame (x right, y down, z forward) -> rig (x forward, y left, z up), at the rig origin
T_SENSOR_RIG = np.array([[0, 0, 1, 0], [-1, 0, 0, 0], [0, -1, 0, 0], [0, 0, 0, 1.0]])

CAMERAS = {
    "pinhole": {"type": "pinhole", "resolution": [1280, 720], "focal_length": [800.0, 800.0],
                "principal_point": [639.5, 359.5]},
    "opencv_pinhole": {"type": "opencv_pinhole", "resolution": [1280, 720], "focal_length": [700.0, 700.0],
                       "principal_point": [640.0, 360.0], "radial_coeffs": [-0.32, 0.12, 0, 0, 0, 0],
                       "tangential_coeffs": [0.0005, -0.0003], "thin_prism_coeffs": [0, 0, 0, 0]},
    "opencv_fisheye": {"type": "opencv_fisheye", "resolution": [1280, 720], "focal_length": [400.0, 400.0],
                       "principal_point": [640.0, 360.0], "radial_coeffs": [0.05, -0.01, 0.002, -0.0003]},
    # NCore's 120-degree test calibration (shared/ref/ftheta_vectors.json), copied here so the
    # property tests run without ../shared.
    "ftheta": {"type": "ftheta", "resolution": [3848, 2168],
               "principal_point": [1904.948486328125, 1090.5164794921875], "reference_poly": "PIXELDIST_TO_ANGLE",
               "pixeldist_to_angle_poly": [0.0, 0.0005380856455303729, -1.2021251771798802e-09,
                                           4.5657002484267295e-12, -5.581118088908714e-16, 0.0],
               "angle_to_pixeldist_poly": [0.0, 1858.59228515625, 6.894773483276367, -53.92193603515625,
                                           14.201756477355957, 0.0],
               "max_angle": 1.2292176485061646, "linear_cde": [1.0, 0.0, 0.0]},
}


def one_box_scene(model: dict, pose7, dims, *, offsets=(0.0, 1.0), gt=True) -> Scene:
    """A one-frame scene (world = rig) with one box and renders at ``offsets``."""
    rows = [("cam", 0, "gt", 0.0, "gt.png")] if gt else []
    rows += [("cam", 0, "render", float(o), f"r{o:+.1f}.png") for o in offsets]
    images = pd.DataFrame(rows, columns=["camera", "timestamp_us", "source", "y_offset_m", "path"])
    track = Track("obj", "automobile", np.asarray(dims, float), np.array([0]), np.asarray([pose7], float))
    return Scene(root=pd.io.common.Path("."), clip_id="c", attributes={"lighting": "daytime"},
                 cameras={"cam": CameraCalib("cam", T_SENSOR_RIG, model)},
                 rig_timestamps_us=np.array([0]), T_rig_world=np.eye(4)[None], tracks=[track], images=images)


def test_hand_worked_pinhole_box():
    """A 4 x 2 x 2 m box 10 m ahead (rig x), seen by f = 800, c = (639.5, 359.5).

    Its near face (x = 8 m) spans lateral +-1 m and height +-1 m: u = 639.5 -+ 800 * 1 / 8 =
    [539.5, 739.5] and likewise v = [259.5, 459.5], so x0 = 539, x1 = 740, y0 = 259, y1 = 460.
    A +1 m offset moves the camera left, so the box moves right in the image by
    800 * 1 / 8 = 100 px at the near face: [639.5, 839.5] -> x0 = 639, x1 = 840.
    """
    scene = one_box_scene(CAMERAS["pinhole"], [10, 0, 0, 0, 0, 0, 1], [4, 2, 2])
    pairs, stats = make_pairs(scene, progress=False)
    assert len(pairs) == 2
    r = pairs.set_index("y_offset_m")
    assert tuple(r.loc[0.0, ["gt_x0", "gt_y0", "gt_x1", "gt_y1"]]) == (539, 259, 740, 460)
    assert tuple(r.loc[1.0, ["r_x0", "r_y0", "r_x1", "r_y1"]]) == (639, 259, 840, 460)
    assert r.loc[1.0, "pair_id"] == "c:cam:obj:0:+1.00"
    assert list(pairs.columns[:17]) == ["pair_id", "clip_id", "camera", "track_id", "label_class", "timestamp_us",
                                        "y_offset_m", "gt_path", "render_path", "gt_x0", "gt_y0", "gt_x1",
                                        "gt_y1", "r_x0", "r_y0", "r_x1", "r_y1"]
    assert pairs["lighting"].tolist() == ["daytime"] * 2
    assert stats.kept == 2 and stats.candidates == 2


def test_drop_reasons():
    # outside the image in the novel view only: 7 m to the left the near face (8 m) reaches
    # u = 639.5 + 800 * (7 + 1) / 8 = 1439.5 > 1279
    scene = one_box_scene(CAMERAS["pinhole"], [10, 0, 0, 0, 0, 0, 1], [4, 2, 2], offsets=(0.0, 7.0))
    pairs, stats = make_pairs(scene, progress=False)
    assert len(pairs) == 1 and stats.dropped["outside_image"] == 1
    # too small: 200 m away the 2 m box is 800 * 2 / 198 ~ 8 px
    _, stats = make_pairs(one_box_scene(CAMERAS["pinhole"], [200, 0, 0, 0, 0, 0, 1], [4, 2, 2]), progress=False)
    assert stats.dropped["too_small"] == 2 and stats.kept == 0
    # min_side / min_area thresholds are inclusive: the 10 m box is 202 x 202 px
    scene = one_box_scene(CAMERAS["pinhole"], [10, 0, 0, 0, 0, 0, 1], [4, 2, 2], offsets=(0.0,))
    assert make_pairs(scene, min_side=202, progress=False)[1].kept == 1
    assert make_pairs(scene, min_side=203, progress=False)[1].kept == 0
    assert make_pairs(scene, min_area=202 * 202 + 1, progress=False)[1].dropped["too_small"] == 1
    # straddling the camera: unprojectable
    _, stats = make_pairs(one_box_scene(CAMERAS["pinhole"], [0.5, 0, 0, 0, 0, 0, 1], [4, 2, 2]), progress=False)
    assert stats.dropped["unprojectable"] == 2
    # no GT image for the frame
    _, stats = make_pairs(one_box_scene(CAMERAS["pinhole"], [10, 0, 0, 0, 0, 0, 1], [4, 2, 2], gt=False),
                          progress=False)
    assert stats.dropped["no_gt_image"] == 2 and stats.kept == 0


def test_object_outside_its_track_span_is_skipped_not_extrapolated():
    scene = one_box_scene(CAMERAS["pinhole"], [10, 0, 0, 0, 0, 0, 1], [4, 2, 2])
    t = scene.tracks[0]
    scene.tracks[0] = Track(t.track_id, t.label_class, t.dims_lwh, np.array([10, 20]), np.stack([t.poses[0]] * 2))
    pairs, stats = make_pairs(scene, progress=False)
    assert len(pairs) == 0 and stats.candidates == 0


yaw = st.floats(-np.pi, np.pi)


def _q(a):
    return [0.0, 0.0, float(np.sin(a / 2)), float(np.cos(a / 2))]


@pytest.mark.parametrize("name", list(CAMERAS))
@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(depth=st.floats(8, 20), lat=st.floats(-0.12, 0.12), up=st.floats(-0.08, 0.08), a=yaw,
       dims=st.tuples(st.floats(1.0, 3.0), st.floats(1.0, 2.5), st.floats(1.0, 2.5)))
def test_boxes_well_inside_the_view_are_kept(name, depth, lat, up, a, dims):
    model = CAMERAS[name]
    # a bigger min side would reject far boxes in the low-resolution models; 10 px still tests the rule
    scene = one_box_scene(model, [depth, lat * depth, up * depth, *_q(a)], dims, offsets=(0.0, 0.3, -0.3))
    pairs, stats = make_pairs(scene, min_side=10, progress=False)
    assert stats.kept == 3, stats.summary()


@pytest.mark.parametrize("name", list(CAMERAS))
@settings(max_examples=150, deadline=None)
@given(x=st.floats(-6, 6), y=st.floats(-15, 15), z=st.floats(-3, 3), a=yaw,
       dims=st.tuples(st.floats(0.3, 12.0), st.floats(0.3, 4.0), st.floats(0.3, 4.0)),
       off=st.sampled_from([0.0, 1.0, -2.0, 3.0]))
def test_box_with_a_corner_behind_the_camera_is_never_kept(name, x, y, z, a, dims, off):
    pose = [x, y, z, *_q(a)]
    corners = box_corners(pose7_to_matrix(np.array(pose)), np.array(dims))  # rig = world
    # depth in a camera at rig lateral offset o is the rig x coordinate (forward), whatever o is
    assume((corners[:, 0] <= 0).any())
    scene = one_box_scene(CAMERAS[name], pose, dims, offsets=(off,))
    pairs, stats = make_pairs(scene, min_side=0, progress=False)
    assert len(pairs) == 0
    assert stats.dropped["unprojectable"] == 1


def test_pair_stats_counts_per_axis_and_in_total():
    stats = PairStats()
    axes_ = np.array(["y", "z", "y", "z", "none", "y"], dtype=object)
    stats.add(axes_, np.array([True, True, False, True, True, True]), np.array([0, 1, 0, 3, 2, 4], np.int8))
    assert (stats.candidates, stats.kept, stats.dropped) == (
        6, 1, {"no_gt_image": 1, "unprojectable": 1, "outside_image": 1, "too_small": 1, "occluded": 1})
    assert stats.by_axis == {
        "y": {"candidates": 3, "kept": 1, "no_gt_image": 1, "unprojectable": 0, "outside_image": 0, "too_small": 0,
              "occluded": 1},
        "z": {"candidates": 2, "kept": 0, "no_gt_image": 0, "unprojectable": 1, "outside_image": 0, "too_small": 1,
              "occluded": 0},
        "none": {"candidates": 1, "kept": 0, "no_gt_image": 0, "unprojectable": 0, "outside_image": 1,
                 "too_small": 0, "occluded": 0}}
    rng = np.random.default_rng(0)
    for _ in range(20):  # the totals are the sums over the axes
        n = int(rng.integers(0, 40))
        stats.add(np.array(["y", "z", "yaw", "combined"], dtype=object)[rng.integers(0, 4, n)],
                  rng.random(n) < 0.7, rng.integers(0, 5, n).astype(np.int8))
    for k in ("candidates", "kept"):
        assert getattr(stats, k) == sum(c[k] for c in stats.by_axis.values())
    for k in DROP_REASONS:
        assert stats.dropped[k] == sum(c[k] for c in stats.by_axis.values())
