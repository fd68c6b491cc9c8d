"""KITTI: projected 3D label boxes land on the hand-annotated 2D boxes (real data check).

The 2D boxes of KITTI's label_2 were drawn by annotators independently of the 3D boxes
(shared/realdata/README.md), so IoU >= 0.85 between them and the extrema of our projected
corners is an outside check of box construction, frames and projection.
"""

from __future__ import annotations

import numpy as np
import pytest

from data_schema.scene import load_scene
from nvrq.geometry.boxes import box_corners
from nvrq.geometry.cameras import camera_from_model
from nvrq.geometry.poses import invert_rigid, pose7_to_matrix
from nvrq.pairs import make_pairs
from nvrq.sources.kitti import import_kitti, read_labels

FRAMES = ["000000", "000001", "000002"]


def iou(a, b):
    ix = max(0.0, min(a[2], b[2]) - max(a[0], b[0]))
    iy = max(0.0, min(a[3], b[3]) - max(a[1], b[1]))
    inter = ix * iy
    return inter / ((a[2] - a[0]) * (a[3] - a[1]) + (b[2] - b[0]) * (b[3] - b[1]) - inter)


@pytest.mark.parametrize("frame", FRAMES)
def test_projected_boxes_match_kitti_2d_labels(shared_dir, tmp_path, frame):
    kitti = shared_dir / "realdata" / "kitti"
    if not kitti.is_dir():
        pytest.skip("no KITTI frames in ../shared/realdata")
    scene = load_scene(import_kitti(kitti, frame, tmp_path / frame))
    labels = read_labels(kitti / "label_2" / f"{frame}.txt")
    objs = labels[labels["type"] != "DontCare"].reset_index(drop=True)
    assert len(scene.tracks) == len(objs)
    cam = scene.cameras["image_2"]
    model = camera_from_model(cam.model)
    T_world_sensor = invert_rigid(scene.T_rig_world[0] @ cam.T_sensor_rig)
    poses = np.stack([t.poses[0] for t in scene.tracks])
    dims = np.stack([t.dims_lwh for t in scene.tracks])
    corners = box_corners(pose7_to_matrix(poses), dims)
    corners_s = corners @ T_world_sensor[:3, :3].T + T_world_sensor[:3, 3]
    uv, ok = model.project(corners_s)
    checked = 0
    for i, o in objs.iterrows():
        if o["truncated"] != 0:
            continue
        assert ok[i].all()
        ours = [uv[i, :, 0].min(), uv[i, :, 1].min(), uv[i, :, 0].max(), uv[i, :, 1].max()]
        theirs = [o["left"], o["top"], o["right"], o["bottom"]]
        assert iou(ours, theirs) >= 0.85, (frame, o["type"], ours, theirs, iou(ours, theirs))
        checked += 1
    assert checked >= 1


def test_kitti_scene_runs_through_pairs(shared_dir, tmp_path):
    kitti = shared_dir / "realdata" / "kitti"
    if not kitti.is_dir():
        pytest.skip("no KITTI frames in ../shared/realdata")
    scene = load_scene(import_kitti(kitti, "000000", tmp_path / "k"))
    pairs, stats = make_pairs(scene, progress=False)
    # 000000 has one pedestrian, 186 px tall, fully inside the image (label_2)
    assert len(pairs) == 1 and pairs.label_class.iloc[0] == "person"
    assert stats.kept == 1 and stats.candidates == 1
    r = pairs.iloc[0]
    assert (r.gt_x0, r.gt_y0, r.gt_x1, r.gt_y1) == (r.r_x0, r.r_y0, r.r_x1, r.r_y1)


def test_computed_visibility_falls_with_kittis_occluded_level(shared_dir, tmp_path):
    """KITTI's hand-given ``occluded`` level (0 fully visible, 1 partly, 2 largely occluded; 3
    unknown) against our GT-view visible fraction from the 3D boxes alone: the median falls
    with the level, over the levels present in the shared frames; every level-0 object is
    mostly visible, and the label travels into the pairs as ``source_visibility``."""
    kitti = shared_dir / "realdata" / "kitti"
    if not kitti.is_dir():
        pytest.skip("no KITTI frames in ../shared/realdata")
    by_level: dict[int, list[float]] = {}
    for frame in FRAMES:
        scene = load_scene(import_kitti(kitti, frame, tmp_path / frame))
        pairs, _ = make_pairs(scene, min_side=0, min_visible=0, progress=False)
        labels = read_labels(kitti / "label_2" / f"{frame}.txt")
        for _, p in pairs.iterrows():
            level = int(p.source_visibility.split()[0].split("=")[1])
            i = int(p.track_id.split("-")[0])
            assert int(labels.loc[i, "occluded"]) == level  # the label carried unchanged
            by_level.setdefault(level, []).append(p.gt_visible)
    present = [lv for lv in (0, 1, 2) if lv in by_level]
    assert present, by_level
    medians = [float(np.median(by_level[lv])) for lv in present]
    assert all(a > b for a, b in zip(medians, medians[1:], strict=False)), dict(zip(present, medians, strict=True))
    assert min(by_level[0]) >= 0.8, by_level[0]
