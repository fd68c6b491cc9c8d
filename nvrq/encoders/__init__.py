"""Image encoders for NVRQ: the registry (:mod:`nvrq.encoders.registry`) and one backend

Layer: nvrq core, encoders.
module per model family (``hf_vit``, ``segformer``, ``efficientnet``)."""

from nvrq.encoders.registry import (
    DEFAULT_ENCODER,
    ENCODERS,
    Encoder,
    EncoderConfig,
    EncoderSpec,
    TorchEncoder,
    build_random,
    encoder_config,
    encoder_for_metrics,
    get_spec,
    load_encoder,
)

__all__ = ["DEFAULT_ENCODER", "ENCODERS", "Encoder", "EncoderConfig", "EncoderSpec", "TorchEncoder",
           "build_random", "encoder_config", "encoder_for_metrics", "get_spec", "load_encoder"]

# a submodule (e.g. nvrq.encoders.<module>) resolves on first use after a plain import of the package
from nvrq.lazy import lazy_exports  # noqa: E402

__getattr__, __dir__ = lazy_exports("nvrq.encoders", {}, globals())
