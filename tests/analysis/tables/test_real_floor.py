"""The viewpoint floor on real photographs (analysis.tables.real_floor, ``analyze --real-floor``).

Expected numbers are worked by hand here: PSNR from its formula on crops sliced with NumPy, the
viewing angle ``atan(|du| / fx)`` from the boxes, and the matched rows from the pairs picked by it.
"""

from __future__ import annotations

import json
import math

import cv2
import numpy as np
import pandas as pd
import pytest

from analysis.tables import real_floor as rf


def _psnr(a, b):
    mse = np.mean((a.astype(float) - b.astype(float)) ** 2)
    return 10 * math.log10(255 ** 2 / mse)


@pytest.fixture()
def fleet(tmp_path):
    """A scene folder (fx = 500) with one GT image, real pairs and two synthetic methods."""
    rng = np.random.default_rng(0)
    img = cv2.GaussianBlur(rng.integers(0, 256, (200, 300, 3)).astype(np.uint8), (7, 7), 2)
    (tmp_path / "gt.png").write_bytes(cv2.imencode(".png", img)[1].tobytes())
    (tmp_path / "scene.json").write_text(json.dumps({"cameras": {"c": {"model": {"focal_length": [500.0, 500.0]}}}}))
    rows = []
    # (method, gt box, box centre move du): real moves 20 and 40 px -> angles atan(20/500), atan(40/500)
    for i, (m, box, du, y) in enumerate([("real", (50, 50, 120, 120), 20, -0.3), ("real", (10, 60, 80, 150), 40, -0.3),
                                         ("perfect", (100, 40, 160, 100), 30, 1.0),   # matched (30 in 20..40)
                                         ("perfect", (100, 40, 160, 100), 80, 2.0),   # not matched
                                         ("3dgs", (100, 40, 160, 100), 25, 1.0),      # matched
                                         ("nerf", (100, 40, 160, 100), 5, 0.5)]):     # not matched
        x0, y0, x1, y1 = box
        rows.append({"pair_id": f"p{i}", "camera": "c", "gt_path": "gt.png", "y_offset_m": y,
                     "scene_root": str(tmp_path), "method": m, "gt_x0": x0, "gt_y0": y0, "gt_x1": x1, "gt_y1": y1,
                     "r_x0": x0 - du, "r_y0": y0, "r_x1": x1 - du, "r_y1": y1, "psnr": 10.0 + i})
    return img, pd.DataFrame(rows)


def test_view_angles_are_atan_of_the_box_move_over_fx(fleet):
    _, pairs = fleet
    np.testing.assert_allclose(rf.view_angles(pairs), np.degrees(np.arctan(np.array([20, 40, 30, 80, 25, 5]) / 500)))


def test_floor_rows_by_hand(fleet):
    img, pairs = fleet
    res = rf.real_floor(pairs, ["psnr"], {"psnr": True})
    t = res.table.set_index("row")
    assert list(t.index) == ["real photograph (0.30 m)", "GT crop moved 5 px", "GT crop moved 10 px",
                             "GT crop moved 20 px", "perfect synthetic renders (matched angle)",
                             "renders 3dgs (matched angle)"]
    assert t.loc["real photograph (0.30 m)", "mean"] == pytest.approx(10.5)  # pairs p0, p1
    assert t.loc["perfect synthetic renders (matched angle)", "mean"] == pytest.approx(12.0)  # p2 only
    assert t.loc["renders 3dgs (matched angle)", "mean"] == pytest.approx(14.0)
    for k in (5, 10, 20):  # each real box moved k px left and right (both fit), PSNR by its formula
        per_pair = []
        for x0, y0, x1, y1 in [(50, 50, 120, 120), (10, 60, 80, 150)]:
            crop = img[y0:y1 + 1, x0:x1 + 1]
            moves = [img[y0:y1 + 1, x0 + s:x1 + s + 1] for s in (-k, k) if x0 + s >= 0 and x1 + s <= 299]
            per_pair.append(np.mean([_psnr(crop, m) for m in moves]))
        assert t.loc[f"GT crop moved {k} px", "mean"] == pytest.approx(np.mean(per_pair), rel=1e-6)
    assert any("nerf: no pair within" in n for n in res.notes)
    sentence = rf.floor_sentence(res)
    assert sentence.startswith("At 0.30 m, a real photograph scores psnr 10.5 (the GT crop merely moved: 5 px ")
    assert "your renders at the matched viewing angle score perfect 12, 3dgs 14." in sentence


