"""``nvrq render-plan``: poses of paper Eq. 1-2 against a hand-worked example."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from data_schema.errors import InputError
from data_schema.scene import load_scene, save_scene
from nvrq.cli import main
from nvrq.render_plans import plan_table

# Camera looking forward (camera z = rig x, camera x = rig -y, camera y = rig -z), 1.5 m ahead
# of the rig origin and 1.6 m up.
T_SR = np.array([[0, 0, 1, 1.5], [-1, 0, 0, 0], [0, -1, 0, 1.6], [0, 0, 0, 1]], float)


def _yaw(x, y, deg):
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    return np.array([[c, -s, 0, x], [s, c, 0, y], [0, 0, 1, 0], [0, 0, 0, 1]], float)


@pytest.fixture
def scene_dir(tmp_path):
    doc = {
        "clip_id": "hand",
        "attributes": {"lighting": "daytime"},
        "cameras": {
            "front": {
                "T_sensor_rig": T_SR.tolist(),
                "model": {
                    "type": "pinhole",
                    "resolution": [100, 80],
                    "focal_length": [50, 50],
                    "principal_point": [49.5, 39.5],
                },
            }
        },
        "rig_trajectory": {
            "timestamps_us": [0, 200000],
            "T_rig_world": [_yaw(10, 5, 90).tolist(), _yaw(10, 9, 90).tolist()],
        },
        "tracks": [],
    }
    images = pd.DataFrame(
        [
            ("front", 100000, "gt", 0.0, "gt/100000.png"),
            ("front", 100000, "render", 2.0, "r/plus2.png"),
            ("front", 300000, "gt", 0.0, "gt/300000.png"),
        ],
        columns=["camera", "timestamp_us", "source", "y_offset_m", "path"],
    )
    save_scene(doc, images, tmp_path / "scene")
    return tmp_path / "scene"


def test_plan_matches_hand_worked_eq_1_2(scene_dir):
    plan = plan_table(load_scene(scene_dir, check_images=False), offsets=[2.0, -1.0])
    # t = 300000 lies outside the rig trajectory [0, 200000]: skipped, never extrapolated
    assert sorted(plan.timestamp_us.unique()) == [100000]
    row = plan[plan.y_offset_m == 2.0].iloc[0]
    # Eq. 1-2 by hand: T_sensor'_rig = T_offset @ T_sensor_rig just adds (0, 2, 0) to the translation.
    expected_sr = T_SR.copy()
    expected_sr[:3, 3] = [1.5, 2.0, 1.6]
    np.testing.assert_allclose(row.T_sensor_rig, expected_sr, atol=1e-12)
    # At t = 100000 the rig is half-way: world (10, 7, 0), yawed +90 deg (rig x -> world +y,
    # rig y -> world -x). Camera centre = (10 - 2, 7 + 1.5, 1.6); optical axis (rig x) = world +y.
    T_sw = row.T_sensor_world
    np.testing.assert_allclose(T_sw[:3, 3], [8.0, 8.5, 1.6], atol=1e-9)
    np.testing.assert_allclose(T_sw[:3, 2], [0, 1, 0], atol=1e-9)
    np.testing.assert_allclose(
        T_sw[:3, 0], [1, 0, 0], atol=1e-9
    )  # camera x (right) = rig -y = world +x
    np.testing.assert_allclose(row.T_world_sensor @ T_sw, np.eye(4), atol=1e-12)
    # the world point 10 m ahead of the virtual camera lands on its optical axis
    p = row.T_world_sensor @ np.array([8.0, 18.5, 1.6, 1.0])
    np.testing.assert_allclose(p[:3], [0, 0, 10], atol=1e-9)
    # paths: the listed render keeps its images.csv path; an unlisted offset gets the default layout
    assert row.path == "r/plus2.png"
    assert plan[plan.y_offset_m == -1.0].iloc[0].path == "images/front/render_-1.00/100000.png"


def test_cli_writes_csv_and_json(scene_dir, tmp_path):
    assert (
        main(
            ["render-plan", str(scene_dir), "--offsets", "-1,2", "--out", str(tmp_path / "p.json")]
        )
        == 0
    )
    doc = json.loads((tmp_path / "p.json").read_text())
    assert doc["clip_id"] == "hand" and len(doc["renders"]) == 2
    assert (
        main(["render-plan", str(scene_dir), "--out", str(tmp_path / "p.csv")]) == 0
    )  # offsets from images.csv
    df = pd.read_csv(tmp_path / "p.csv")
    assert df.y_offset_m.tolist() == [2.0]
    np.testing.assert_allclose(
        np.array(json.loads(df.T_sensor_world[0]))[:3, 3], [8.0, 8.5, 1.6], atol=1e-9
    )


def test_bad_input_is_reported(scene_dir, tmp_path, capsys):
    assert main(["render-plan", str(scene_dir), "--out", str(tmp_path / "p.txt")]) == 2
    assert "--out" in capsys.readouterr().err
    with pytest.raises(InputError, match="cameras"):
        plan_table(load_scene(scene_dir, check_images=False), offsets=[1.0], cameras=["rear"])


def test_plan_with_a_perturb_grid_rotates_about_the_camera_centre(scene_dir, tmp_path):
    # --perturb z=1,yaw=90: the camera rises 1 m; the yawed camera keeps its centre
    # (1.5, 0, 1.6) and its optical axis (rig x) turns to rig +y, i.e. world -x at t = 100000
    assert main(["render-plan", str(scene_dir), "--perturb", "z=1,yaw=90", "--out", str(tmp_path / "p.csv")]) == 0
    df = pd.read_csv(tmp_path / "p.csv")
    assert df.perturbation.tolist() == ["z=+1.00", "yaw=+90.00"]
    assert df.path.tolist() == ["images/front/render_z+1.00/100000.png", "images/front/render_yaw+90.00/100000.png"]
    T_z, T_yaw = (np.array(json.loads(v)) for v in df.T_sensor_rig)
    np.testing.assert_allclose(T_z[:3, 3], [1.5, 0.0, 2.6], atol=1e-12)
    np.testing.assert_allclose(T_yaw[:3, 3], [1.5, 0.0, 1.6], atol=1e-12)
    np.testing.assert_allclose(T_yaw[:3, 2], [0, 1, 0], atol=1e-12)
    np.testing.assert_allclose(np.array(json.loads(df.T_sensor_world[1]))[:3, 2], [-1, 0, 0], atol=1e-9)
    # an old lateral plan keeps its columns exactly
    lateral = plan_table(load_scene(scene_dir, check_images=False), offsets=[2.0])
    assert "perturbation" not in lateral.columns


# --- intrinsics, the npz plan and the source world (issue 27 item 2) ----------------------------

@pytest.fixture(scope="module")
def synth_dir(tmp_path_factory):
    """A synthetic clip with an OpenCV-distorted pinhole camera and an f-theta camera."""
    d = tmp_path_factory.mktemp("plan") / "scene"
    assert main(["synth", str(d), "--seconds", "1", "--fps", "2", "--size", "320x180", "--offsets=-1,2",
                 "--cameras", "pinhole,ftheta", "--quiet"]) == 0
    return d


def _K(cam) -> np.ndarray:
    (fx, fy), (cx, cy) = cam.focal_length, cam.principal_point
    return np.array([[fx, 0, cx], [0, fy, cy], [0, 0, 1.0]])


def test_npz_viewmats_invert_the_csv_poses_and_Ks_are_the_cameras(synth_dir, tmp_path):
    from nvrq.geometry.cameras import camera_from_model

    assert main(["render-plan", str(synth_dir), "--out", str(tmp_path / "p.csv")]) == 0
    assert main(["render-plan", str(synth_dir), "--format", "npz", "--out", str(tmp_path / "p.npz")]) == 0
    csv = pd.read_csv(tmp_path / "p.csv")
    with np.load(tmp_path / "p.npz", allow_pickle=False) as z:
        npz = dict(z)
    n = len(csv)
    assert n == 2 * 2 * 2 and npz["viewmats"].shape == (n, 4, 4) and npz["Ks"].shape == (n, 3, 3)
    # viewmats are the inverses (numpy's general inverse, not the toolkit's rigid one) of T_sensor_world
    T_sw = np.stack([np.array(json.loads(v)) for v in csv.T_sensor_world])
    np.testing.assert_allclose(npz["viewmats"], np.linalg.inv(T_sw), atol=1e-9)
    np.testing.assert_allclose(npz["T_sensor_world"], T_sw, atol=1e-12)
    assert npz["paths"].tolist() == csv.path.tolist() and len(set(npz["view_ids"])) == n
    scene = load_scene(synth_dir)
    assert npz["view_ids"][0] == f"{scene.clip_id}:front:0:-1.00"  # CLIP:CAMERA:T:VIEW
    for i, name in enumerate(npz["cameras"]):
        model = scene.cameras[name].model
        cam = camera_from_model(model)
        assert (npz["widths"][i], npz["heights"][i]) == cam.resolution == (csv.width[i], csv.height[i])
        assert npz["camera_models"][i] == model["type"] == csv.camera_model[i]
        if model["type"] == "ftheta":  # no K: NaN, the parameters in camera_params / the distortion column
            assert np.isnan(npz["Ks"][i]).all() and np.isnan(csv.loc[i, ["fx", "fy", "cx", "cy"]].astype(float)).all()
            assert json.loads(csv.distortion[i])["angle_to_pixeldist_poly"] == model["angle_to_pixeldist_poly"]
            continue
        np.testing.assert_array_equal(npz["Ks"][i], _K(cam))
        assert csv.loc[i, ["fx", "fy", "cx", "cy"]].tolist() == [*cam.focal_length, *cam.principal_point]
        np.testing.assert_array_equal(npz["radial_coeffs"][i], cam.radial_coeffs)
        assert json.loads(csv.distortion[i])["radial_coeffs"] == model["radial_coeffs"]
    assert json.loads(str(npz["camera_params"])) == {c: m.model for c, m in scene.cameras.items()}
    assert str(npz["world"]) == "scene" and np.array_equal(npz["T_world_source"], np.eye(4))


def _cv2_project(points_world, viewmat, K, radial, tangential, prism):
    """OpenCV's own projection (cv2.projectPoints, 12 coefficients k1 k2 p1 p2 k3 k4 k5 k6 s1..s4)."""
    import cv2

    rvec, _ = cv2.Rodrigues(viewmat[:3, :3])
    dist = np.array([radial[0], radial[1], *tangential, *radial[2:], *prism])
    uv, _ = cv2.projectPoints(points_world.reshape(-1, 1, 3), rvec, viewmat[:3, 3], K, dist)
    return uv.reshape(-1, 2)


