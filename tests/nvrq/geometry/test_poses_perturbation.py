"""6-DoF novel views: the T_pert convention against hand-worked poses, SciPy's Euler
rotations and OpenCV's projectPoints / fisheye.projectPoints for every camera model."""

from __future__ import annotations

import cv2
import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation

from data_schema.errors import InputError
from data_schema.perturbation import axes, axis_values, labels, parse_perturb, view_suffix
from data_schema.scene import CameraCalib, Scene, Track
from nvrq.geometry.boxes import box_corners, pixel_box
from nvrq.geometry.cameras import camera_from_model
from nvrq.geometry.poses import (
    invert_rigid,
    offset_T_sensor_rig,
    perturb_T_sensor_rig,
    pose7_to_matrix,
)
from nvrq.pairs import make_pairs

# a level camera 1.5 m ahead of and 1.5 m above the rig origin: camera x right = rig -y,
# camera y down = rig -z, camera z forward = rig x
T_LEVEL = np.array([[0, 0, 1, 1.5], [-1, 0, 0, 0], [0, -1, 0, 1.5], [0, 0, 0, 1.0]])
PINHOLE = {"type": "pinhole", "resolution": [1280, 720], "focal_length": [800.0, 800.0],
           "principal_point": [639.5, 359.5]}
OPENCV = {"type": "opencv_pinhole", "resolution": [1920, 1208], "focal_length": [1010.5, 1008.2],
          "principal_point": [962.3, 598.1], "radial_coeffs": [-0.12, 0.03, -0.004, 0.02, 0.001, 0.0005],
          "tangential_coeffs": [0.0008, -0.0004], "thin_prism_coeffs": [0.0007, -0.0002, 0.0005, 0.0001]}
FISHEYE = {"type": "opencv_fisheye", "resolution": [1920, 1080], "focal_length": [560.0, 561.5],
           "principal_point": [958.4, 542.9], "radial_coeffs": [0.05, -0.012, 0.003, -0.0004]}
FTHETA = {"type": "ftheta", "resolution": [1920, 1080], "principal_point": [961.0, 538.4],
          "reference_poly": "PIXELDIST_TO_ANGLE",
          "pixeldist_to_angle_poly": [0.0, 1.05e-3, -2.1e-9, 5.5e-12, -8.0e-16, 0.0],
          "angle_to_pixeldist_poly": [0.0, 952.0, 0.0, 0.0, 0.0, 0.0], "max_angle": 1.1,
          "linear_cde": [0.9998, 0.0003, 0.0002]}
MODELS = {"pinhole": PINHOLE, "opencv_pinhole": OPENCV, "opencv_fisheye": FISHEYE, "ftheta": FTHETA}
# a box 12 m ahead, 1 m to the left, centre 1 m up: its 8 corners in the rig frame
CORNERS = box_corners(pose7_to_matrix(np.array([13.5, 1.0, 1.0, 0, 0, 0, 1.0]))[None], np.array([[3.0, 2.0, 2.0]]))[0]


def _to_cam(T_sensor_rig: np.ndarray, p_rig: np.ndarray) -> np.ndarray:
    T = invert_rigid(T_sensor_rig)
    return p_rig @ T[:3, :3].T + T[:3, 3]


def _independent_T(T_sensor_rig, p):
    """T_sensor'_rig built with SciPy: rotate about the sensor centre c by extrinsic x-y-z
    (roll, then pitch, then yaw about the fixed rig axes), then translate by d."""
    R = Rotation.from_euler("xyz", p[3:], degrees=True).as_matrix()
    c = T_sensor_rig[:3, 3]
    T = np.eye(4)
    T[:3, :3] = R @ T_sensor_rig[:3, :3]
    T[:3, 3] = c + np.asarray(p[:3])
    return T


