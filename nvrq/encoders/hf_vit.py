"""Vision-transformer encoders from Hugging Face ``transformers``: DINOv2, DINOv2 with
registers, CLIP and SigLIP vision towers.

Layer: nvrq core, encoders.

Token layout of ``last_hidden_state`` (B, n_prefix + P, D): DINOv2 ``[CLS, patches]``,
DINOv2-reg ``[CLS, 4 registers, patches]``, CLIP ``[CLS, patches]``, SigLIP ``[patches]``.
The embedding is the mean over the P patch tokens (:func:`pool_patch_tokens`).

Final LayerNorm: DINOv2, DINOv2-reg and SigLIP already return LayerNorm-ed tokens; CLIP's
``last_hidden_state`` is *before* ``post_layernorm`` (transformers only norms the pooled
class token), so :func:`final_tokens` applies ``post_layernorm`` to every CLIP token first.
All ViT embeddings are then averages of final, LayerNorm-ed patch tokens.
"""

from __future__ import annotations

import os

from data_schema.errors import InputError

__all__ = ["ARCHS", "load", "from_local", "from_config", "build_random", "final_tokens", "pool_patch_tokens",
           "embed_tokens"]

#: arch -> (transformers model class, config class)
ARCHS = {
    "dinov2": ("Dinov2Model", "Dinov2Config"),
    "dinov2_reg": ("Dinov2WithRegistersModel", "Dinov2WithRegistersConfig"),
    "clip": ("CLIPVisionModel", "CLIPVisionConfig"),
    "siglip": ("SiglipVisionModel", "SiglipVisionConfig"),
}


def _classes(arch: str):
    import transformers

    model_cls, config_cls = ARCHS[arch]
    return getattr(transformers, model_cls), getattr(transformers, config_cls)


def missing_weights_error(spec, weights) -> InputError:
    """The one-line error for encoder weights that cannot be found (docs/FORMATS.md §4)."""
    where = weights if weights is not None else f"encoder {spec.name}"
    return InputError(
        where, "weights",
        f"weights for encoder {spec.name}: `weights` (a local Hugging Face model folder "
        f"of {spec.source}), or {spec.source} in the Hugging Face hub cache "
        f"(e.g. `huggingface-cli download {spec.source}` on a machine with network; "
        f"nvrq never downloads)",
        "none found")


def load(spec, weights):
    """Real weights from ``weights`` (a model folder) or the hub cache (``local_files_only``).

    Parameters
    ----------
    spec : EncoderSpec
        A ViT registry entry; its ``arch`` picks the transformers class (:data:`ARCHS`).
    weights : str or Path or None
        A local copy of ``spec.source``; ``None``: look for it in the hub cache.

    Returns
    -------
    transformers.PreTrainedModel
        The vision tower of ``spec.arch`` with its trained weights.
    """
    return from_local(_classes(spec.arch)[0], spec, weights)


def from_local(model_cls, spec, weights):
    """``model_cls.from_pretrained`` on the folder ``weights`` or the hub cache, never downloading.

    Missing weights raise the :func:`missing_weights_error` naming the encoder.

    Parameters
    ----------
    model_cls : type
        A ``transformers`` model class.
    spec : EncoderSpec
        The registry entry (its ``source`` is the hub repo id).
    weights : str or Path or None
        A model folder; ``None``: the hub cache.

    Returns
    -------
    transformers.PreTrainedModel
    """
    source = os.fspath(weights) if weights is not None else spec.source
    if weights is not None and not os.path.isdir(source):
        raise missing_weights_error(spec, weights)
    try:
        return model_cls.from_pretrained(source, local_files_only=True)
    except OSError:
        raise missing_weights_error(spec, weights) from None


def from_config(model_cls, config_cls, spec, overrides: dict):
    """``model_cls`` built from ``config_cls(**spec.config, **overrides)``, weights random.

    Parameters
    ----------
    model_cls, config_cls : type
        A ``transformers`` model class and its configuration class.
    spec : EncoderSpec
        The registry entry; ``spec.config`` holds the architecture's config fields.
    overrides : dict
        Config fields that replace those of ``spec.config`` (e.g. a smaller test model).

    Returns
    -------
    transformers.PreTrainedModel
        An untrained ``model_cls``.
    """
    return model_cls(config_cls(**{**spec.config, **overrides}))


def build_random(spec, overrides: dict):
    """The ViT of ``spec.arch`` with random weights (:func:`from_config`).

    Parameters
    ----------
    spec : EncoderSpec
        A ViT registry entry (``arch`` and ``config``).
    overrides : dict
        ViT config fields to change, e.g. ``num_hidden_layers``.

    Returns
    -------
    transformers.PreTrainedModel
        The untrained vision tower.
    """
    return from_config(*_classes(spec.arch), spec, overrides)


def final_tokens(model, pixel_values):
    """Final-layer tokens (B, n_prefix + P, D), LayerNorm-ed for every architecture.

    Parameters
    ----------
    model : transformers.PreTrainedModel
        A vision tower.
    pixel_values : (B, 3, S, S) float32 tensor
        Normalised RGB.

    Returns
    -------
    (B, n_prefix + P, D) float32 tensor
    """
    out = model(pixel_values=pixel_values)
    tokens = out.last_hidden_state
    if type(model).__name__ == "CLIPVisionModel":
        # transformers >= 5 keeps post_layernorm on the model; 4.x on model.vision_model
        inner = getattr(model, "vision_model", model)
        tokens = inner.post_layernorm(tokens)
    return tokens


def pool_patch_tokens(tokens, n_prefix: int):
    """Mean over the patch tokens of ``tokens`` (B, n_prefix + P, D) -> (B, D).

    Parameters
    ----------
    tokens : (B, n_prefix + P, D) tensor
        Final-layer tokens.
    n_prefix : int
        Class and register tokens before the patches.

    Returns
    -------
    (B, D) tensor

    >>> import torch
    >>> t = torch.tensor([[[100.0], [1.0], [3.0]]])  # one prefix token, two patches
    >>> pool_patch_tokens(t, 1).tolist()
    [[2.0]]
    """
    return tokens[:, n_prefix:, :].mean(dim=1)


def embed_tokens(model, pixel_values, spec):
    """Embedding (B, D): GAP of the final patch tokens, prefix tokens excluded.

    Parameters
    ----------
    model : transformers.PreTrainedModel
        The ViT of ``spec`` (:func:`load` or :func:`build_random`).
    pixel_values : (B, 3, S, S) float32 tensor
        Crops normalised with ``spec.mean``/``spec.std``, ``S = spec.input_size``.
    spec : EncoderSpec
        The registry entry; ``n_prefix_tokens`` class/register tokens are left out.

    Returns
    -------
    (B, D) float32 tensor
    """
    return pool_patch_tokens(final_tokens(model, pixel_values), spec.n_prefix_tokens)
