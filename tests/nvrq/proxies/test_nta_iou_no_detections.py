"""NTA-IoU with no usable detection: a table with a header and no rows, or one whose every
detection fails the score filter, is valid input; every projected box is a miss (IoU 0), the
table is written and one note says so (it was an IndexError)."""

from __future__ import annotations

import pandas as pd
import pytest

from nvrq.cli import main


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    out = tmp_path_factory.mktemp("nta") / "scene"
    assert main(["synth", str(out), "--seconds", "1", "--fps", "2", "--size", "480x270", "--offsets", "1",
                 "--quiet"]) == 0
    return out


@pytest.mark.parametrize("rows", ["", "images/front/render_+1.00/0.png,1,1,20,20,0.01,car\n"])
def test_no_usable_detection_is_every_box_a_miss(scene, tmp_path, capsys, rows):
    dets = tmp_path / "dets.csv"
    dets.write_text("path,x0,y0,x1,y1,score,coco_class\n" + rows)
    assert main(["proxy", "nta-iou", str(scene), "--detections", str(dets), "--out", str(tmp_path / "n.csv")]) == 0
    out = capsys.readouterr().out
    assert "every box is a miss (IoU 0)" in out
    table = pd.read_csv(tmp_path / "n.csv")
    assert len(table) > 0 and (table["iou"] == 0).all() and table["d_score"].isna().all()


def test_the_pooled_number_says_what_it_pools(scene, tmp_path, capsys):
    dets = tmp_path / "dets.csv"
    dets.write_text("path,x0,y0,x1,y1,score,coco_class\n")
    assert main(["proxy", "nta-iou", str(scene), "--detections", str(dets), "--out", str(tmp_path / "n.csv")]) == 0
    table = pd.read_csv(tmp_path / "n.csv")
    line = capsys.readouterr().out.strip().splitlines()[-1]
    assert line.startswith(f"NTA-IoU (nvrq) 0.0000: the mean IoU of {len(table)} boxes, every view pooled "
                           "(the recorded view included); per box: ")
    assert line.endswith("n.summary.csv")
