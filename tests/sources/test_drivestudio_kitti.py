"""Real data through ``nvrq import drivestudio``: the three KITTI object frames of
../shared/realdata (skipped when absent; never copied into the repository) written in
drivestudio's KITTI-raw layout, imported, and the imported GT boxes of every untruncated object
checked against KITTI's hand-drawn 2D boxes (IoU >= 0.85, as tests/sources/test_kitti.py does for
``nvrq import kitti``).

The layout is written by :func:`nvrq.examples.kitti_drivestudio.write_kitti_layout` (the README's
example folder; its module docstring states drivestudio's KITTI-raw conventions, from
datasets/kitti/kitti_preprocess.py). Only camera 0 exists here (the object benchmark has no
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