def test_npz_poses_and_intrinsics_project_as_the_scene_camera(synth_dir):
    # what a renderer does with the arrays (OpenCV here) lands where the toolkit's camera puts it
    import nvrq
    from nvrq.geometry.boxes import box_corners
    from nvrq.geometry.cameras import camera_from_model
    from nvrq.pairs import track_boxes_at

    scene = load_scene(synth_dir)
    plan = nvrq.render_plan(synth_dir, cameras=["front"])
    cam = camera_from_model(scene.cameras["front"].model)
    for i in range(len(plan)):
        _, k, T_box_world = track_boxes_at(scene, plan.timestamps_us[[i]])
        dims = np.array([scene.tracks[j].dims_lwh for j in _]).reshape(-1, 3)
        corners = box_corners(T_box_world, dims).reshape(-1, 3)
        pc = corners @ plan.viewmats[i, :3, :3].T + plan.viewmats[i, :3, 3]
        uv, ok = cam.project(pc)
        ok &= cam.in_image(uv)  # (far outside the image OpenCV's rotation round trip costs 1e-7 relative)
        got = _cv2_project(corners[ok], plan.viewmats[i], plan.Ks[i], plan.radial_coeffs[i],
                           plan.tangential_coeffs[i], plan.thin_prism_coeffs[i])
        assert ok.sum() > 8
        np.testing.assert_allclose(got, uv[ok], atol=1e-6)


