"""The renderer draws each vehicle inside the box that scene.json's geometry projects to."""

from __future__ import annotations

import numpy as np
import pytest

from nvrq.geometry.cameras import camera_from_model
from nvrq.synth.assets import build_assets
from nvrq.synth.generate import camera_models
from nvrq.synth.ground import build_ground, camera_background
from nvrq.synth.layout import build_world
from nvrq.synth.renderer import virtual_camera
from nvrq.synth.view import render_view

SIZE = (320, 192)


@pytest.fixture(scope="module")
def world():
    ts = np.arange(12) * 100_000
    w = build_world(np.random.default_rng([2, 1]), timestamps_us=ts)
    return (
        w,
        build_assets(w, np.random.default_rng([2, 2])),
        build_ground(w, np.random.default_rng([2, 3]), res=0.16),
    )


@pytest.mark.parametrize("name", ["front", "front_wide"])
def test_vehicles_render_inside_their_projected_boxes(world, name):
    w, assets, ground = world
    cam = camera_models(SIZE)[name]
    vc = virtual_camera(cam["model"])
    bgd = camera_background(vc.K, vc.size, cam["T_sensor_rig"], lighting=w.lighting)
    model = camera_from_model(
        cam["model"]
    )  # the camera model of scene.json, independent of the renderer
    checked = 0
    for f in (0, 6, 11):
        T_cam_world = w.T_rig_world[f] @ cam["T_sensor_rig"]
        img, ids, _ = render_view(w, assets, ground, bgd, vc.K, vc.size, T_cam_world, f)
        ids_real = vc.to_real(ids, nearest=True)
        assert img.shape == (vc.size[1], vc.size[0], 3)
        T_world_cam = np.linalg.inv(T_cam_world)
        for k, actor in enumerate(w.actors):
            if actor.label_class in ("person", "rider") or not actor.present[f]:
                continue
            v, u = np.nonzero(ids_real == k)
            if len(u) < 20:
                continue
            l, wd, h = actor.dims
            local = np.array(
                [
                    [sx * l / 2, sy * wd / 2, sz * h / 2, 1.0]
                    for sx in (-1, 1)
                    for sy in (-1, 1)
                    for sz in (-1, 1)
                ]
            )
            pc = (T_world_cam @ actor.T_box_world[f] @ local.T).T[:, :3]
            uv, ok = model.project(pc)
            if not ok.all():
                continue  # a box partly behind the camera has no finite projected box
            # drawn pixels lie within the projected 8-corner box (1 px for sampling)
            assert (
                u.min() >= np.floor(uv[:, 0].min()) - 1 and u.max() <= np.ceil(uv[:, 0].max()) + 1
            )
            assert (
                v.min() >= np.floor(uv[:, 1].min()) - 1 and v.max() <= np.ceil(uv[:, 1].max()) + 1
            )
            checked += 1
    assert checked >= 5


def test_ftheta_pixels_beyond_max_angle_are_black(world):
    w, assets, ground = world
    cam = camera_models(SIZE)["front_wide"]
    vc = virtual_camera(cam["model"])
    bgd = camera_background(vc.K, vc.size, cam["T_sensor_rig"], lighting=w.lighting)
    img, _, _ = render_view(
        w, assets, ground, bgd, vc.K, vc.size, w.T_rig_world[0] @ cam["T_sensor_rig"], 0
    )
    real = vc.to_real(img)
    model = camera_from_model(cam["model"])
    W, H = SIZE
    uu, vv = np.meshgrid(np.arange(W, dtype=float), np.arange(H, dtype=float))
    rays = model.unproject(np.stack([uu, vv], -1))
    beyond = ~np.isfinite(rays).all(-1)  # unprojectable: angle >= max_angle (the image corners)
    assert beyond[0, 0] and beyond.mean() > 0.01
    assert (real[beyond] == 0).all()
    assert real[~beyond].mean() > 20  # the visible part is drawn
