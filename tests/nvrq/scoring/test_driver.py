"""The scoring pipeline: GT-crop reuse, batching, equality with a naive per-pair loop, CLI."""

from __future__ import annotations

import cv2
import numpy as np
import pandas as pd
import pytest
from skimage.metrics import peak_signal_noise_ratio, structural_similarity

from nvrq.cli import main
from nvrq.crops import cut_box, encoder_input, read_rgb
from nvrq.encoders import load_encoder
from nvrq.metrics.formulas import nvrq_ca
from nvrq.scoring.driver import score_pairs
from nvrq.scoring.plan import ScorePlan


@pytest.fixture(scope="module")
def effnet():
    return load_encoder("efficientnet-lite0")


def _naive_s(pairs, root, enc):
    """Reference: for each pair, read both images, crop, embed GT and render separately."""
    out = []
    for row in pairs.itertuples():
        gt = cut_box(read_rgb(root / row.gt_path), (row.gt_x0, row.gt_y0, row.gt_x1, row.gt_y1))
        rc = cut_box(read_rgb(root / row.render_path), (row.r_x0, row.r_y0, row.r_x1, row.r_y1))
        f = enc.embed(np.stack([encoder_input(gt, 224), encoder_input(rc, 224)])).astype(np.float64)
        out.append((f[0] @ f[1] / np.linalg.norm(f[0]) / np.linalg.norm(f[1]) + 1) / 2)
    return np.array(out)


def test_gt_crops_embedded_once_and_scores_match_naive_loop(tiny_scene, effnet):
    root, pairs = tiny_scene
    shuffled = pairs.sample(frac=1.0, random_state=3).reset_index(drop=True)
    res = score_pairs(shuffled, ScorePlan.for_columns(["nvrq:efficientnet-lite0", "nvrq_ca:efficientnet-lite0"], encoder=effnet, tau=0.6, batch_size=5),
                      encoder=effnet, progress=False)
    # 2 frames x 3 objects GT crops (6) + 18 render crops = 24 encoder images for 18 pairs
    assert res.n_encoder_images == 24 and res.n_pairs == 18
    assert res.n_images_decoded == 2 + 2 * 3  # 2 GT images + 6 render images, once each
    assert res.table["pair_id"].tolist() == shuffled["pair_id"].tolist()  # input order kept
    s = res.table["nvrq:efficientnet-lite0"].to_numpy()
    np.testing.assert_allclose(s, _naive_s(shuffled, root, effnet), atol=2e-5)
    np.testing.assert_allclose(res.table["nvrq_ca:efficientnet-lite0"], nvrq_ca(s, tau=0.6))
    assert list(res.timing.columns) == ["metric", "seconds", "pairs"]


def test_batch_size_does_not_change_scores(tiny_scene, effnet):
    _, pairs = tiny_scene
    a = score_pairs(pairs, ScorePlan.for_columns(["nvrq:efficientnet-lite0"], encoder=effnet, batch_size=1),
                    encoder=effnet, progress=False)
    b = score_pairs(pairs, ScorePlan.for_columns(["nvrq:efficientnet-lite0"], encoder=effnet, batch_size=64),
                    encoder=effnet, progress=False)
    np.testing.assert_allclose(a.table.iloc[:, 1], b.table.iloc[:, 1], atol=2e-5)


def test_more_noise_lower_s_for_every_object(tiny_scene, effnet):
    # the fixture adds pixel noise of sigma 4, 10, 16 to the renders at offsets -1, 0, +1
    # (conftest.tiny_scene): for each of the 6 objects S must fall strictly with the noise.
    # Measured margins with efficientnet-lite0 are 0.01-0.03, far above the 2e-5 batch jitter.
    _, pairs = tiny_scene
    res = score_pairs(pairs, ScorePlan.for_columns(["nvrq:efficientnet-lite0"], encoder=effnet),
                      encoder=effnet, progress=False)
    s = pairs.assign(s=res.table.iloc[:, 1].to_numpy()).pivot_table(
        index=["track_id", "timestamp_us"], columns="y_offset_m", values="s")
    assert s.shape == (6, 3)
    assert (s[-1.0] > s[0.0] + 1e-3).all() and (s[0.0] > s[1.0] + 1e-3).all(), s


