"""nvrq.scene_boxes: the projection ``nvrq pairs`` and ``nvrq proxy nta-iou`` share."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from nvrq.scene_boxes import frame_candidates, render_views, view_transforms


def test_frame_candidates_equals_a_double_loop():
    # reference: for each render row, every box whose frame is the row's frame, in box order
    rng = np.random.default_rng(0)
    frames = np.array([100, 200, 300, 400], np.int64)
    frame_index = rng.integers(0, 4, 50)
    renders = pd.DataFrame({"timestamp_us": rng.choice(frames[:3], 30)})  # frame 400: boxes, no render
    rows, boxes = frame_candidates(renders, frames, frame_index)
    want = [(r, b) for r, t in enumerate(renders.timestamp_us)
            for b in range(len(frame_index)) if frames[frame_index[b]] == t]
    assert list(zip(rows.tolist(), boxes.tolist(), strict=True)) == want


def test_view_transforms_hand_worked():
    # camera looking along the rig's x axis (z_cam = x_rig, x_cam = -y_rig, y_cam = -z_rig) 1.5 m up;
    # rig at x = 5 m in the world. A world point (15, 0, 1.5) is 10 m straight ahead: (0, 0, 10) in
    # the GT camera. Moved 2 m left (dy = +2), the camera sees it 2 m to its right: (2, 0, 10);
    # moved 1 m up (dz = +1), 1 m below: y_cam = +1.
    T_sensor_rig = np.array([[0, 0, 1, 0], [-1, 0, 0, 0], [0, -1, 0, 1.5], [0, 0, 0, 1.0]])
    T_rig_world = np.eye(4)[None].copy()
    T_rig_world[0, 0, 3] = 5.0
    views = np.array([[0, 0, 0, 0, 0, 0], [0, 2.0, 0, 0, 0, 0], [0, 0, 1.0, 0, 0, 0]])
    T_gt_world, T_view_gt = view_transforms(T_sensor_rig, T_rig_world, views)
    p = np.array([15.0, 0, 1.5, 1])
    got = [(T_view_gt[k] @ T_gt_world[0] @ p)[:3] for k in range(3)]
    np.testing.assert_allclose(got, [[0, 0, 10], [2, 0, 10], [0, 1, 10]], atol=1e-12)


def test_render_views_keeps_the_zero_view():
    views, k = render_views(pd.DataFrame({"y_offset_m": [1.0, 1.0, 3.0]}))
    assert views[:, 1].tolist() == [0.0, 1.0, 3.0] and k.tolist() == [1, 1, 2]
    assert (views[:, [0, 2, 3, 4, 5]] == 0).all()


@pytest.fixture(scope="module")
def tiny_scene(tmp_path_factory):
    from nvrq.cli import main

    root = tmp_path_factory.mktemp("scene_boxes") / "scene"
    assert main(["synth", str(root), "--seconds", "1", "--size", "320x180", "--offsets", "-2,0,2",
                 "--quiet"]) == 0
    return root


def test_pairs_and_nta_see_the_same_novel_boxes(tiny_scene):
    # every pair's novel-view box is the NTA-IoU table's box of the same render and track:
    # pairs' inclusive pixel box is floor(min u) .. ceil(max u) of the projected corners
    # (nvrq.geometry.boxes.pixel_box), NTA's is the same corners as pixel edges (+0.5)
    from data_schema.scene import load_scene
    from nvrq.pairs import make_pairs
    from nvrq.proxies.nta_iou import get_protocol
    from nvrq.proxies.nta_scene import novel_boxes

    scene = load_scene(tiny_scene, check_images=False)
    pairs, _ = make_pairs(scene, progress=False)
    boxes = novel_boxes(scene, get_protocol("nvrq"))
    assert len(pairs) > 20
    m = pairs.merge(boxes, on=["render_path", "track_id"], how="left", validate="one_to_one")
    assert m.b_x0.notna().all()
    for a, b, f in (("r_x0", "b_x0", np.floor), ("r_y0", "b_y0", np.floor),
                    ("r_x1", "b_x1", np.ceil), ("r_y1", "b_y1", np.ceil)):
        assert (m[a].to_numpy() == f(m[b].to_numpy() - 0.5)).all(), a
