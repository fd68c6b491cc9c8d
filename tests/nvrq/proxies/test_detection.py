"""Detection confidence s_det (paper Eq. 6-8) on hand-built detection sets.

Every expected number is worked by hand from the rule in the issue: the class-valid
detection of highest IoU if that IoU >= 0.3, else the highest-IoU detection of any class;
s_det is its score if its IoU >= 0.3, else 0; detections below confidence 0.1 are ignored.
The render box [0, 0, 9, 9] (inclusive) is the continuous square [0, 10] x [0, 10], area 100.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from data_schema.errors import InputError
from nvrq.proxies import load_class_maps
from nvrq.proxies.detection import detection_confidence, iou_matrix, validate_detections

from .conftest import run_proxy

COCO = load_class_maps()["coco"]


def _pairs(*rows):
    """rows: (pair_id, label_class, render_path, (x0, y0, x1, y1) inclusive)."""
    return pd.DataFrame(
        [
            dict(
                pair_id=p,
                label_class=c,
                render_path=path,
                r_x0=b[0],
                r_y0=b[1],
                r_x1=b[2],
                r_y1=b[3],
            )
            for p, c, path, b in rows
        ]
    )


def _dets(*rows):
    """rows: (path, x0, y0, x1, y1, score, coco_class)."""
    df = pd.DataFrame(rows, columns=["path", "x0", "y0", "x1", "y1", "score", "coco_class"])
    return validate_detections(df)


def _sdet(pairs, dets):
    return detection_confidence(pairs, dets, coco_map=COCO)["s_det"].tolist()


def test_iou_matches_hand_worked_boxes():
    # [0,10]^2 vs [5,15]x[0,10]: inter 50, union 150 -> 1/3; vs disjoint box -> 0; vs itself -> 1
    a = np.array([[0.0, 0, 10, 10]])
    b = np.array([[5.0, 0, 15, 10], [20, 20, 30, 30], [0, 0, 10, 10]])
    np.testing.assert_allclose(iou_matrix(a, b), [[1 / 3, 0.0, 1.0]])


def test_class_valid_path_beats_higher_iou_of_wrong_class():
    pairs = _pairs(("p", "automobile", "r/0.png", (0, 0, 9, 9)))
    dets = _dets(
        ("r/0.png", 0, 0, 10, 10, 0.4, "person"),  # IoU 1.0, wrong class
        ("r/0.png", 0, 0, 10, 5, 0.8, "car"),  # IoU 0.5, class-valid
        ("r/0.png", 0, 0, 10, 4, 0.9, "truck"),  # IoU 0.4, class-valid but lower IoU
    )
    assert _sdet(pairs, dets) == [0.8]


def test_any_class_fallback_when_no_class_valid_detection_overlaps():
    pairs = _pairs(("p", "person", "r/0.png", (0, 0, 9, 9)))
    dets = _dets(
        ("r/0.png", 0, 0, 10, 2, 0.95, "person"),  # class-valid, IoU 0.2 < 0.3
        ("r/0.png", 0, 0, 10, 6, 0.55, "dog"),  # any class, IoU 0.6
        ("r/0.png", 0, 0, 10, 5, 0.70, "car"),  # any class, IoU 0.5 (lower IoU)
    )
    assert _sdet(pairs, dets) == [0.55]


def test_fallback_below_threshold_gives_zero():
    pairs = _pairs(("p", "person", "r/0.png", (0, 0, 9, 9)))
    dets = _dets(("r/0.png", 0, 0, 10, 2, 0.95, "person"), ("r/0.png", 0, 0, 10, 2.9, 0.9, "car"))
    assert _sdet(pairs, dets) == [0.0]  # best IoU 0.29 < 0.3


def test_iou_exactly_threshold_counts():
    # [0,10]x[0,3] inside the box: IoU = 30 / 100 = 0.3 exactly (>= 0.3 counts, Eq. 8)
    pairs = _pairs(("p", "heavy_truck", "r/0.png", (0, 0, 9, 9)))
    assert _sdet(pairs, _dets(("r/0.png", 0, 0, 10, 3, 0.6, "truck"))) == [0.6]
    # just below: 29.99 / 100
    assert _sdet(pairs, _dets(("r/0.png", 0, 0, 10, 2.999, 0.6, "truck"))) == [0.0]


def test_no_detections_at_all_and_other_images_give_zero():
    pairs = _pairs(
        ("a", "automobile", "r/0.png", (0, 0, 9, 9)), ("b", "bus", "r/1.png", (0, 0, 9, 9))
    )
    empty = _dets()
    assert _sdet(pairs, empty) == [0.0, 0.0]
    # a detection on image 0 only: pair b (image 1) gets 0
    assert _sdet(pairs, _dets(("r/0.png", 0, 0, 10, 10, 0.7, "bus"))) == [0.7, 0.0]


def test_low_confidence_detections_are_ignored():
    pairs = _pairs(("p", "automobile", "r/0.png", (0, 0, 9, 9)))
    dets = _dets(("r/0.png", 0, 0, 10, 10, 0.09, "car"), ("r/0.png", 0, 0, 10, 4, 0.1, "car"))
    assert _sdet(pairs, dets) == [0.1]  # 0.09 dropped; 0.1 kept (IoU 0.4)


def test_unmapped_class_and_bad_detections_are_input_errors():
    pairs = _pairs(("p", "spaceship", "r/0.png", (0, 0, 9, 9)))
    with pytest.raises(InputError, match="spaceship"):
        _sdet(pairs, _dets(("r/0.png", 0, 0, 10, 10, 0.5, "car")))
    with pytest.raises(InputError, match="x1 >= x0"):
        _dets(("r/0.png", 5, 0, 1, 10, 0.5, "car"))
    with pytest.raises(InputError, match=r"\[0, 1\]"):
        _dets(("r/0.png", 0, 0, 1, 10, 1.5, "car"))


@pytest.mark.parametrize("kw, name", [({"iou_min": 7.0}, "iou_min"), ({"iou_min": 0.0}, "iou_min"),
                                      ({"min_score": 1.5}, "min_score"), ({"min_score": float("nan")}, "min_score")])
def test_thresholds_out_of_their_range_are_input_errors(kw, name):
    pairs = _pairs(("p", "automobile", "r/0.png", (0, 0, 9, 9)))
    dets = _dets(("r/0.png", 0, 0, 10, 10, 0.7, "car"))
    with pytest.raises(InputError, match=f"^{name}: expected a number in "):
        detection_confidence(pairs, dets, coco_map=COCO, **kw)
    assert detection_confidence(pairs, dets, coco_map=COCO, iou_min=1.0)["s_det"].tolist() == [0.7]  # IoU 1


def test_a_coco_class_coco_does_not_have_is_an_input_error():
    with pytest.raises(InputError, match=r"row 3, column coco_class: expected one of the 80 COCO class names.*'vehicle'"):
        _dets(("r/0.png", 0, 0, 10, 10, 0.5, "car"), ("r/0.png", 0, 0, 10, 10, 0.5, "Vehicle"))


def test_cli_writes_proxy_table(tmp_path, capsys):
    pairs = _pairs(
        ("p0", "automobile", "r/0.png", (0, 0, 9, 9)), ("p1", "rider", "r/0.png", (20, 0, 29, 9))
    )
    pd.DataFrame(
        [dict(path="r/0.png", x0=20, y0=0, x1=30, y1=10, score=0.66, coco_class="bicycle")]
    ).to_csv(tmp_path / "dets.csv", index=False)
    rc, path = run_proxy(tmp_path, pairs, "detection", "proxy.csv", "--detections", str(tmp_path / "dets.csv"))
    assert rc == 0
    out = pd.read_csv(path)
    assert out.columns.tolist() == ["pair_id", "s_det"]
    assert out["s_det"].tolist() == [0.0, 0.66]
    # a paths mismatch is one error line, exit 2
    pd.DataFrame(
        [dict(path="elsewhere.png", x0=0, y0=0, x1=1, y1=1, score=0.5, coco_class="car")]
    ).to_csv(tmp_path / "bad.csv", index=False)
    rc, _ = run_proxy(tmp_path, pairs, "detection", "p2.csv", "--detections", str(tmp_path / "bad.csv"))
    assert rc == 2 and "render_path" in capsys.readouterr().err
    assert not (tmp_path / "p2.csv").exists()


def test_yolo_backend_missing_weights_is_one_line_error(tmp_path, capsys):
    # the optional backend checks the weights file before importing ultralytics
    pairs = _pairs(("p0", "automobile", "r/0.png", (0, 0, 9, 9)))
    rc, _ = run_proxy(tmp_path, pairs, "detect", "dets.csv", "--yolo", str(tmp_path / "none.pt"))
    assert rc == 2 and "--yolo" in capsys.readouterr().err
