"""Real data through ``nvrq import drivestudio``: the three KITTI object frames of
../shared/realdata (skipped when absent; never copied into the repository) written in
drivestudio's KITTI-raw layout, imported, and the imported GT boxes of every untruncated object
checked against KITTI's hand-drawn 2D boxes (IoU >= 0.85, as tests/nvrq/sources/test_kitti.py does for
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
from tests.nvrq.sources.test_kitti import FRAMES, iou


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


def test_the_example_has_an_off_path_view_whose_stand_in_follows_the_plan(shared_dir, tmp_path):
    """The guide's example (docs/guides/real-data.md) imports its frame at the offsets of
    :data:`OFFSETS`, one of them off the path: the stand-in renders come in the plan's row order,
    and the leaderboard's off-path rows are made of off-path pairs."""
    import pandas as pd

    from analysis.cli import main as analyze
    from nvrq.cli import main
    from nvrq.examples.kitti_drivestudio import OFFSETS, make_example
    from nvrq.render_plans import plan_table, render_plan

    kitti = shared_dir / "realdata" / "kitti"
    if not kitti.is_dir():
        pytest.skip("no KITTI frames in ../shared/realdata")
    assert any(y != 0 for y in OFFSETS)
    make_example(kitti, tmp_path / "ex")
    scene = tmp_path / "scene"
    offsets = ",".join(f"{y:g}" for y in OFFSETS)
    assert main(["import", "drivestudio", str(tmp_path / "ex" / "drivestudio" / "000001"), str(scene),
                 "--dataset", "kitti", f"--offsets={offsets}"]) == 0
    rows = plan_table(render_plan(scene, method="sharp"))
    assert rows["y_offset_m"].tolist() == sorted(OFFSETS)  # 0000i.png is the plan's row i
    for method in ("sharp", "blurry"):
        assert main(["import", "renders", str(scene), str(tmp_path / "ex" / f"renders-{method}" / "000001"),
                     "--layout", "order", "--method", method]) == 0
    assert main(["pairs", str(scene), "--out", str(tmp_path / "pairs.csv"), "--quiet"]) == 0
    pairs = pd.read_csv(tmp_path / "pairs.csv")
    off = pairs[pairs.y_offset_m != 0]
    assert len(off) and set(off.method) == {"sharp", "blurry"}
    # camera 1 m to the left: the object moves right in the view, as the stand-in's shift does
    on = pairs[pairs.y_offset_m == 0].set_index(["method", "track_id"])
    moved = off.set_index(["method", "track_id"])
    assert (moved.r_x0 - on.loc[moved.index].r_x0 > 0).all()
    assert main(["score", str(tmp_path / "pairs.csv"), "--out", str(tmp_path / "m.csv"), "--metrics", "psnr",
                 "--quiet"]) == 0
    assert analyze(["--pairs", str(tmp_path / "pairs.csv"), "--metrics-table", str(tmp_path / "m.csv"),
                    "--compare-methods", "--quiet", "--out", str(tmp_path / "rep")]) == 0
    by = pd.read_csv(tmp_path / "rep" / "methods.csv", dtype={"group": str})
    groups = by.loc[by.breakdown == "y_offset_m", "group"].astype(float)
    assert set(groups) == set(OFFSETS)  # the off-path table has a row per off-path offset
    assert (by.loc[by.breakdown == "off-path", "n"] == len(off) // 2).all()