def _with_source_world(scene_dir, T_world_source) -> None:
    doc = json.loads((scene_dir / "scene.json").read_text())
    doc["source_world"] = {"name": "drivestudio", "dataset": "waymo", "T_world_source": T_world_source.tolist()}
    (scene_dir / "scene.json").write_text(json.dumps(doc))


def test_world_source_is_the_scene_world_rebased_on_the_first_rig_pose(scene_dir, tmp_path):
    from nvrq.geometry.poses import invert_rigid
    from nvrq.render_plans import render_plan

    scene = load_scene(scene_dir, check_images=False)
    T_ws = invert_rigid(scene.T_rig_world[0])  # drivestudio: poses times inv(first ego pose)
    _with_source_world(scene_dir, T_ws)
    own, src = render_plan(scene_dir, offsets=[2.0]), render_plan(scene_dir, offsets=[2.0], world="source")
    np.testing.assert_allclose(src.T_sensor_world, T_ws @ own.T_sensor_world, atol=1e-9)
    np.testing.assert_allclose(src.viewmats, np.linalg.inv(T_ws @ own.T_sensor_world), atol=1e-9)
    np.testing.assert_array_equal(src.T_sensor_rig, own.T_sensor_rig)
    # by hand: at t = 100000 the rig has driven 2 m forward (rig x) from its first pose, so in the
    # re-based world the camera 1.5 m ahead, 1.6 m up and 2 m left (y = +2) is at (3.5, 2, 1.6)
    np.testing.assert_allclose(src.T_sensor_world[0, :3, 3], [3.5, 2.0, 1.6], atol=1e-9)
    np.testing.assert_allclose(src.T_sensor_world[0, :3, 2], [1, 0, 0], atol=1e-9)  # looking along rig x
    assert src.world == "source" and np.array_equal(src.T_world_source, T_ws)
    assert main(["render-plan", str(scene_dir), "--world", "source", "--out", str(tmp_path / "p.json")]) == 0
    doc = json.loads((tmp_path / "p.json").read_text())
    assert doc["world"] == "source" and doc["renders"][0]["fx"] == 50.0
    np.testing.assert_allclose(doc["T_world_source"], T_ws, atol=0)


