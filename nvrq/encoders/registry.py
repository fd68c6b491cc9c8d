"""The encoder registry: every image encoder NVRQ can use, known in one place, and loaded here.

Layer: nvrq core, encoders.

The specs and the configs are plain data in the leaf module :mod:`nvrq.encoder_specs`
(:class:`EncoderSpec`, :data:`ENCODERS`, :data:`DEFAULT_ENCODER`, :func:`get_spec`,
:class:`EncoderConfig`, :func:`encoder_config`), re-exported here, so that the metrics and the
scoring plan name and check encoders without importing this package. Backends live one per
file (``hf_vit``, ``segformer``, ``efficientnet``); each provides ``load(spec, weights)`` and
``build_random(spec, overrides)`` returning an ``nn.Module`` plus
``embed_tokens(model, pixel_values) -> (B, D)``.

Embedding (paper section 3.3): global average pooling of the final layer's patch tokens,
prefix tokens excluded; for a convolutional encoder, of the final feature map.

>>> spec = get_spec("dinov2-reg-small")
>>> spec.input_size, spec.n_prefix_tokens, spec.tau
(224, 5, 0.65)
>>> sorted(ENCODERS)[:3]
['clip-b16', 'dinov2-base', 'dinov2-reg-base']
"""

from __future__ import annotations

import importlib
from typing import Any, Protocol, runtime_checkable

import numpy as np

from nvrq.encoder_specs import (
    DEFAULT_ENCODER,
    ENCODERS,
    EncoderConfig,
    EncoderSpec,
    encoder_config,
    get_spec,
)
from nvrq.metrics.resolve import encoder_for_metrics

__all__ = ["EncoderSpec", "ENCODERS", "DEFAULT_ENCODER", "get_spec", "Encoder", "TorchEncoder",
           "EncoderConfig", "encoder_config", "encoder_for_metrics", "load_encoder", "build_random",
           "load_for_worker"]


def _backend(spec: EncoderSpec):
    return importlib.import_module(f"nvrq.encoders.{spec.backend}")


class TorchEncoder:
    """An :class:`Encoder` running its torch module (``runtime`` torch, ``precision`` fp32).

    ``embed(images (B, S, S, 3) uint8 RGB) -> (B, D) float32``, ``S = spec.input_size``.
    Normalisation ``(x / 255 - mean) / std`` happens here, on the device, so callers hand over
    plain uint8 crops from :func:`nvrq.crops.encoder_input`. ``threads``: torch's CPU threads
    when it was made (``torch.set_num_threads`` is process-wide: the commands set it from
    ``--threads``; the library leaves it to its caller).

    Parameters
    ----------
    spec : EncoderSpec
        The registry entry.
    model : torch.nn.Module
        The loaded model.
    device : str, optional
        A torch device, ``'cpu'`` or ``'cuda[:k]'``.
    """

    runtime = "torch"
    precision = "fp32"

    def __init__(self, spec: EncoderSpec, model, *, device: str = "cpu"):
        import torch

        self.spec = spec
        self.device = torch.device(device)
        self.threads = torch.get_num_threads()
        self._backend = _backend(spec)
        self.model = model.to(self.device).eval()
        # convolutional backends run ~1.5x faster on CPU with NHWC weights (measured for
        # efficientnet-lite0, batch 32, 1-2 threads); inputs arrive NHWC-strided already
        self.channels_last = bool(getattr(self._backend, "CHANNELS_LAST", False))
        if self.channels_last:
            self.model = self.model.to(memory_format=torch.channels_last)
        self._mean = torch.tensor(spec.mean, dtype=torch.float32, device=self.device).view(1, 3, 1, 1)
        self._std = torch.tensor(spec.std, dtype=torch.float32, device=self.device).view(1, 3, 1, 1)

    def pixel_values(self, images: np.ndarray):
        """uint8 (B, S, S, 3) RGB -> normalised float tensor (B, 3, S, S) on the device."""
        import torch

        from nvrq.crops import normalised_tensor  # OpenCV: not for `nvrq --help`


        images = np.asarray(images)
        s = self.spec.input_size
        if images.dtype != np.uint8 or images.ndim != 4 or images.shape[1:] != (s, s, 3):
            raise ValueError(f"encoder {self.spec.name}: expected uint8 (B, {s}, {s}, 3), "
                             f"got {images.dtype} {images.shape}")
        x = normalised_tensor(images, self._mean, self._std, device=self.device)
        return x.contiguous(memory_format=torch.channels_last) if self.channels_last else x

    def embed(self, images: np.ndarray) -> np.ndarray:
        """Embeddings (B, D) float32 of uint8 RGB encoder inputs (B, S, S, 3)."""
        import torch

        if len(images) == 0:
            return np.zeros((0, 0), np.float32)
        with torch.inference_mode():
            feats = self._backend.embed_tokens(self.model, self.pixel_values(images), self.spec)
        return feats.float().cpu().numpy()


