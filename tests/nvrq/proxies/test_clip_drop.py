"""CLIP zero-shot true-category drop (paper Eq. 10) with a tiny random-weight CLIP built offline.

The folder path (CLIPModel + a hand-made tokenizer + preprocessor config) is checked against
CLIPModel's own ``logits_per_image`` softmax; the sign of Eq. 10 is checked with category
text features constructed to point at the GT crop's embedding.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
import torch
from skimage import data

from data_schema.errors import InputError
from nvrq.proxies import load_class_maps
from nvrq.proxies.clip_drop import ZeroShotCLIP, clip_drop, load_clip, zero_shot_probs

from .conftest import CAT_BOX, CLIP_MEAN, CLIP_STD, crop_input, run_proxy

MAPS = load_class_maps()
MEAN, STD = CLIP_MEAN, CLIP_STD


def test_zero_shot_probs_is_clip_softmax():
    # exp(log 10) * cos: image along text 0 -> logits [10, 0] -> softmax
    p = zero_shot_probs(
        np.array([[3.0, 0.0]]), np.array([[1.0, 0.0], [0.0, 2.0]]), logit_scale=np.log(10.0)
    )
    np.testing.assert_allclose(p, [[1 / (1 + np.exp(-10)), 1 - 1 / (1 + np.exp(-10))]])


def test_folder_path_matches_clipmodel_forward(cat_scene, clip_folder):
    from transformers import AutoTokenizer, CLIPModel

    clip = load_clip(clip_folder, prompts=MAPS["clip_prompts"], runtime="torch")
    assert clip.categories[0] == "automobile" and clip.input_size == 32
    out = clip_drop(cat_scene, clip, category_map=MAPS["clip_category"], progress=False)
    drops = out["clip_drop"].to_numpy()
    assert abs(drops[0]) < 1e-9  # identical render -> 0
    # independent: CLIPModel(input_ids, pixel_values).logits_per_image softmax, true category automobile
    model = CLIPModel.from_pretrained(clip_folder).eval()
    tok = AutoTokenizer.from_pretrained(clip_folder)
    text = tok(
        [MAPS["clip_prompts"][c] for c in clip.categories], padding=True, return_tensors="pt"
    )
    gt = crop_input(data.chelsea(), CAT_BOX, 32) / 255.0
    x = torch.tensor(np.stack([gt, np.zeros_like(gt)]), dtype=torch.float32).permute(0, 3, 1, 2)
    x = (x - torch.tensor(MEAN).view(1, 3, 1, 1)) / torch.tensor(STD).view(1, 3, 1, 1)
    with torch.no_grad():
        logits = model(
            input_ids=text["input_ids"], attention_mask=text["attention_mask"], pixel_values=x
        )
    p = torch.softmax(logits.logits_per_image.double(), 1).numpy()
    assert drops[1] == pytest.approx(p[0, 0] - p[1, 0], abs=1e-5)


def test_blacked_out_render_gives_positive_drop(cat_scene, clip_folder):
    # text feature of the true category = the GT crop's own image embedding; the other four are
    # orthogonal to it, so p(GT, c*) is high and the black render (another embedding) loses it
    base = load_clip(clip_folder, prompts=MAPS["clip_prompts"], runtime="torch")
    g = base.image_features(crop_input(data.chelsea(), CAT_BOX, 32)[None])[0]
    rng = np.random.default_rng(0)
    others = rng.normal(size=(4, g.size))
    others -= np.outer(others @ g / (g @ g), g)
    clip = ZeroShotCLIP(
        base.model, base.categories, np.vstack([g, others]), 32, tuple(MEAN), tuple(STD)
    )
    drops = clip_drop(cat_scene, clip, category_map=MAPS["clip_category"], progress=False)[
        "clip_drop"
    ]
    assert abs(drops.iloc[0]) < 1e-9
    assert drops.iloc[1] > 0


def test_null_category_is_nan_and_unknown_class_is_an_error(cat_scene, clip_folder):
    clip = load_clip(clip_folder, prompts=MAPS["clip_prompts"], runtime="torch")
    pairs = cat_scene.assign(label_class=["misc", "person"])
    out = clip_drop(pairs, clip, category_map=MAPS["clip_category"], progress=False)["clip_drop"]
    assert np.isnan(out.iloc[0]) and np.isfinite(out.iloc[1])
    with pytest.raises(InputError, match="spaceship"):
        clip_drop(
            cat_scene.assign(label_class="spaceship"),
            clip,
            category_map=MAPS["clip_category"],
            progress=False,
        )


def test_cli_clip(cat_scene, clip_folder, tmp_path, capsys):
    rc, path = run_proxy(tmp_path, cat_scene, "clip", "c.parquet", "--clip", str(clip_folder), "--quiet")
    assert rc == 0
    assert pd.read_parquet(path).columns.tolist() == ["pair_id", "clip_drop"]
    timing = pd.read_csv(tmp_path / "c.timing.csv")  # as nvrq score writes one (issue 23 item 8)
    assert timing.columns.tolist() == ["metric", "seconds", "pairs", "runtime", "precision", "threads", "device"]
    assert timing.metric.tolist() == ["clip_drop"] and timing.pairs.tolist() == [2] and timing.seconds[0] > 0
    rc, _ = run_proxy(tmp_path, cat_scene, "clip", "d.csv", "--clip", str(tmp_path / "none"))
    assert rc == 2 and "--clip" in capsys.readouterr().err
