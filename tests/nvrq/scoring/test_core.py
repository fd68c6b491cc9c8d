"""The one crop-scoring core (nvrq.scoring.core) against an independent per-pair computation.

Reference per pair: read both image files with Pillow, slice the inclusive boxes with numpy,
bicubic-resize the render crop to the GT crop's size (docs/FORMATS.md §4; cv2.INTER_CUBIC is the
resampler the spec names), call the registry's metric function; for NVRQ pad each crop to a
black square and resize it here, embed GT and render crops one at a time, and take
``(cos + 1) / 2`` (paper Eq. 4) with SciPy's cosine distance and Eq. 5 written out below.
Every command that scores crops (score, calibrate-tau, stability, the proxies) is checked
against the same kind of reference: pixel metrics to 1e-9, embedding metrics to 1e-6.
"""

from __future__ import annotations

import shutil

import cv2
import numpy as np
import pandas as pd
import pytest
from PIL import Image
from scipy.spatial.distance import cosine

from data_schema.errors import InputError
from nvrq.encoders import build_random
from nvrq.metrics import REGISTRY
from nvrq.scoring.batches import iter_crop_batches
from nvrq.scoring.core import CropBatch, embed_crops, run_batched, score_crop_batch
from nvrq.scoring.driver import score_pairs
from nvrq.scoring.plan import ScorePlan

ENC = "dinov2-small"
TINY = {"num_hidden_layers": 1, "hidden_size": 32, "num_attention_heads": 2, "intermediate_size": 64}
PIXEL = ["psnr", "ssim", "gmsd", "mse", "mae"]


@pytest.fixture(scope="module")
def encoder():
    return build_random(ENC, seed=1, overrides=TINY, runtime="torch")


def _crop(root, rel, box):
    x0, y0, x1, y1 = (int(v) for v in box)
    return np.asarray(Image.open(root / rel).convert("RGB"))[y0:y1 + 1, x0:x1 + 1]