def test_world_source_boxes_project_as_in_the_scene(synth_dir, tmp_path):
    # a renderer placed in the source world with the plan's poses sees the boxes where the scene does
    import shutil

    from nvrq.geometry.boxes import box_corners
    from nvrq.geometry.cameras import camera_from_model
    from nvrq.geometry.poses import invert_rigid, pose7_to_matrix
    from nvrq.pairs import track_boxes_at
    from nvrq.render_plans import render_plan

    d = tmp_path / "scene"
    shutil.copytree(synth_dir, d)
    scene = load_scene(d)
    T_ws = invert_rigid(scene.T_rig_world[0]) @ pose7_to_matrix(np.array([3.0, -2, 0.5, 0.1, 0.2, 0.3, 0.9]))
    _with_source_world(d, T_ws)
    plan = render_plan(d, cameras=["front"], world="source")
    cam = camera_from_model(scene.cameras["front"].model)
    for i in range(len(plan)):
        tracks, _, T_box_world = track_boxes_at(scene, plan.timestamps_us[[i]])
        dims = np.array([scene.tracks[j].dims_lwh for j in tracks]).reshape(-1, 3)
        corners = box_corners(T_box_world, dims).reshape(-1, 3)
        own = render_plan(d, cameras=["front"]).viewmats[i]
        uv, ok = cam.project(corners @ own[:3, :3].T + own[:3, 3])  # the scene's own projection
        ok &= cam.in_image(uv)
        corners_src = corners @ T_ws[:3, :3].T + T_ws[:3, 3]
        got = _cv2_project(corners_src[ok], plan.viewmats[i], plan.Ks[i], plan.radial_coeffs[i],
                           plan.tangential_coeffs[i], plan.thin_prism_coeffs[i])
        assert ok.sum() > 8
        np.testing.assert_allclose(got, uv[ok], atol=1e-6)


def test_world_source_needs_a_source_world(scene_dir, tmp_path, capsys):
    assert main(["render-plan", str(scene_dir), "--world", "source", "--out", str(tmp_path / "p.npz")]) == 2
    err = capsys.readouterr().err
    # it reads forwards: the file and the option, what --world source needs, what this scene has,
    # and the value of the option to use instead
    assert err.count("\n") == 1 and err.startswith("error: ") and "scene.json: --world: source_world: " in err
    assert "expected the source dataset's world, which only a scene imported from drivestudio " in err
    assert err.rstrip().endswith("with --world scene instead), got no source_world key"), err
    assert not (tmp_path / "p.npz").exists()
    bad = np.eye(4)
    bad[0, 0] = 2.0  # not a rotation
    _with_source_world(scene_dir, bad)
    assert main(["render-plan", str(scene_dir), "--world", "source", "--out", str(tmp_path / "p.npz")]) == 2
    assert "source_world.T_world_source" in capsys.readouterr().err and not (tmp_path / "p.npz").exists()


def test_format_must_match_the_suffix(scene_dir, tmp_path, capsys):
    assert main(["render-plan", str(scene_dir), "--format", "npz", "--out", str(tmp_path / "p.csv")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--format" in err and not (tmp_path / "p.csv").exists()
    assert main(["render-plan", str(scene_dir), "--method", "a:b", "--out", str(tmp_path / "p.csv")]) == 2
    assert "--method" in capsys.readouterr().err


def test_python_render_plan_is_the_table_of_the_command(synth_dir):
    import nvrq
    from nvrq.render_plans import plan_table

    plan = nvrq.render_plan(synth_dir)
    table = plan_table(load_scene(synth_dir, check_images=False))
    assert isinstance(plan, nvrq.RenderPlan) and len(plan) == len(table)
    assert plan.paths.tolist() == table.path.tolist()
    np.testing.assert_array_equal(np.stack(table.T_world_sensor), plan.viewmats)
