"""Encoder registry: token layout, GAP over patch tokens only, CLIP's final LayerNorm,
efficientnet-lite0's normalisation, missing weights."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from data_schema.errors import InputError
from nvrq.crops import encoder_input
from nvrq.encoders import ENCODERS, build_random, get_spec, load_encoder
from nvrq.encoders.hf_vit import final_tokens

SMALL = {"num_hidden_layers": 2}


def _images(n, size, seed=0):
    return np.random.default_rng(seed).integers(0, 256, (n, size, size, 3), dtype=np.uint8)


def _perturb_hook(positions, scale=50.0):
    """Forward hook adding large noise to the given token positions of a module's output."""
    def hook(module, inputs, output):
        out = output.clone()
        g = torch.Generator().manual_seed(1)
        out[:, positions] += scale * torch.randn(out[:, positions].shape, generator=g)
        return out
    return hook


@pytest.mark.parametrize("name, final_norm, n_prefix", [
    ("dinov2-small", "layernorm", 1),       # [CLS, patches]
    ("dinov2-reg-small", "layernorm", 5),   # [CLS, 4 registers, patches]
    ("clip-b16", "post_layernorm", 1),      # [CLS, patches]; we apply post_layernorm to all tokens
])
def test_gap_excludes_class_and_register_tokens(name, final_norm, n_prefix):
    enc = build_random(name, overrides=SMALL, runtime="torch")
    assert enc.spec.n_prefix_tokens == n_prefix
    x = _images(2, 224)
    base = enc.embed(x)
    norm = getattr(enc.model, final_norm)
    # perturb exactly the prefix tokens of the final-layer output: the embedding must not move
    h = norm.register_forward_hook(_perturb_hook(list(range(n_prefix))))
    np.testing.assert_array_equal(enc.embed(x), base)
    h.remove()
    # perturbing the first patch token instead must move it (so the check above can fail)
    h = norm.register_forward_hook(_perturb_hook([n_prefix]))
    assert np.abs(enc.embed(x) - base).max() > 1e-2
    h.remove()


def test_token_count_matches_layout():
    # DINOv2-reg at 224 with patch 14: 16 x 16 = 256 patches + 1 CLS + 4 registers
    enc = build_random("dinov2-reg-small", overrides=SMALL, runtime="torch")
    with torch.inference_mode():
        tokens = final_tokens(enc.model, enc.pixel_values(_images(1, 224)))
    assert tokens.shape == (1, 256 + 5, 384)


def test_clip_pools_post_layernormed_patch_tokens():
    # Choice (documented in hf_vit): CLIP's last_hidden_state is pre-LayerNorm; we apply
    # post_layernorm per token, then average the patch tokens (index 1 onwards).
    enc = build_random("clip-b16", overrides=SMALL, runtime="torch")
    x = _images(2, 224, seed=3)
    with torch.inference_mode():
        pv = enc.pixel_values(x)
        raw = enc.model(pixel_values=pv).last_hidden_state
        want = enc.model.post_layernorm(raw)[:, 1:].mean(1).numpy()
        unnormed = raw[:, 1:].mean(1).numpy()
    np.testing.assert_allclose(enc.embed(x), want, rtol=1e-5, atol=1e-5)
    assert np.abs(enc.embed(x) - unnormed).max() > 1e-2


def test_siglip_has_no_prefix_and_segformer_pools_feature_map():
    enc = build_random("siglip-b16", overrides=SMALL, runtime="torch")
    x = _images(1, 224)
    with torch.inference_mode():
        tokens = enc.model(pixel_values=enc.pixel_values(x)).last_hidden_state
    assert tokens.shape[1] == 196  # 14 x 14 patches, no class token
    np.testing.assert_allclose(enc.embed(x), tokens.mean(1).numpy(), rtol=1e-5, atol=1e-6)
    assert get_spec("segformer-b0").input_size == 1024  # paper: SegFormer at 1024


def test_registry_constants():
    # taus from docs/FORMATS.md §4 / the paper
    assert {n: ENCODERS[n].tau for n in ["dinov2-small", "dinov2-reg-base", "clip-b16",
                                         "siglip-b16", "segformer-b0"]} == {
        "dinov2-small": 0.65, "dinov2-reg-base": 0.65, "clip-b16": 0.70, "siglip-b16": 0.55,
        "segformer-b0": 0.50}
    assert get_spec("clip-b16").mean == pytest.approx((0.48145466, 0.4578275, 0.40821073))
    with pytest.raises(InputError, match="^encoder: expected one of"):  # the parameter; the CLI says --encoder
        get_spec("resnet-9000")


def test_efficientnet_normalisation_and_rgb_order_classify_known_photos():
    # Independent reference: ImageNet labels of scikit-image's sample photos. With the
    # registry's (x - 127) / 128 on RGB, the real weights give 'espresso' (967) > 0.7 for
    # 'coffee' and 'Egyptian cat' (285) > 0.65 for 'chelsea'; feeding BGR drops both < 0.5.
    skd = pytest.importorskip("skimage.data")
    enc = load_encoder("efficientnet-lite0", runtime="torch")  # the torch module, ImageNet head included
    for img, cls, floor in [(skd.coffee(), 967, 0.7), (skd.chelsea(), 285, 0.65)]:
        with torch.inference_mode():
            p = enc.model(enc.pixel_values(encoder_input(img, 224)[None])).softmax(-1)[0]
            p_bgr = enc.model(enc.pixel_values(encoder_input(img[..., ::-1].copy(), 224)[None])).softmax(-1)[0]
        assert int(p.argmax()) == cls and float(p[cls]) > floor
        assert float(p_bgr[cls]) < 0.5


def test_identical_crops_give_s_one():
    from nvrq.metrics.formulas import nvrq_similarity

    enc = load_encoder("efficientnet-lite0")
    x = _images(3, 224, seed=5)
    f = enc.embed(x)
    np.testing.assert_allclose(nvrq_similarity(f, enc.embed(x.copy())), 1.0, atol=1e-6)


def test_missing_weights_is_input_error_naming_encoder(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("HF_HOME", str(tmp_path / "hf"))  # an empty hub cache
    monkeypatch.setenv("HF_HUB_CACHE", str(tmp_path / "hf" / "hub"))
    with pytest.raises(InputError) as err:
        load_encoder("dinov2-small")
    msg = str(err.value)
    assert "dinov2-small" in msg and "`weights` (a local" in msg and "facebook/dinov2-small" in msg
    # the command line names its option instead (nvrq.cli_types.flags_in_errors)
    from nvrq.cli import main
    from nvrq.scoring.driver import REQUIRED_COLUMNS

    (tmp_path / "p.csv").write_text(",".join(REQUIRED_COLUMNS) + "\n")
    assert main(["score", str(tmp_path / "p.csv"), "--out", str(tmp_path / "m.csv"), "--metrics", "nvrq",
                 "--encoder", "dinov2-small", "--quiet"]) == 2
    cli = capsys.readouterr().err
    assert "expected weights for encoder dinov2-small: --weights (a local" in cli and "`weights`" not in cli
    (tmp_path / "empty").mkdir()
    with pytest.raises(InputError, match="dinov2-reg-small"):
        load_encoder("dinov2-reg-small", weights=tmp_path / "empty")  # a folder without weights
    with pytest.raises(InputError, match="siglip-b16"):
        load_encoder("siglip-b16", weights=tmp_path / "not-there")
    with pytest.raises(InputError, match="efficientnet-lite0"):
        load_encoder("efficientnet-lite0", weights=tmp_path / "missing.pth")
