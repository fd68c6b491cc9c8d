"""``nvrq import nurec``: archives built here in the NuRec layout round-trip into a scene whose
rig pose, camera and track boxes project where this test's own geometry says."""

from __future__ import annotations

import json
import zipfile

import numpy as np
import pandas as pd
import pytest

from data_schema.errors import InputError
from data_schema.scene import load_scene
from nvrq.cli import main
from nvrq.geometry.cameras import camera_from_model
from nvrq.geometry.poses import interpolate_poses, pose7_to_matrix
from nvrq.sources.nurec import import_nurec

UID = "camera_front_wide_120fov@seq-1"
T_SR = np.array([[0, 0, 1, 1.5], [-1, 0, 0, 0], [0, -1, 0, 1.6], [0, 0, 0, 1]], float)
F = 200.0  # f-theta: pixel distance = 200 * angle
PARAMS = {
    "resolution": [400, 300],
    "principal_point": [199.5, 149.5],
    "reference_poly": "PIXELDIST_TO_ANGLE",
    "pixeldist_to_angle_poly": [0, 1 / F, 0, 0, 0, 0],
    "angle_to_pixeldist_poly": [0, F, 0, 0, 0, 0],
    "max_angle": 1.2,
    "linear_cde": [1.0, 0.0, 0.0],
    "shutter_type": "ROLLING_TOP_TO_BOTTOM",
}
RIG_TS = [1_000_000, 1_100_000, 1_200_000]
YAW = np.radians(30)


def _yaw(x, y, z, yaw):
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, -s, 0, x], [s, c, 0, y], [0, 0, 1, z], [0, 0, 0, 1]], float)


def _rig(t_us):
    """The test's own rig: 10 m/s along heading 30 deg from (100, 200)."""
    d = 10.0 * (t_us - RIG_TS[0]) / 1e6
    return _yaw(100 + d * np.cos(YAW), 200 + d * np.sin(YAW), 0.0, YAW)


# world -> NRE: a rotation of 90 deg about z and a shift
W2N = _yaw(-50.0, 30.0, 1.0, np.pi / 2)
CAR_WORLD = _rig(1_100_000) @ _yaw(
    20.0, 2.0, 0.8, np.radians(10)
)  # 20 m ahead, 2 m left, box centre 0.8 m up
DIMS = [4.5, 1.9, 1.6]


def _pose7(T):
    from scipy.spatial.transform import Rotation

    return list(T[:3, 3]) + list(
        Rotation.from_matrix(T[:3, :3]).as_quat()
    )  # scipy: [qx, qy, qz, qw]


def _archive(path, *, model_type="ftheta", drop=None, tracks_top_level=False):
    rig = {
        "T_world_base": np.eye(4).tolist(),
        "world_to_nre": {"matrix": W2N.tolist()},
        "camera_calibrations": {
            UID: {
                "logical_sensor_name": "camera_front_wide_120fov",
                "T_sensor_rig": T_SR.tolist(),
                "camera_model": {"type": model_type, "parameters": PARAMS},
            }
        },
        "rig_trajectories": [
            {
                "sequence_id": "seq-1",
                "T_rig_worlds": [_rig(t).tolist() for t in RIG_TS],
                "T_rig_world_timestamps_us": RIG_TS,
                "cameras_frame_timestamps_us": {
                    UID: [[1_020_000, 1_050_000], [1_120_000, 1_150_000], [1_220_000, 1_250_000]]
                },
            }
        ],
    }
    car_nre = W2N @ CAR_WORLD
    block = {
        "tracks_data": {
            "tracks_id": ["car-7"],
            "tracks_label_class": ["automobile"],
            "tracks_flags": [0],
            "tracks_timestamps_us": [[1_000_000, 1_200_000]],
            "tracks_poses": [[_pose7(car_nre), _pose7(car_nre)]],
        },
        "cuboidtracks_data": {"cuboids_dims": [DIMS]},
    }
    tracks = block if tracks_top_level else {"seq-1": block}
    with zipfile.ZipFile(path, "w") as zf:
        if drop != "rig":
            zf.writestr("scene/rig_trajectories.json", json.dumps(rig))
        if drop != "tracks":
            zf.writestr("scene/sequence_tracks.json", json.dumps(tracks))
        zf.writestr("scene/default.usda", "#usda 1.0\n")
    return path


def _hand_ftheta(p_cam):
    """Pixel of a camera-frame point under the test's f-theta (rho = F * theta)."""
    x, y, z = p_cam
    r = np.hypot(x, y)
    theta = np.arctan2(r, z)
    return np.array([199.5 + F * theta * x / r, 149.5 + F * theta * y / r])