def _square_input(crop, size):
    """Black square pad (content centred, odd pixel bottom/right) + bicubic resize, written out."""
    h, w = crop.shape[:2]
    s = max(h, w)
    sq = np.zeros((s, s, 3), np.uint8)
    sq[(s - h) // 2:(s - h) // 2 + h, (s - w) // 2:(s - w) // 2 + w] = crop
    return sq if s == size else cv2.resize(sq, (size, size), interpolation=cv2.INTER_CUBIC)


def _reference(gt, rc, encoder, tau=None):
    """One pair's metrics, computed alone (``nvrq_ca`` only with a ``tau``)."""
    rs = cv2.resize(rc, (gt.shape[1], gt.shape[0]), interpolation=cv2.INTER_CUBIC) \
        if rc.shape != gt.shape else rc
    out = {m: REGISTRY[m].fn(gt, rs) for m in PIXEL}
    f_gt = encoder.embed(_square_input(gt, 224)[None])[0].astype(np.float64)
    f_r = encoder.embed(_square_input(rc, 224)[None])[0].astype(np.float64)
    s = (1.0 - cosine(f_gt, f_r) + 1.0) / 2.0
    out["nvrq"] = s
    if tau is not None:
        out["nvrq_ca"] = _eq5(s, tau)
    return out


def _eq5(s, tau):
    """Paper Eq. 5 with w = 0.1, one number at a time."""
    return s / tau * 0.1 if s < tau else 0.1 + 0.9 * ((s - tau) / (1 - tau)) ** 2


def _assert_matches(values: dict, refs: list[dict], columns: dict):
    for col, key in columns.items():
        expected = np.array([r[key] for r in refs])
        tol = 1e-6 if key.startswith("nvrq") else 1e-9
        np.testing.assert_allclose(values[col], expected, rtol=0, atol=tol, err_msg=col)


def test_score_pairs_matches_per_pair_reference(tiny_scene, encoder):
    root, pairs = tiny_scene
    pairs = pairs.sample(frac=1.0, random_state=5).reset_index(drop=True)
    enc_cols = {f"nvrq:{ENC}": "nvrq", f"nvrq_ca:{ENC}": "nvrq_ca"}
    refs = [_reference(_crop(root, r.gt_path, (r.gt_x0, r.gt_y0, r.gt_x1, r.gt_y1)),
                       _crop(root, r.render_path, (r.r_x0, r.r_y0, r.r_x1, r.r_y1)), encoder)
            for r in pairs.itertuples()]
    tau = float(np.median([r["nvrq"] for r in refs]))  # both branches of Eq. 5 get used
    for r in refs:
        r["nvrq_ca"] = _eq5(r["nvrq"], tau)
    res = score_pairs(pairs, ScorePlan.for_columns([*PIXEL, *enc_cols], encoder=encoder, tau=tau, batch_size=5, max_pairs=4),
                      encoder=encoder, progress=False)
    assert res.table["pair_id"].tolist() == pairs["pair_id"].tolist()
    _assert_matches(res.table, refs, {m: m for m in PIXEL} | enc_cols)
    # 6 unique GT crops (2 frames x 3 objects) + 18 render crops; 2 GT + 6 render images
    assert (res.n_encoder_images, res.n_images_decoded) == (24, 8)
    assert res.timing["metric"].tolist() == [*PIXEL, *enc_cols]
    assert (res.timing["seconds"] >= res.timing.attrs["decode_seconds"]).all()


def test_batches_keep_gt_images_whole_and_share_gt_crops(tiny_scene):
    root, pairs = tiny_scene
    fg = list(iter_crop_batches(pairs, max_pairs=4, background=False))
    bg = list(iter_crop_batches(pairs, max_pairs=4, background=True))
    # the fixture has 9 pairs per GT image: max_pairs=4 still gives one batch per image
    assert [len(b.rows) for b in fg] == [9, 9]
    assert sorted(np.concatenate([b.rows for b in fg]).tolist()) == list(range(len(pairs)))
    for a, b in zip(fg, bg, strict=True):
        assert len(a.gt_crops) == 3 and a.n_images_decoded == 4  # 3 objects; 1 GT + 3 renders
        assert np.array_equal(a.rows, b.rows) and np.array_equal(a.gt_index, b.gt_index)
        assert all(np.array_equal(x, y) for x, y in zip(a.render_crops, b.render_crops, strict=True))
        assert pairs["gt_path"].iloc[a.rows].nunique() == 1
    # the first batch is the first image alone (the encoder starts sooner); later images pack
    shutil.copy(root / pairs["gt_path"].iloc[0], root / "gt" / "copy.png")
    three = pd.concat([pairs, pairs.iloc[:9].assign(gt_path="gt/copy.png")], ignore_index=True)
    big = list(iter_crop_batches(three, max_pairs=100, background=False))
    assert [len(b.rows) for b in big] == [9, 18] and [len(b.gt_crops) for b in big] == [3, 6]
    assert [b.n_images_decoded for b in big] == [4, 2 + 6]  # GT image(s) + renders, each once


def test_parallel_decoding_gives_the_same_batches(tiny_scene):
    _, pairs = tiny_scene
    one = list(iter_crop_batches(pairs, background=False))
    for background in (False, True):
        many = list(iter_crop_batches(pairs, background=background, decode_threads=3))
        assert [b.rows.tolist() for b in many] == [b.rows.tolist() for b in one]
        for a, b in zip(one, many, strict=True):
            assert a.n_images_decoded == b.n_images_decoded and np.array_equal(a.gt_index, b.gt_index)
            assert all(np.array_equal(x, y) for x, y in zip(a.gt_crops + a.render_crops,
                                                            b.gt_crops + b.render_crops, strict=True))


@pytest.mark.parametrize("background, threads", [(True, 1), (True, 2), (False, 2)])
def test_background_decode_error_reaches_the_caller(tiny_scene, background, threads):
    root, pairs = tiny_scene
    (root / pairs["render_path"].iloc[-1]).write_bytes(b"not an image")  # found, fails to decode
    with pytest.raises(InputError, match="undecodable"):
        list(iter_crop_batches(pairs, max_pairs=2, background=background, decode_threads=threads))


def test_core_names_its_parameters(tiny_scene, encoder):
    gt = np.zeros((5, 5, 3), np.uint8)
    batch = CropBatch(np.array([0]), [gt], np.array([0]), [gt])
    with pytest.raises(InputError, match=r"^tau: "):
        score_crop_batch(batch, ScorePlan.for_columns([f"nvrq_ca:{ENC}"], encoder=encoder, tau=None),
                         encoder=encoder)
    with pytest.raises(InputError, match=r"^encoder: "):
        score_crop_batch(batch, ScorePlan.for_columns([f"nvrq:{ENC}"]))
    with pytest.raises(InputError, match=r"^batch_size: "):
        score_crop_batch(batch, ScorePlan.for_columns(["psnr"], batch_size=0))
    with pytest.raises(InputError, match=r"^metrics: "):
        score_crop_batch(batch, ScorePlan.for_columns(["nope"]))
    with pytest.raises(InputError, match=r"^max_pairs: "):
        iter_crop_batches(tiny_scene[1], max_pairs=0)
    with pytest.raises(InputError, match=r"^decode_threads: "):
        iter_crop_batches(tiny_scene[1], decode_threads=0)


def test_embed_crops_and_run_batched_equal_one_at_a_time(encoder):
    rng = np.random.default_rng(0)
    crops = [rng.integers(0, 256, (h, w, 3), dtype=np.uint8) for h, w in [(30, 50), (64, 20), (224, 224)]]
    one = np.stack([encoder.embed(_square_input(c, 224)[None])[0] for c in crops])
    times: dict = {}
    np.testing.assert_allclose(embed_crops(crops, encoder, batch_size=2, timings=times), one, atol=1e-6)
    assert set(times) == {"prepare", "forward"}
    assert run_batched([], encoder.embed, size=224).shape == (0, 0)


def test_stability_scores_through_the_core(encoder):
    from nvrq.stability import Sample, score_samples

    rng = np.random.default_rng(1)
    gts = [rng.integers(0, 256, (40, 60, 3), dtype=np.uint8), rng.integers(0, 256, (50, 30, 3), dtype=np.uint8)]
    samples = [Sample(o, "x", "artefact", 0.5, rng.integers(0, 256, (30 + 5 * k, 44, 3), dtype=np.uint8))
               for k, o in enumerate([0, 0, 0, 1, 1])]
    cols = {m: m for m in PIXEL} | {f"nvrq:{ENC}": "nvrq", f"nvrq_ca:{ENC}": "nvrq_ca"}
    got = score_samples(gts, samples, ScorePlan.for_columns(list(cols), encoder=encoder, tau=0.5, batch_size=3, max_pairs=2),
                        encoder=encoder, progress=False)
    _assert_matches(got, [_reference(gts[s.obj], s.crop, encoder, 0.5) for s in samples], cols)


def test_calibrate_embeds_gt_crops_through_the_core(tiny_scene, encoder):
    from nvrq.calibrate import calibrate_tau

    root, pairs = tiny_scene
    cal = calibrate_tau(pairs, encoder, max_crops=10, batch_size=4, progress=False)
    crops = pairs.drop_duplicates(subset=["camera", "track_id", "timestamp_us", "gt_path"])
    feats = {(r.track_id, r.timestamp_us): encoder.embed(_square_input(
        _crop(root, r.gt_path, (r.gt_x0, r.gt_y0, r.gt_x1, r.gt_y1)), 224)[None])[0].astype(np.float64)
        for r in crops.itertuples()}
    # 3 objects of 3 classes at 2 frames: every pair of crops of different tracks is unrelated
    keys = list(feats)
    expected = sorted((1.0 - cosine(feats[a], feats[b]) + 1.0) / 2.0
                      for i, a in enumerate(keys) for b in keys[i + 1:] if a[0] != b[0])
    np.testing.assert_allclose(np.sort(cal.s), expected, rtol=0, atol=1e-6)
