"""Acceptance on a synthetic scene with the real efficientnet-lite0 weights (issue 4).

The scene comes from ``nvrq.synth.generate_scene`` (its ``degradation.csv`` holds the latent
render ``severity`` of every object, camera, frame and offset) and ``nvrq.pairs.make_pairs``.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy.stats import spearmanr

from nvrq.crops import cut_box, encoder_input, read_rgb
from nvrq.encoders import load_encoder
from nvrq.metrics.formulas import nvrq_similarity
from nvrq.scoring.driver import score_pairs
from nvrq.scoring.plan import ScorePlan

synth = pytest.importorskip("nvrq.synth.generate")


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    from data_schema.scene import load_scene
    from nvrq.pairs import make_pairs

    root = tmp_path_factory.mktemp("synth") / "scene"
    synth.generate_scene(root, seed=0, seconds=1.0, fps=4.0, offsets=(-3, -1.5, 0, 1.5, 3),
                         cameras=("pinhole",), size=(640, 360), progress=False)
    pairs, _ = make_pairs(load_scene(root), progress=False)
    return root, pairs


@pytest.fixture(scope="module")
def effnet():
    return load_encoder("efficientnet-lite0")


def test_shifted_copy_beats_other_object(scene, effnet):
    root, pairs = scene
    crops = pairs.drop_duplicates(["camera", "timestamp_us", "track_id"]).reset_index(drop=True)
    assert crops["track_id"].nunique() >= 3
    same, shifted, other = [], [], []
    images = {}
    for k, r in enumerate(crops.itertuples()):
        img = images.setdefault(r.gt_path, read_rgb(root / r.gt_path))
        w = img.shape[1]
        dx = 2 if r.gt_x1 + 2 < w else -2  # a 2-pixel horizontal shift that stays in the image
        # the next object at the same frame if there is one, else any other object
        others = crops[(crops.track_id != r.track_id)]
        o = others[others.gt_path == r.gt_path]
        o = (o if len(o) else others).iloc[k % len(o if len(o) else others)]
        oimg = images.setdefault(o.gt_path, read_rgb(root / o.gt_path))
        same.append(encoder_input(cut_box(img, (r.gt_x0, r.gt_y0, r.gt_x1, r.gt_y1)), 224))
        shifted.append(encoder_input(cut_box(img, (r.gt_x0 + dx, r.gt_y0, r.gt_x1 + dx, r.gt_y1)), 224))
        other.append(encoder_input(cut_box(oimg, (o.gt_x0, o.gt_y0, o.gt_x1, o.gt_y1)), 224))
    f0, f1, f2 = (effnet.embed(np.stack(x)) for x in (same, shifted, other))
    s_shift, s_other = nvrq_similarity(f0, f1), nvrq_similarity(f0, f2)
    assert (s_shift > s_other).mean() >= 0.8, (s_shift, s_other)


def test_s_falls_as_severity_rises(scene, effnet):
    root, pairs = scene
    res = score_pairs(pairs, ScorePlan.for_columns(["nvrq:efficientnet-lite0"], encoder=effnet),
                      encoder=effnet, progress=False)
    deg = pd.read_csv(root / "degradation.csv", dtype={"track_id": str, "camera": str})
    keys = ["camera", "timestamp_us", "track_id", "y_offset_m"]
    scored = pairs[keys].assign(s=res.table["nvrq:efficientnet-lite0"].to_numpy())
    merged = scored.merge(deg[keys + ["severity"]], on=keys, how="inner")
    assert len(merged) >= 0.9 * len(pairs)
    rho = spearmanr(merged["s"], merged["severity"]).statistic
    assert rho < -0.3, rho
