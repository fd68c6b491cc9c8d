"""``nvrq render-plan``: poses of paper Eq. 1-2 against a hand-worked example."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from data_schema.errors import InputError
from data_schema.scene import load_scene, save_scene
from nvrq.cli import main
from nvrq.render_plan import render_plan

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
    plan = render_plan(load_scene(scene_dir, check_images=False), offsets=[2.0, -1.0])
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
        render_plan(load_scene(scene_dir, check_images=False), offsets=[1.0], cameras=["rear"])


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
    lateral = render_plan(load_scene(scene_dir, check_images=False), offsets=[2.0])
    assert "perturbation" not in lateral.columns
