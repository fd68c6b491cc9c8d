"""NTA-IoU (issue 35): the peers' protocol against an independent re-implementation of
ReconDreamer's calculate.py, the nvrq protocol against hand-worked numbers, and the scene path
(``nvrq proxy nta-iou``) on a synthetic clip with two methods."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from data_schema.errors import InputError
from nvrq.proxies.nta_iou import NTAIoU, get_protocol, nta_iou

REF = Path(__file__).resolve().parent / "nta_reference"
sys.path.insert(0, str(REF))
from layout import SHIFTS, layout_digest, make_inputs, write_layout  # noqa: E402


def _read(path: Path) -> np.ndarray:
    rows = [list(map(float, line.split(","))) for line in path.read_text().splitlines() if line]
    return np.array(rows, np.float64).reshape(-1, 4)


def test_recondreamer_equals_calculate_py(tmp_path):
    # expected: tests/nvrq/proxies/nta_reference/reference_recondreamer.py (a loop-for-loop
    # re-implementation of ReconDreamer's calculate.py) run on this very layout; the command is
    # in the fixture's "command" field
    expected = json.loads((REF / "expected_recondreamer.json").read_text())
    write_layout(tmp_path, make_inputs(expected["seed"]))
    assert layout_digest(tmp_path) == expected["layout_sha256"]  # the same files the reference read
    for shift in SHIFTS:
        m = NTAIoU(protocol="recondreamer")
        frames = sorted((tmp_path / "shift_gt" / str(shift)).glob("*.txt"))
        boxes, dets = [], []
        for f in frames:
            b = _read(f)
            d = _read(tmp_path / "detect_txt" / f"shifting_{shift}_lane" / f.name.replace(".txt", "_rgb.txt"))
            boxes.append({"boxes": b, "labels": ["car"] * len(b)})
            dets.append({"boxes": d, "scores": [0.9] * len(d), "labels": ["car"] * len(d)})
        m.update(boxes, dets, image_size=(480, 320))
        want = expected["average_iou"][str(shift)]
        got = m.compute() if len(m.ious) else 0.0
        assert abs(got - want) <= 1e-12, (shift, got, want)


def test_nvrq_protocol_hand_worked():
    # one 100x80 image; IoUs worked by hand:
    # A [10,10,30,30] car  <- d1 [12,10,32,30] car: inter 18*20=360, union 440 -> 9/11
    # B [50,10,70,30] car  <- nothing (d3 overlaps it but has score 0.4 <= 0.5) -> 0
    # C [20,20,40,40] person <- d2 person (identical) -> 1 (d1 overlaps C but is a car)
    # D [0,50,20,70] and E [10,50,30,70] cars, d5 [5,50,25,70] and d6 [10,50,30,70]:
    #   D-d5 0.6 + E-d6 1.0 = 1.6 beats D-d6 1/3 + E-d5 0.6 (one-to-one) -> 0.6, 1
    # F [90,70,110,90] car, clipped to [90,70,100,80] <- d7 [90,70,100,80] -> 1
    # d4 and the train d8 are false positives (no box); mean = (9/11 + 0 + 1 + 0.6 + 1 + 1) / 6
    boxes = [{"boxes": [[10, 10, 30, 30], [50, 10, 70, 30], [20, 20, 40, 40], [0, 50, 20, 70],
                        [10, 50, 30, 70], [90, 70, 110, 90]],
              "labels": ["automobile", "automobile", "person", "automobile", "automobile", "automobile"]}]
    dets = [{"boxes": [[12, 10, 32, 30], [20, 20, 40, 40], [50, 10, 70, 30], [60, 50, 80, 70], [5, 50, 25, 70],
                       [10, 50, 30, 70], [90, 70, 100, 80], [0, 0, 100, 80]],
             "scores": [0.9, 0.8, 0.4, 0.9, 0.9, 0.9, 0.9, 0.99],
             "labels": ["car", "person", "car", "car", "car", "car", "truck", "train"]}]
    m = NTAIoU(min_side=1)
    m.update(boxes, dets, image_size=(100, 80))
    np.testing.assert_allclose(m.ious, [9 / 11, 0, 1, 0.6, 1, 1], rtol=0, atol=1e-15)
    assert nta_iou(boxes, dets, image_size=(100, 80)) == pytest.approx((9 / 11 + 3.6) / 6, abs=1e-15)
    # the peers' nearest-centre rule on the same image (scaled to 480x320, truncated, vehicles only,
    # C a person, so not projected; F [90,70,110,90] lies inside 480x320)
    peer = NTAIoU(protocol="drivedreamer4d").update(boxes, dets, image_size=(480, 320)).ious
    # A: centre (20,20), d1 centre (22,20) at 2 px -> 9/11; B: d3 (score 0.4) dropped -> 0;
    # D: d5 at 5 px -> 0.6; E: d6 at 0 px -> 1; F: the truck d7 (every class kept), centre
    # (95, 75) at 7.07 px < 10 -> 100 / 400 = 0.25
    np.testing.assert_allclose(peer, [9 / 11, 0, 0.6, 1, 0.25], atol=1e-15)
    m.reset()
    assert np.isnan(m.compute())


def test_bad_api_input():
    with pytest.raises(InputError, match="protocol"):
        NTAIoU(protocol="waymo")
    with pytest.raises(InputError, match="x1 >= x0"):
        nta_iou([{"boxes": [[5, 0, 1, 4]], "labels": ["car"]}], [{"boxes": []}], image_size=(10, 10))
    with pytest.raises(InputError, match="one dict per image"):
        nta_iou([{"boxes": [], "labels": []}], [], image_size=(10, 10))


@pytest.fixture(scope="module")
def two_methods(tmp_path_factory):
    from nvrq.cli import main

    root = tmp_path_factory.mktemp("nta") / "scene"
    assert main(["synth", str(root), "--seconds", "1", "--size", "320x180", "--methods",
                 "sharp:0.5,blurry:1.5", "--quiet"]) == 0
    return root


def _jittered_dets(scene_root: Path):
    """Detections made from the projected boxes (clipped to the image): shifted right by
    ``scale * |offset|`` px (sharp 0.5, blurry 1.5), every track whose number is a multiple of 4
    missed, and one train false positive per image. Returns (dets, expected IoU per kept box)."""
    from data_schema.scene import load_scene
    from nvrq.proxies.nta_scene import novel_boxes

    scene = load_scene(scene_root, check_images=False)
    b = novel_boxes(scene, get_protocol("nvrq"))
    x0, x1 = b.b_x0.clip(0, 320).to_numpy(), b.b_x1.clip(0, 320).to_numpy()
    y0, y1 = b.b_y0.clip(0, 180).to_numpy(), b.b_y1.clip(0, 180).to_numpy()
    w, h = x1 - x0, y1 - y0
    keep = np.minimum(w, h) >= 10
    s = b.method.map({"sharp": 0.5, "blurry": 1.5}).to_numpy() * np.abs(b.y_offset_m.to_numpy())
    missed = b.track_id.str.extract(r"(\d+)$")[0].astype(int).to_numpy() % 4 == 0
    coco = {"automobile": "car", "bus": "bus", "heavy_truck": "truck", "person": "person", "rider": "person"}
    sel = keep & ~missed
    dets = pd.DataFrame({"path": b.render_path[sel], "x0": (x0 + s)[sel], "y0": y0[sel], "x1": (x1 + s)[sel],
                         "y1": y1[sel], "score": 0.9, "coco_class": b.label_class[sel].map(coco)})
    fps = pd.DataFrame({"path": b.render_path.unique(), "x0": 0.0, "y0": 0.0, "x1": 320.0, "y1": 180.0,
                        "score": 0.99, "coco_class": "train"})
    # a box shifted by s < w along x: IoU = (w - s) h / ((w + s) h) = (w - s) / (w + s)
    with np.errstate(invalid="ignore"):  # w = 0 boxes are not kept
        expected = b[keep].assign(iou_hand=np.where(missed, 0.0, (w - s) / (w + s))[keep])
    return pd.concat([dets, fps], ignore_index=True), expected


def _scene_nta(scene: Path, tmp_path: Path, *options: str):
    """``nvrq proxy nta-iou`` of ``scene`` with :func:`_jittered_dets` as its detections and
    ``options``; (tmp_path / nta.csv, the hand-worked IoUs)."""
    from nvrq.cli import main

    dets, expected = _jittered_dets(scene)
    dets.to_csv(tmp_path / "dets.csv", index=False)
    out = tmp_path / "nta.csv"
    assert main(["proxy", "nta-iou", str(scene), "--detections", str(tmp_path / "dets.csv"),
                 "--out", str(out), *options]) == 0
    return out, expected


def test_two_methods_scene(two_methods, tmp_path):
    from nvrq.commands.proxy import nta_summary_path

    out, expected = _scene_nta(two_methods, tmp_path, "--min-side", "10", "--bootstrap", "200")
    table = pd.read_csv(out)
    assert len(table) == len(expected)
    keys = ["render_path", "track_id"]
    merged = table.merge(expected[keys + ["iou_hand"]], on=keys, validate="one_to_one")
    np.testing.assert_allclose(merged["iou"], merged["iou_hand"], rtol=0, atol=1e-12)
    summary = pd.read_csv(nta_summary_path(out))
    piv = summary.pivot(index="y_offset_m", columns="method", values="nta_iou")
    off = piv.index.to_numpy() != 0
    assert (piv.loc[off, "sharp"] > piv.loc[off, "blurry"]).all(), piv
    assert (piv.loc[~off, "sharp"] == piv.loc[~off, "blurry"]).all()
    # the summary is the mean of the per-box table, with an interval around it
    mean = table.groupby(["method", "y_offset_m"])["iou"].mean()
    got = summary.set_index(["method", "y_offset_m"])["nta_iou"]
    np.testing.assert_allclose(got.loc[mean.index], mean, atol=1e-12)
    assert (summary.ci_lo <= summary.nta_iou).all() and (summary.nta_iou <= summary.ci_hi).all()


def test_summary_min_clusters(two_methods, tmp_path):
    _scene_nta(two_methods, tmp_path, "--min-clusters", "1000", "--protocol", "recondreamer")
    s = pd.read_csv(tmp_path / "nta.summary.csv")
    assert s.ci_lo.isna().all() and s.reason.str.contains("fewer than the 1000").all()