def test_floor_needs_real_pairs(fleet):
    from data_schema.errors import InputError

    _, pairs = fleet
    with pytest.raises(InputError, match="pairs of method real"):
        rf.real_floor(pairs[pairs.method != "real"], ["psnr"], {"psnr": True})


def test_analyze_real_floor_reports_every_metric(tmp_path):
    from analysis.cli import main as analyze
    from nvrq.cli import main
    from tests.nvrq.sources.stereo_layout import import_argv, write_pair

    assert main(import_argv(write_pair(tmp_path / "in"), tmp_path / "scene")) == 0
    assert main(["pairs", str(tmp_path / "scene"), "--out", str(tmp_path / "pairs.csv"), "--quiet"]) == 0
    assert main(["score", str(tmp_path / "pairs.csv"), "--out", str(tmp_path / "m.csv"), "--metrics", "psnr,ssim,mae",
                 "--quiet"]) == 0
    assert analyze(["--pairs", str(tmp_path / "pairs.csv"), "--metrics-table", str(tmp_path / "m.csv"),
                    "--real-floor", "--out", str(tmp_path / "rep"), "--quiet"]) == 0
    floor = pd.read_csv(tmp_path / "rep" / "floor.csv", keep_default_na=False)
    assert sorted(set(floor.metric)) == ["mae", "psnr", "ssim"]
    assert list(dict.fromkeys(floor.row)) == ["real photograph (0.50 m)", "GT crop moved 5 px", "GT crop moved 10 px",
                                             "GT crop moved 20 px"]
    # the synthetic right image holds the objects' very texture: the real pairs are exact copies
    # of the padded GT crop but for the margin's background
    assert (floor[floor.row.str.startswith("real")].n == 2).all()
    md = (tmp_path / "rep" / "report.md").read_text()
    assert "## Viewpoint floor on real photographs" in md and "At 0.50 m, a real photograph scores" in md


def test_fleet_with_a_synthetic_scene_gets_the_perfect_row(tmp_path):
    # a stereo scene (angles atan(0.5 / 10) to atan(0.5 / 5): 2.9 to 5.7 deg) beside a synthetic
    # clip with a perfect method at 1 m offsets (objects 10 to 40 m away: some pairs in that range)
    from analysis.cli import main as analyze
    from nvrq.cli import main
    from tests.nvrq.sources.stereo_layout import import_argv, write_pair

    assert main(import_argv(write_pair(tmp_path / "in"), tmp_path / "scenes" / "stereo")) == 0
    assert main(["synth", str(tmp_path / "scenes" / "synth"), "--seconds", "1", "--fps", "2", "--size", "480x270",
                 "--methods", "perfect:0,3dgs:1", "--quiet"]) == 0
    assert main(["pairs", str(tmp_path / "scenes"), "--out", str(tmp_path / "pairs"), "--quiet"]) == 0
    assert main(["score", str(tmp_path / "pairs"), "--out", str(tmp_path / "m"), "--metrics", "psnr", "--quiet"]) == 0
    assert analyze(["--pairs", str(tmp_path / "pairs"), "--metrics-table", str(tmp_path / "m"), "--real-floor",
                    "--out", str(tmp_path / "rep"), "--quiet"]) == 0
    floor = pd.read_csv(tmp_path / "rep" / "floor.csv", keep_default_na=False)
    perfect = floor[floor.method == "perfect"]
    assert list(perfect.row) == ["perfect synthetic renders (matched angle)"] and int(perfect.n.iloc[0]) > 0
    lo, hi = np.degrees(np.arctan(0.5 / 10)), np.degrees(np.arctan(0.5 / 5))
    assert float(perfect.angle_lo_deg.iloc[0]) == pytest.approx(lo, abs=0.05)
    assert float(perfect.angle_hi_deg.iloc[0]) == pytest.approx(hi, abs=0.05)
