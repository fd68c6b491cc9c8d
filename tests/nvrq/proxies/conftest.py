"""Fixtures for the proxy tests: a tiny on-disk "scene" of one GT image and two renders."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from PIL import Image

from data_schema.tables import PAIRS_COLUMNS, pair_id
from nvrq.cli import main

#: the cat of scikit-image's 'chelsea' photo (300 x 451), inclusive box
CAT_BOX = (100, 20, 330, 290)
CLIP_MEAN, CLIP_STD = [0.48, 0.45, 0.40], [0.26, 0.26, 0.27]


@pytest.fixture
def cat_scene(tmp_path):
    """GT = chelsea; renders: identical copy (+0.00 m) and the cat box blacked out (+1.00 m).

    Returns pairs (docs/FORMATS.md §3 columns + scene_root): row 0 identical, row 1 blacked out.
    """
    from skimage import data

    gt = data.chelsea()
    black = gt.copy()
    x0, y0, x1, y1 = CAT_BOX
    black[y0 : y1 + 1, x0 : x1 + 1] = 0
    Image.fromarray(gt).save(tmp_path / "gt.png")
    Image.fromarray(gt).save(tmp_path / "r0.png")
    Image.fromarray(black).save(tmp_path / "r1.png")
    rows = []
    for off, path, cls in ((0.0, "r0.png", "automobile"), (1.0, "r1.png", "automobile")):
        rows.append(
            dict(
                pair_id=pair_id("c", "front", "cat", 0, off), clip_id="c", camera="front",
                track_id="cat", label_class=cls, timestamp_us=0, y_offset_m=off,
                gt_path="gt.png", render_path=path,
                gt_x0=x0, gt_y0=y0, gt_x1=x1, gt_y1=y1, r_x0=x0, r_y0=y0, r_x1=x1, r_y1=y1,
            )
        )
    pairs = pd.DataFrame(rows, columns=list(PAIRS_COLUMNS))
    pairs["scene_root"] = str(tmp_path)
    return pairs


def crop_input(image: np.ndarray, box, size: int) -> np.ndarray:
    """Independent encoder input: black square pad (content centred) + bicubic resize (docs/FORMATS.md §4), re-implemented here."""
    x0, y0, x1, y1 = box
    crop = image[y0 : y1 + 1, x0 : x1 + 1]
    h, w = crop.shape[:2]
    s = max(h, w)
    sq = np.zeros((s, s, 3), np.uint8)
    sq[(s - h) // 2 : (s - h) // 2 + h, (s - w) // 2 : (s - w) // 2 + w] = crop
    import cv2

    return cv2.resize(sq, (size, size), interpolation=cv2.INTER_CUBIC)


def run_proxy(tmp_path, pairs: pd.DataFrame, kind: str, out_name: str, *options: str):
    """Write ``pairs`` to ``tmp_path/pairs.csv``, run ``nvrq proxy KIND pairs.csv --out OUT
    OPTIONS...`` and return ``(exit status, OUT path)``."""
    pairs.to_csv(tmp_path / "pairs.csv", index=False)
    out = tmp_path / out_name
    return main(["proxy", kind, str(tmp_path / "pairs.csv"), "--out", str(out), *options]), out


@pytest.fixture(scope="session")
def clip_folder(tmp_path_factory):
    """A tiny random-weight CLIP folder: CLIPModel, a hand-made BPE tokenizer, preprocessor config."""
    import torch
    from transformers import CLIPConfig, CLIPModel, CLIPTokenizer

    d = tmp_path_factory.mktemp("tinyclip")
    vocab = {"<|startoftext|>": 0, "<|endoftext|>": 1}
    for ch in "abcdefghijklmnopqrstuvwxyz":
        vocab[ch] = len(vocab)
        vocab[ch + "</w>"] = len(vocab)
    vocab.update({"in": len(vocab), "er": len(vocab) + 1})
    (d / "vocab.json").write_text(json.dumps(vocab))
    (d / "merges.txt").write_text("#version: 0.2\ni n\ne r\n")
    CLIPTokenizer(str(d / "vocab.json"), str(d / "merges.txt")).save_pretrained(d)
    torch.manual_seed(0)
    tiny = dict(hidden_size=32, intermediate_size=64, num_hidden_layers=2, num_attention_heads=2)
    cfg = CLIPConfig(
        text_config=dict(tiny, vocab_size=len(vocab) + 2, max_position_embeddings=160,
                         bos_token_id=0, eos_token_id=1, pad_token_id=1),
        vision_config=dict(tiny, image_size=32, patch_size=8),
        projection_dim=16,
    )
    CLIPModel(cfg).save_pretrained(d)
    (d / "preprocessor_config.json").write_text(
        json.dumps({"image_mean": CLIP_MEAN, "image_std": CLIP_STD, "crop_size": {"height": 32, "width": 32}})
    )
    return d