def _cv2_project(model: dict, T_sensor_rig: np.ndarray, p_rig: np.ndarray) -> np.ndarray:
    """OpenCV projection of rig points seen from ``T_sensor_rig`` (OpenCV does the transform)."""
    T = invert_rigid(T_sensor_rig)
    rvec, _ = cv2.Rodrigues(T[:3, :3])
    (fx, fy), (cx, cy) = model["focal_length"], model["principal_point"]
    K = np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])
    pts = p_rig.reshape(-1, 1, 3)
    if model["type"] == "opencv_fisheye":
        uv, _ = cv2.fisheye.projectPoints(pts, rvec, T[:3, 3], K, np.array(model["radial_coeffs"]))
    else:
        k = model.get("radial_coeffs", [0.0] * 6)
        pp = model.get("tangential_coeffs", [0.0] * 2)
        s = model.get("thin_prism_coeffs", [0.0] * 4)
        dist = np.array([k[0], k[1], pp[0], pp[1], k[2], k[3], k[4], k[5], *s])
        uv, _ = cv2.projectPoints(pts, rvec, T[:3, 3], K, dist)
    return uv.reshape(-1, 2)


def _novel_uv(model: dict, T_sensor_rig: np.ndarray, p) -> np.ndarray:
    """The pairs route: GT camera frame -> perturbed camera frame -> the camera model."""
    cam = camera_from_model(model)
    T_sk_s = invert_rigid(perturb_T_sensor_rig(T_sensor_rig, np.array([p], float)))[0] @ T_sensor_rig
    pc = _to_cam(T_sensor_rig, CORNERS)
    uv, ok = cam.project(pc @ T_sk_s[:3, :3].T + T_sk_s[:3, 3])
    assert ok.all()
    return uv


def test_pure_dz_moves_every_corner_by_the_pinhole_amount():
    # hand-worked: the camera raised by dz = +1 m (rig z up) sees every point 1 m lower
    # relative to itself, so at depth Z (= rig x - 1.5, unchanged) the corner moves
    # f * 1 / Z pixels DOWN the image (v grows; image v points down), u unchanged.
    # (Issue 16 wrote "up (smaller v)": that is the box raised, i.e. dz = -1 m, checked too.)
    uv0 = _novel_uv(PINHOLE, T_LEVEL, [0, 0, 0, 0, 0, 0])
    uv1 = _novel_uv(PINHOLE, T_LEVEL, [0, 0, 1.0, 0, 0, 0])
    depth = CORNERS[:, 0] - 1.5
    np.testing.assert_allclose(uv1[:, 0], uv0[:, 0], atol=1e-9)
    np.testing.assert_allclose(uv1[:, 1], uv0[:, 1] + 800.0 / depth, atol=1e-9)
    assert (uv1[:, 1] > uv0[:, 1]).all()
    uv_low = _novel_uv(PINHOLE, T_LEVEL, [0, 0, -1.0, 0, 0, 0])
    np.testing.assert_allclose(uv_low[:, 1], uv0[:, 1] - 800.0 / depth, atol=1e-9)
    np.testing.assert_allclose(uv1, _cv2_project(PINHOLE, _independent_T(T_LEVEL, [0, 0, 1, 0, 0, 0]), CORNERS),
                               atol=1e-6)


@pytest.mark.parametrize("theta", [-10.0, 7.5, 30.0])
def test_pure_yaw_keeps_the_centre_and_turns_the_bearing(theta):
    T = perturb_T_sensor_rig(T_LEVEL, np.array([[0, 0, 0, 0, 0, theta]]))[0]
    np.testing.assert_allclose(T[:3, 3], T_LEVEL[:3, 3], atol=1e-12)  # centre fixed
    # level camera: yaw is a rotation about the camera's -y axis, so every point's azimuth
    # atan2(x, z) grows by theta (the camera turns left, the world moves right)
    a0 = np.arctan2(*_to_cam(T_LEVEL, CORNERS)[:, [0, 2]].T)
    a1 = np.arctan2(*_to_cam(T, CORNERS)[:, [0, 2]].T)
    np.testing.assert_allclose(a1 - a0, np.radians(theta), atol=1e-12)
    np.testing.assert_allclose(_novel_uv(PINHOLE, T_LEVEL, [0, 0, 0, 0, 0, theta]),
                               _cv2_project(PINHOLE, _independent_T(T_LEVEL, [0, 0, 0, 0, 0, theta]), CORNERS),
                               atol=1e-6)