@runtime_checkable
class Encoder(Protocol):
    """What the scoring core needs of a loaded encoder (:func:`load_encoder` returns one).

    ``embed(images)``: uint8 RGB encoder inputs (B, S, S, 3), ``S = spec.input_size`` ->
    embeddings (B, D) float32. ``runtime`` (``torch``, ``openvino``, ``onnxruntime``),
    ``precision`` (``fp32``, ``bf16``, ``int8``), ``threads`` and ``device`` (``str(device)``
    names it, e.g. ``cpu``, ``cuda:0``) say how it runs (the timing table records them).
    :class:`TorchEncoder` and :class:`nvrq.encoders.runtimes.RuntimeEncoder` are the two kinds.
    """

    spec: EncoderSpec
    runtime: str
    precision: str
    threads: int
    device: Any

    def embed(self, images: np.ndarray) -> np.ndarray: ...


def load_encoder(encoder: EncoderConfig | str | None = None, **options) -> Encoder:
    """Load an encoder with real weights from ``weights`` or the local cache, never the net.

    ``encoder``: an :class:`EncoderConfig`, or a registry name with the config's fields as
    keywords (``load_encoder("dinov2-small", device="cuda")``). ``weights``: a Hugging Face
    model folder (transformer encoders, read with ``local_files_only``) or a ``.pth`` state
    dict (efficientnet-lite0). Missing weights raise :class:`InputError` naming the encoder
    and the ways to provide them. A reduced ``precision`` needs a passing drift check on
    record (:mod:`nvrq.encoders.drift`; Spearman >= ``min_spearman``).

    Process-wide settings are left alone: ``nvrq`` commands also set the Hugging Face hub
    offline and tune glibc's allocator (:func:`nvrq.encoders.memory.tune_allocator`, an
    opt-in for API users: ~2x faster CPU batches for efficientnet-lite0).

    Parameters
    ----------
    encoder, **options
        Which encoder and how to run it, as for :func:`encoder_config`.

    Returns
    -------
    Encoder
        ``embed(uint8 (B, S, S, 3)) -> float32 (B, D)``.

    Raises
    ------
    InputError
        Unknown encoder, missing weights, or no passing drift check.
    """
    cfg = encoder_config(encoder, **options)
    spec = get_spec(cfg.name)
    model = _backend(spec).load(spec, cfg.weights)
    return _on_runtime(TorchEncoder(spec, model, device=cfg.device), cfg)


def load_for_worker(encoder: EncoderConfig) -> Encoder:
    """:func:`load_encoder` in a process of an engine's own (a Ray model actor), whose glibc
    allocator is tuned first as the commands tune theirs (:func:`nvrq.encoders.memory.tune_allocator`);
    the loader an engine gives a :class:`~nvrq.scoring.plan.ScorePlan` (``loader``).

    Parameters
    ----------
    encoder : EncoderConfig
        The plan's encoder.

    Returns
    -------
    Encoder
    """
    from nvrq.encoders.memory import tune_allocator

    tune_allocator()
    return load_encoder(encoder)


def build_random(encoder: EncoderConfig | str | None = None, *, seed: int = 0,
                 overrides: dict | None = None, **options) -> Encoder:
    """The encoder's architecture with random weights (tests, speed benchmarks).

    ``overrides`` changes the architecture config (e.g. ``{'num_hidden_layers': 2}``);
    ``encoder`` and ``options`` as in :func:`load_encoder` (the same defaults: ``runtime='auto'``
    exports the random model too; pass ``runtime='torch'`` to get the torch module).

    Parameters
    ----------
    encoder : EncoderConfig, str or None, optional
        A config, a registry name or ``None`` (the default encoder).
    seed : int, optional
        Torch seed of the weights.
    overrides : dict, optional
        Architecture config fields to change.
    **options
        :class:`EncoderConfig` fields.

    Returns
    -------
    Encoder
    """
    import torch

    cfg = encoder_config(encoder, **options)
    spec = get_spec(cfg.name)
    torch.manual_seed(seed)
    model = _backend(spec).build_random(spec, dict(overrides or {}))
    return _on_runtime(TorchEncoder(spec, model, device=cfg.device), cfg)


def _on_runtime(encoder: TorchEncoder, cfg: EncoderConfig) -> Encoder:
    from nvrq.encoders.drift import require_check
    from nvrq.encoders.runtimes import wrap_runtime

    model_file = None
    runtime = cfg.runtime
    if runtime == "auto" and cfg.precision != "fp32":
        runtime = "openvino"  # the only runtime with bf16, and the better int8 (measured)
    if cfg.precision != "fp32":
        model_file = require_check(encoder, runtime=runtime, precision=cfg.precision,
                                   cache_dir=cfg.cache_dir, min_spearman=cfg.min_spearman)
    return wrap_runtime(encoder, runtime=runtime, precision=cfg.precision, threads=cfg.threads,
                        cache_dir=cfg.cache_dir, model_file=model_file)
