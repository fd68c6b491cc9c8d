"""Real data through ``nvrq import drivestudio``: the three KITTI object frames of
../shared/realdata (skipped when absent; never copied into the repository) written in
drivestudio's KITTI-raw layout, imported, and the imported GT boxes of every untruncated object
checked against KITTI's hand-drawn 2D boxes (IoU >= 0.85, as tests/sources/test_kitti.py does for
``nvrq import kitti``).

The layout follows datasets/kitti/kitti_preprocess.py of drivestudio: camera 0 is the rectified
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

import json

import cv2
import numpy as np
import pytest

from data_schema.scene import load_scene
from nvrq.pairs import make_pairs
from nvrq.sources.drivestudio import import_drivestudio
from nvrq.sources.kitti import read_labels
from tests.sources.test_kitti import FRAMES, iou

DYNAMIC = ("Pedestrian", "Person_sitting", "Cyclist", "Car", "Van", "Truck", "Tram")  # kitti_preprocess.py


def _calib(path) -> dict:
    out = {}
    for line in path.read_text().splitlines():
        key, _, rest = line.partition(":")
        if rest.strip():
            out[key.strip()] = np.array([float(v) for v in rest.split()])
    return out


def _h(M34) -> np.ndarray:
    T = np.eye(4)
    T[: M34.shape[0], : M34.shape[1]] = M34
    return T


def write_kitti_layout(kitti, frame, root):
    """drivestudio's KITTI-raw layout of one KITTI object frame; returns its labels."""
    cal = _calib(kitti / "calib" / f"{frame}.txt")
    P2 = cal["P2"].reshape(3, 4)
    T2 = np.eye(4)
    T2[0, 3] = P2[0, 3] / P2[0, 0]
    rect_velo = _h(cal["R0_rect"].reshape(3, 3)) @ _h(cal["Tr_velo_to_cam"].reshape(3, 4))  # velo -> rect cam 0
    T_cam2_velo = T2 @ rect_velo
    for sub in ("images", "intrinsics", "extrinsics", "ego_pose", "instances"):
        (root / sub).mkdir(parents=True)
    img = cv2.imread(str(kitti / "image_2" / f"{frame}.png"))
    cv2.imwrite(str(root / "images" / "000_0.jpg"), img, [cv2.IMWRITE_JPEG_QUALITY, 95])
    np.savetxt(root / "intrinsics" / "0.txt", [P2[0, 0], P2[1, 1], P2[0, 2], P2[1, 2], 0, 0, 0, 0, 0])
    np.savetxt(root / "extrinsics" / "0.txt", np.linalg.inv(T_cam2_velo))
    np.savetxt(root / "ego_pose" / "000.txt", np.eye(4))
    labels = read_labels(kitti / "label_2" / f"{frame}.txt")
    labels = labels[labels["type"].isin(DYNAMIC)].reset_index(drop=True)
    info = {}
    for i, o in labels.iterrows():
        bottom = np.linalg.inv(rect_velo) @ [o["x"], o["y"], o["z"], 1.0]
        yaw = -o["rotation_y"] - np.pi / 2
        c, s = np.cos(yaw), np.sin(yaw)
        o2v = np.array([[c, -s, 0, bottom[0]], [s, c, 0, bottom[1]], [0, 0, 1, bottom[2] + o["h"] / 2],
                        [0, 0, 0, 1]])
        info[str(i)] = {"id": i, "class_name": o["type"],
                        "frame_annotations": {"frame_idx": [0], "obj_to_world": [o2v.tolist()],
                                              "box_size": [[o["l"], o["w"], o["h"]]]}}
    (root / "instances" / "instances_info.json").write_text(json.dumps(info))
    (root / "instances" / "frame_instances.json").write_text(json.dumps({"0": [int(k) for k in info]}))
    return labels


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
