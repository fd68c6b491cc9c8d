"""Real data through ``nvrq import drivestudio``: the three KITTI object frames of
../shared/realdata (skipped when absent; never copied into the repository) written in
drivestudio's KITTI-raw layout, imported, and the imported GT boxes of every untruncated object
checked against KITTI's hand-drawn 2D boxes (IoU >= 0.85, as tests/sources/test_kitti.py does for
``nvrq import kitti``).

The layout, written by :func:`nvrq.examples.kitti_drivestudio.write_kitti_layout` (the README's
example folder), follows datasets/kitti/kitti_preprocess.py of drivestudio: camera 0 is the rectified
left colour camera (``images/000_0.jpg``, ``intrinsics/0.txt`` = ``K_cam2`` with zero
distortion), ``extrinsics/0.txt = inv(T_cam2_velo)`` with pykitti's ``T_cam2_velo = T2 @ R0_rect
@ Tr_velo_to_cam`` (``T2`` the x shift ``P2[0, 3] / P2[0, 0]``), the ego frame is the Velodyne
frame and ``ego_pose/000.txt`` its pose (the identity: one frame), and each object's
``obj_to_world`` puts the box centre ``h / 2`` above the bottom centre along the Velodyne z, with
the tracklet's yaw about it. KITTI's object labels give the bottom centre in the rectified camera
0 frame and ``rotation_y``; the Velodyne yaw is ``-rotation_y - pi / 2`` (the KITTI devkit's
conversion between the two frames). Only camera 0 exists here (the object benchmark has no
image_3), so the dataset is named with ``--dataset kitti``.
"""

from __future__ import annotations

import pytest

from data_schema.scene import load_scene
from nvrq.examples.kitti_drivestudio import write_kitti_layout
from nvrq.pairs import make_pairs
from nvrq.sources.drivestudio import import_drivestudio
from tests.sources.test_kitti import FRAMES, iou


@pytest.mark.parametrize("frame", FRAMES)
def test_imported_kitti_boxes_overlap_the_hand_drawn_boxes(shared_dir, tmp_path, frame):
    kitti = shared_dir / "realdata" / "kitti"
    if not kitti.is_dir():
        pytest.skip("no KITTI frames in ../shared/realdata")
    labels = write_kitti_layout(kitti, frame, tmp_path / "layout")
    scene = load_scene(import_drivestudio(tmp_path / "layout", tmp_path / "scene", offsets=[0.0], dataset="kitti"),
                       check_images=False)
    pairs, _ = make_pairs(scene, min_side=0, progress=False)
    # floor(min u) .. ceil(max u): the pixel box brackets the projected corners within 1 px
    boxes = {r.track_id: (r.gt_x0, r.gt_y0, r.gt_x1, r.gt_y1) for r in pairs.itertuples()}
    checked = 0
    for i, o in labels.iterrows():
        if o["truncated"] != 0:
            continue
        theirs = [o["left"], o["top"], o["right"], o["bottom"]]
        assert str(i) in boxes, (frame, o["type"])  # every untruncated object is a pair
        assert iou(boxes[str(i)], theirs) >= 0.85, (frame, o["type"], boxes[str(i)], theirs)
        checked += 1
    assert checked >= 1
    assert {t.label_class for t in scene.tracks} <= {"automobile", "heavy_truck", "person", "rider", "tram"}
