"""SegFormer-B0 encoder (transformers ``SegformerModel``, the hierarchical Mix Transformer
without the decode head). Input 1024 x 1024 (the Cityscapes checkpoint's resolution, as in
the paper); the embedding is the global average of the last stage's feature map
(B, 256, 32, 32) -> (B, 256).
"""

from __future__ import annotations

import os

from nvrq.encoders.hf_vit import missing_weights_error

__all__ = ["load", "build_random", "embed_tokens"]


def load(spec, weights):
    """Real weights from ``weights`` (a model folder) or the hub cache (``local_files_only``)."""
    from transformers import SegformerModel

    source = os.fspath(weights) if weights is not None else spec.source
    if weights is not None and not os.path.isdir(source):
        raise missing_weights_error(spec, weights)
    try:
        return SegformerModel.from_pretrained(source, local_files_only=True)
    except OSError:
        raise missing_weights_error(spec, weights) from None


def build_random(spec, overrides: dict):
    """SegFormer-B0 architecture (transformers' default ``SegformerConfig``) with random weights."""
    from transformers import SegformerConfig, SegformerModel

    return SegformerModel(SegformerConfig(**{**spec.config, **overrides}))


def embed_tokens(model, pixel_values, spec):
    """GAP of the final feature map (B, C, h, w) -> (B, C)."""
    return model(pixel_values=pixel_values).last_hidden_state.mean(dim=(2, 3))