@pytest.mark.parametrize("theta", [-5.0, 4.0])
def test_pure_pitch_keeps_the_centre_and_tilts_the_bearing(theta):
    T = perturb_T_sensor_rig(T_LEVEL, np.array([[0, 0, 0, 0, theta, 0]]))[0]
    np.testing.assert_allclose(T[:3, 3], T_LEVEL[:3, 3], atol=1e-12)
    # positive pitch tilts the view down: the elevation atan2(-y, z) of every point grows by theta
    e0 = np.arctan2(-_to_cam(T_LEVEL, CORNERS)[:, 1], _to_cam(T_LEVEL, CORNERS)[:, 2])
    e1 = np.arctan2(-_to_cam(T, CORNERS)[:, 1], _to_cam(T, CORNERS)[:, 2])
    np.testing.assert_allclose(e1 - e0, np.radians(theta), atol=1e-12)
    np.testing.assert_allclose(_novel_uv(PINHOLE, T_LEVEL, [0, 0, 0, 0, theta, 0]),
                               _cv2_project(PINHOLE, _independent_T(T_LEVEL, [0, 0, 0, 0, theta, 0]), CORNERS),
                               atol=1e-6)


def test_combined_perturbation_composes_in_the_documented_order():
    # a pitched, offset camera; roll, pitch and yaw all non-zero
    T_sr = _independent_T(T_LEVEL, [0.2, -0.1, 0.0, 1.0, 3.0, -2.0])
    p = [0.3, -0.8, 0.5, 4.0, -6.0, 9.0]
    got = perturb_T_sensor_rig(T_sr, np.array([p]))[0]
    np.testing.assert_allclose(got, _independent_T(T_sr, p), atol=1e-12)
    # the order matters: yaw-first (extrinsic z-y-x) is a different pose
    R_other = Rotation.from_euler("zyx", p[3:][::-1], degrees=True).as_matrix()
    assert np.abs(got[:3, :3] - R_other @ T_sr[:3, :3]).max() > 1e-3
    # roll, then pitch, then yaw, each about the sensor centre, then the shift
    step = T_sr
    for i in (3, 4, 5):
        q = np.zeros(6)
        q[i] = p[i]
        step = perturb_T_sensor_rig(step, q[None])[0]
    step[:3, 3] += p[:3]
    np.testing.assert_allclose(got, step, atol=1e-12)


@pytest.mark.parametrize("name", sorted(MODELS))
def test_every_camera_model_matches_the_reference_projection(name):
    model = MODELS[name]
    T_sr = _independent_T(T_LEVEL, [0, 0, 0, 0, 2.0, 0])  # pitched down 2 deg
    for p in ([0, 0, 1.0, 0, 0, 0], [0, -2.0, 0, 0, 0, 0], [0, 0, 0, 0, 0, -10.0], [0, 0, 0, 0, 5.0, 0],
              [0, 0, 0, 3.0, 0, 0], [0.5, 1.0, 0.5, 2.0, -3.0, 8.0]):
        uv = _novel_uv(model, T_sr, p)
        if name == "ftheta":  # no OpenCV model: the project's NCore-tested projection of
            # the points transformed by the independent (SciPy) pose
            ref, ok = camera_from_model(model).project(_to_cam(_independent_T(T_sr, p), CORNERS))
            assert ok.all()
        else:
            ref = _cv2_project(model, _independent_T(T_sr, p), CORNERS)
        np.testing.assert_allclose(uv, ref, atol=1e-6, err_msg=f"{name} {p}")


