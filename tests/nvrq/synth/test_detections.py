"""``nvrq proxy simulate-detect``: the demo's simulated detector (nvrq.synth.detections)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from nvrq.cli import main


@pytest.fixture(scope="module")
def scene_and_dets(tmp_path_factory):
    root = tmp_path_factory.mktemp("simdet")
    scene = root / "scene"
    assert main(["synth", str(scene), "--seconds", "1", "--size", "320x180", "--offsets", "-2,-1,0,1,2",
                 "--methods", "sharp:0.5,blurry:1.5", "--quiet"]) == 0
    assert main(["proxy", "simulate-detect", str(scene), "--out", str(root / "dets.csv")]) == 0
    return scene, pd.read_csv(root / "dets.csv")


def test_deterministic_per_seed(scene_and_dets):
    from data_schema.scene import load_scene
    from nvrq.synth.detections import simulate_detections

    scene, dets = scene_and_dets
    s = load_scene(scene, check_images=False)
    again = simulate_detections(s, seed=0)
    pd.testing.assert_frame_equal(again.reset_index(drop=True), dets, check_dtype=False, atol=1e-9)
    assert not simulate_detections(s, seed=1)[["x0", "y0"]].equals(again[["x0", "y0"]])


def test_counts_follow_the_model(scene_and_dets):
    # the true objects re-derived here: projected boxes (nvrq corners) clipped to the 320 x 180
    # image, shorter side >= 1 px, with a degradation.csv row. Each is found with probability
    # 1 - s/2 and each image gets a false positive with probability mean(s): the counts are sums
    # of independent Bernoulli draws, within 4 standard deviations of their means
    from data_schema.scene import load_scene
    from nvrq.proxies.nta_iou import get_protocol
    from nvrq.proxies.nta_scene import novel_boxes

    scene, dets = scene_and_dets
    b = novel_boxes(load_scene(scene, check_images=False), get_protocol("nvrq"))
    w = b.b_x1.clip(0, 320) - b.b_x0.clip(0, 320)
    h = b.b_y1.clip(0, 180) - b.b_y0.clip(0, 180)
    b = b[np.minimum(w, h) >= 1]
    deg = pd.read_csv(scene / "degradation.csv", dtype={"track_id": str})
    m = b.merge(deg[["camera", "timestamp_us", "track_id", "y_offset_m", "method", "severity"]],
                on=["camera", "timestamp_us", "track_id", "y_offset_m", "method"], how="inner")
    s = m.severity.clip(0, 1).to_numpy()
    found = (dets.coco_class != "train").sum()
    p = 1 - s / 2
    assert abs(found - p.sum()) < 4 * np.sqrt((p * (1 - p)).sum()) + 1  # + 1: boxes jittered to nothing
    q = m.assign(s=s).groupby("render_path").s.mean().to_numpy()
    fps = (dets.coco_class == "train").sum()
    assert abs(fps - q.sum()) < 4 * np.sqrt((q * (1 - q)).sum())
    # scores are 1 - s/2 of some true object's severity
    assert np.isin(np.round(dets.score[dets.coco_class != "train"], 9), np.round(p, 9)).all()


def test_sharp_above_blurry_off_the_path(scene_and_dets, tmp_path):
    # the README's claim for the demo: on the simulated detector's boxes, NTA-IoU (nvrq protocol)
    # puts sharp first at every |offset| >= 1, and is close to 1 on the recorded path
    from nvrq.commands.proxy import nta_summary_path

    scene, dets = scene_and_dets
    dets.to_csv(tmp_path / "dets.csv", index=False)
    out = tmp_path / "nta.csv"
    assert main(["proxy", "nta-iou", str(scene), "--detections", str(tmp_path / "dets.csv"),
                 "--out", str(out)]) == 0
    piv = pd.read_csv(nta_summary_path(out)).pivot(index="y_offset_m", columns="method", values="nta_iou")
    off = piv.index != 0
    assert (piv.loc[off, "sharp"] > piv.loc[off, "blurry"]).all(), piv
    assert (piv.loc[0.0] > 0.85).all(), piv
