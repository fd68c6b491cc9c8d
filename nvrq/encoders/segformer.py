"""SegFormer-B0 encoder (transformers ``SegformerModel``, the hierarchical Mix Transformer
without the decode head). Input 1024 x 1024 (the Cityscapes checkpoint's resolution, as in
the paper); the embedding is the global average of the last stage's feature map
(B, 256, 32, 32) -> (B, 256).

Layer: nvrq core, encoders.
"""

from __future__ import annotations

from nvrq.encoders.hf_vit import from_config, from_local

__all__ = ["load", "build_random", "embed_tokens"]


def load(spec, weights):
    """Real weights from ``weights`` (a model folder) or the hub cache (``local_files_only``).

    Parameters
    ----------
    spec : EncoderSpec
        The SegFormer-B0 entry; ``spec.source`` is the Cityscapes checkpoint's hub id.
    weights : str or Path or None
        That checkpoint's folder; ``None``: the hub cache.

    Returns
    -------
    transformers.SegformerModel
        The Mix Transformer; a checkpoint's decode head is not loaded.
    """
    from transformers import SegformerModel

    return from_local(SegformerModel, spec, weights)


def build_random(spec, overrides: dict):
    """SegFormer-B0 architecture (transformers' default ``SegformerConfig``) with random weights.

    Parameters
    ----------
    spec : EncoderSpec
        The SegFormer-B0 entry (its ``config``, applied over the defaults).
    overrides : dict
        Fields of ``SegformerConfig`` to change, e.g. ``hidden_sizes``.

    Returns
    -------
    transformers.SegformerModel
        The untrained Mix Transformer (:func:`~nvrq.encoders.hf_vit.from_config`).
    """
    from transformers import SegformerConfig, SegformerModel

    return from_config(SegformerModel, SegformerConfig, spec, overrides)


def embed_tokens(model, pixel_values, spec):
    """GAP of the final feature map (B, C, h, w) -> (B, C).

    Parameters
    ----------
    model : transformers.SegformerModel
        The encoder.
    pixel_values : (B, 3, 1024, 1024) float32 tensor
        Normalised RGB.
    spec : EncoderSpec
        The registry entry (unused).

    Returns
    -------
    (B, C) float32 tensor
        ``C = 256`` for B0.
    """
    return model(pixel_values=pixel_values).last_hidden_state.mean(dim=(2, 3))