@pytest.mark.parametrize("top_level", [False, True])
def test_roundtrip_projects_where_the_test_geometry_says(tmp_path, top_level):
    out = import_nurec(
        _archive(tmp_path / "clip.usdz", tracks_top_level=top_level),
        tmp_path / "scene",
        offsets=[-1.0, 0.0, 2.0],
    )
    scene = load_scene(out, check_images=False)
    assert scene.clip_id == "seq-1" and list(scene.cameras) == ["camera_front_wide_120fov"]
    np.testing.assert_allclose(scene.T_rig_world, np.stack([_rig(t) for t in RIG_TS]), atol=1e-12)
    # frames are stamped with each frame's end time; 1_250_000 is past the rig trajectory
    gt = scene.images[scene.images.source == "gt"]
    assert gt.timestamp_us.tolist() == [1_050_000, 1_150_000]
    assert sorted(scene.images[scene.images.source == "render"].y_offset_m.unique()) == [
        -1.0,
        0.0,
        2.0,
    ]

    (track,) = scene.tracks
    assert track.track_id == "car-7" and track.label_class == "automobile"
    np.testing.assert_allclose(track.dims_lwh, DIMS)
    T_box = pose7_to_matrix(track.poses[0])
    np.testing.assert_allclose(T_box, CAR_WORLD, atol=1e-9)  # NRE -> world undone

    cam = scene.cameras["camera_front_wide_120fov"]
    model = camera_from_model(cam.model)
    t = 1_150_000
    T_rw, ok = interpolate_poses(scene.rig_timestamps_us, scene.T_rig_world, np.array([t]))
    assert ok[0]
    corners_local = np.array(
        [
            [sx * DIMS[0] / 2, sy * DIMS[1] / 2, sz * DIMS[2] / 2, 1.0]
            for sx in (-1, 1)
            for sy in (-1, 1)
            for sz in (-1, 1)
        ]
    )
    world_mine = (CAR_WORLD @ corners_local.T).T
    world_scene = (T_box @ corners_local.T).T
    to_cam_mine = np.linalg.inv(_rig(t) @ T_SR)
    to_cam_scene = np.linalg.inv(T_rw[0] @ cam.T_sensor_rig)
    expected = np.array([_hand_ftheta((to_cam_mine @ p)[:3]) for p in world_mine])
    uv, projectable = model.project((to_cam_scene @ world_scene.T).T[:, :3])
    assert projectable.all()
    np.testing.assert_allclose(uv, expected, atol=1e-6)
    # the car is 20 m ahead of the rig: its box lies inside the 400x300 image
    assert model.in_image(uv).all()


def test_cli_and_errors(tmp_path, capsys):
    arc = _archive(tmp_path / "ok.usdz")
    assert main(["import", "nurec", str(arc), str(tmp_path / "s"), "--offsets", "-3,0,3"]) == 0
    images = pd.read_csv(tmp_path / "s" / "images.csv")
    assert len(images) == 2 * 4
    with pytest.raises(InputError, match="sequence_tracks.json"):
        import_nurec(_archive(tmp_path / "a.usdz", drop="tracks"), tmp_path / "x")
    with pytest.raises(InputError, match=r"camera_model\.type: expected ftheta"):
        import_nurec(_archive(tmp_path / "b.usdz", model_type="opencv_pinhole"), tmp_path / "x")
    (tmp_path / "c.usdz").write_text("not a zip")
    assert main(["import", "nurec", str(tmp_path / "c.usdz"), str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err
    assert "c.usdz" in err and "zip" in err and "Traceback" not in err
    assert not (tmp_path / "x").exists()  # nothing half-written


def test_perturb_grid_lists_one_render_per_view(tmp_path):
    arc = _archive(tmp_path / "ok.usdz")
    assert main(["import", "nurec", str(arc), str(tmp_path / "s"), "--perturb", "y=-1:1:1,pitch=-2:2:4"]) == 0
    images = pd.read_csv(tmp_path / "s" / "images.csv")
    renders = images[images.source == "render"]
    # 2 frames x (3 lateral + 2 pitch views; the shared 0 once)
    assert len(renders) == 2 * 5 and (images.loc[images.source == "gt", "pitch_deg"] == 0).all()
    assert sorted(set(renders.pitch_deg)) == [-2.0, 0.0, 2.0]
    assert any(p.endswith(".png") and "render_pitch-2.00" in p for p in renders.path)


def test_clip_attributes_table_fills_scene_attributes(tmp_path, capsys):
    """NuRec archives carry no lighting / road type; a clip attributes table supplies them."""
    arc = _archive(tmp_path / "ok.usdz")
    table = tmp_path / "attrs.csv"
    pd.DataFrame({"clip_id": ["seq-1", "other"], "lighting": ["night", "daytime"],
                  "road_type": ["urban", ""]}).to_csv(table, index=False)
    args = ["import", "nurec", str(arc), str(tmp_path / "s"), "--clip-attributes", str(table)]
    assert main(args) == 0
    assert load_scene(tmp_path / "s", check_images=False).attributes == {
        "lighting": "night", "road_type": "urban"}
    pd.DataFrame({"clip_id": ["other"], "lighting": ["night"]}).to_csv(table, index=False)
    assert main(args[:3] + [str(tmp_path / "t")] + args[4:]) == 2
    assert "attrs.csv: clip_id: expected a row for clip 'seq-1'" in capsys.readouterr().err
    assert not (tmp_path / "t").exists()