def test_cli_writes_metrics_and_timing(tiny_scene, tmp_path, capsys):
    root, pairs = tiny_scene
    pairs.drop(columns="scene_root").to_csv(tmp_path / "pairs.csv", index=False)
    out = tmp_path / "out" / "M.parquet"
    rc = main(["score", str(tmp_path / "pairs.csv"), "--out", str(out), "--scene", str(root),
               "--metrics", "psnr,ssim,gmsd,nvrq,nvrq_ca", "--tau", "0.6", "--batch-size", "8", "--quiet"])
    assert rc == 0
    table = pd.read_parquet(out)
    assert list(table.columns) == ["pair_id", "psnr", "ssim", "gmsd", "nvrq:efficientnet-lite0",
                                   "nvrq_ca:efficientnet-lite0"]
    assert len(table) == 18 and table.notna().all().all()
    timing = pd.read_csv(tmp_path / "out" / "M.timing.csv")
    assert timing["metric"].tolist() == list(table.columns[1:]) and (timing["pairs"] == 18).all()
    assert "encoder images: 24 (1.33 per pair" in capsys.readouterr().err


def test_cli_errors_exit_2(tiny_scene, tmp_path, capsys):
    root, pairs = tiny_scene
    pairs.drop(columns="scene_root").to_csv(tmp_path / "p.csv", index=False)
    # no scene_root column and no --scene
    assert main(["score", str(tmp_path / "p.csv"), "--out", str(tmp_path / "m.csv"), "--metrics", "psnr"]) == 2
    assert "scene_root" in capsys.readouterr().err
    # missing weights: exit 2 naming the encoder
    rc = main(["score", str(tmp_path / "p.csv"), "--out", str(tmp_path / "m.csv"), "--scene", str(root),
               "--encoder", "clip-b16", "--weights", str(tmp_path / "nothing")])
    assert rc == 2 and "clip-b16" in capsys.readouterr().err
    pairs.drop(columns="gt_x0").to_csv(tmp_path / "bad.csv", index=False)
    assert main(["score", str(tmp_path / "bad.csv"), "--out", str(tmp_path / "m.csv")]) == 2
    assert "gt_x0" in capsys.readouterr().err
    assert not (tmp_path / "m.csv").exists()


def test_render_resized_to_gt_size_in_scoring(tiny_scene):
    # score_pairs cuts both crops and bicubic-resizes the render crop to the GT size; redo it
    # by hand with OpenCV + scikit-image for one pair whose boxes differ in size.
    root, pairs = tiny_scene
    pairs = pairs.iloc[[4]].copy()
    pairs["r_x1"] += 7  # render box 7 px wider than the GT box
    res = score_pairs(pairs, ScorePlan.for_columns(["psnr", "ssim"]), progress=False)
    row = pairs.iloc[0]
    gt_img = cv2.cvtColor(cv2.imread(str(root / row.gt_path)), cv2.COLOR_BGR2RGB)
    r_img = cv2.cvtColor(cv2.imread(str(root / row.render_path)), cv2.COLOR_BGR2RGB)
    gt = gt_img[row.gt_y0:row.gt_y1 + 1, row.gt_x0:row.gt_x1 + 1]
    rc = r_img[row.r_y0:row.r_y1 + 1, row.r_x0:row.r_x1 + 1]
    rc = cv2.resize(rc, (gt.shape[1], gt.shape[0]), interpolation=cv2.INTER_CUBIC)
    assert res.table["psnr"].iloc[0] == pytest.approx(peak_signal_noise_ratio(gt, rc, data_range=255))
    assert res.table["ssim"].iloc[0] == pytest.approx(structural_similarity(
        gt, rc, channel_axis=-1, data_range=255, gaussian_weights=True, sigma=1.5,
        use_sample_covariance=False), abs=1e-7)