def test_lateral_shorthand_is_bitwise_the_pure_translation():
    ys = np.array([-3.0, -0.1, 0.0, 1 / 3, 2.0])
    T_old = np.broadcast_to(np.eye(4), (5, 4, 4)).copy()
    T_old[:, 1, 3] = ys  # paper Eq. 1-2: T_offset = translation (0, y, 0)
    assert np.array_equal(offset_T_sensor_rig(T_LEVEL, ys), T_old @ T_LEVEL)


def _scene(views: list, pose7) -> Scene:
    rows = [("cam", 0, "gt", *[0.0] * 6, "gt.png")]
    rows += [("cam", 0, "render", *v, f"r{i}.png") for i, v in enumerate(views)]
    images = pd.DataFrame(rows, columns=["camera", "timestamp_us", "source", "x_offset_m", "y_offset_m",
                                         "z_offset_m", "roll_deg", "pitch_deg", "yaw_deg", "path"])
    track = Track("obj", "automobile", np.array([3.0, 2.0, 2.0]), np.array([0]), np.asarray([pose7], float))
    return Scene(root=pd.io.common.Path("."), clip_id="c", attributes={}, cameras={"cam": CameraCalib(
        "cam", T_LEVEL, PINHOLE)}, rig_timestamps_us=np.array([0]), T_rig_world=np.eye(4)[None],
        tracks=[track], images=images)


def test_pairs_boxes_and_drops_per_axis_in_perturbed_views():
    views = [[0, 0, 0, 0, 0, 0], [0, 0, 1.0, 0, 0, 0], [0, 0, 0, 0, 0, 8.0], [0, 0, 0, 0, 0, 60.0]]
    pairs, stats = make_pairs(_scene(views, [13.5, 1.0, 1.0, 0, 0, 0, 1]), progress=False)
    # yaw 60 deg turns the 1280 px wide (77 deg) view away: the box leaves the image
    assert stats.by_axis["yaw"]["outside_image"] + stats.by_axis["yaw"]["unprojectable"] == 1
    assert stats.by_axis["yaw"]["kept"] == 1 and stats.by_axis["z"]["kept"] == 1
    assert "axis yaw: 1 kept of 2" in stats.summary()
    r = pairs.set_index("perturbation")
    for lab, v in (("z=+1.00", views[1]), ("yaw=+8.00", views[2])):
        # the same 8-corner box rule on OpenCV's projection of the transformed corners
        want = pixel_box(_cv2_project(PINHOLE, _independent_T(T_LEVEL, v), CORNERS))
        assert tuple(r.loc[lab, ["r_x0", "r_y0", "r_x1", "r_y1"]]) == tuple(want)
    assert r.loc["z=+1.00", "pair_id"] == "c:cam:obj:0:z=+1.00" and r.loc["none", "pair_id"] == "c:cam:obj:0:+0.00"
    assert r.loc["yaw=+8.00", "yaw_deg"] == 8.0 and r.loc["z=+1.00", "z_offset_m"] == 1.0


def test_labels_axes_and_grid_parsing():
    P = parse_perturb("y=-3:3:1,z=0:2:0.5,yaw=-10:10:5")
    # 7 lateral + 4 vertical (0 shared) + 4 yaw (0 shared) views
    assert len(P) == 7 + 4 + 4
    assert labels(P[[0, 3, 8, -1]]) == ["y=-3.00", "none", "z=+1.00", "yaw=+10.00"]
    combo = np.array([[0, 0, 0.5, 0, 0, -5.0]])
    assert labels(combo) == ["z=+0.50,yaw=-5.00"] and axes(combo).tolist() == ["combined"]
    assert np.isnan(axis_values(combo)[0]) and view_suffix(combo) == ["z=+0.50,yaw=-5.00"]
    for bad in ("q=1", "y=3:-3:1", "y=0:1:0", "yaw=100", "y", ""):
        with pytest.raises(InputError, match="--perturb"):
            parse_perturb(bad, option="--perturb")
