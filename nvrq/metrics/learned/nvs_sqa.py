"""NVS-SQA (Qu et al. 2025), the no-reference quality of a set of synthesised views, as the
``nvs-sqa`` package (0.1.1, model v0.0.1) predicts it, in plain torch.

The model, as its configuration file says (``TransEncoder``, RGB, ``normal`` view encoder,
view features 192 + low-level 24 + 48 + 96 = 360, 2 layers, 6 heads, ``last`` fusion, 384
outputs):

- each view, (H, W, 3) uint8 -> ``x / 255`` (no normalisation), goes through the view
  encoder: a 5x5/2 and a 3x3/2 convolution (no padding), then three stages of two
  "double convolutions" (3x3, reflect padding, batch norm, SiLU, a residual where the shapes
  agree) each followed by a 2x2 max-pool, a 1x1 convolution to 192 channels, global average
  pooling and a linear layer; after the first convolutions and the first two stages a
  low-level branch (2x2 max-pool, a double convolution, global average) adds 24, 48 and 96
  features;
- the views' 360 features, in order, plus sinusoidal position encodings, go through a
  2-layer transformer encoder (post-norm, ReLU feed-forward of 2048); the last view's output
  goes through a linear layer to the 384 quality features;
- the package's ridge regressor maps them to a JOD-like score (mostly negative, higher is
  better; comparable within a scene).

The package scores a folder of views of one scene. This toolkit scores each render crop as
a set of one view (column ``nvs_sqa``, kind ``render``), as the NVRQ paper's Table 1 scores
crops: a crop's neighbours in a sequence are other objects' crops or the same object at
other distances, which the model never saw as one scene. :func:`nvs_sqa_views` scores a
whole set of views, as the package does. Views smaller than :data:`MIN_SIDE` px give NaN.
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import cache

import numpy as np

from data_schema.errors import InputError
from nvrq.metrics.learned.batch import to_tensor

__all__ = ["nvs_sqa", "nvs_sqa_views", "features", "prepare", "MIN_SIDE", "D_MODEL", "N_HEADS"]

#: the shorter view side (px) the view encoder takes: after its two stride-2 convolutions and
#: two halvings the last low-level branch halves once more and pads by reflection, which needs 2 px
MIN_SIDE = 69
D_MODEL, N_HEADS, N_LAYERS = 360, 6, 2


@cache
def _weights():
    """The model's tensors and the regressor's arrays, loaded once."""
    import torch

    from nvrq.metrics.learned.weights import component

    sd = {k: torch.from_numpy(np.ascontiguousarray(v, np.float32)) for k, v in component("nvs_sqa").items()}
    return sd, component("nvs_sqa_ridge")


def prepare() -> None:
    """Load NVS-SQA's model and regressor now (the scoring plan calls it before any crop is read).

    Raises
    ------
    InputError
        When they are not found (the message names ``pip install --no-deps nvs-sqa``).
    """
    from nvrq.metrics.learned.weights import for_metric

    for_metric("nvs_sqa", _weights)


def _conv(x, w: dict, p: str, *, stride: int, pad: int):
    import torch.nn.functional as F

    if pad:
        x = F.pad(x, (pad,) * 4, mode="reflect")
    x = F.conv2d(x, w[f"{p}.weight"], w[f"{p}.bias"], stride=stride)
    return x


def _bn(x, w: dict, p: str):
    import torch.nn.functional as F

    return F.batch_norm(x, w[f"{p}.running_mean"], w[f"{p}.running_var"], w[f"{p}.weight"], w[f"{p}.bias"],
                        training=False, eps=1e-5)


def _double(x, w: dict, p: str, *, stride=(1, 1), pad: int = 1):
    """The package's ``double_conv``: (conv, batch norm, SiLU) twice, a residual if shapes agree."""
    import torch.nn.functional as F

    h = F.silu(_bn(_conv(x, w, f"{p}.convna.0", stride=stride[0], pad=pad), w, f"{p}.convna.1"))
    h = F.silu(_bn(_conv(h, w, f"{p}.convna.3", stride=stride[1], pad=pad), w, f"{p}.convna.4"))
    return x + h if h.shape == x.shape else h


def _view_features(x, w: dict):
    """(B, 3, H, W) in [0, 1] -> (B, 360): low-level 24 + 48 + 96, then 192."""
    import torch
    import torch.nn.functional as F

    e = "view_encoder"
    x = _double(x, w, f"{e}.conv_0", stride=(2, 2), pad=0)
    low = []

    def branch(h, i):
        h = _double(F.max_pool2d(h, 2), w, f"{e}.low_level_convs.{i}.1")
        low.append(h.mean((2, 3)))

    branch(x, 0)
    for a, b, i in (("fused_conv_1", "fused_conv_2", 1), ("fused_conv_3", "fused_conv_4", 2),
                    ("dwise_conv_1", "dwise_conv_2", None)):
        x = F.max_pool2d(_double(_double(x, w, f"{e}.{a}"), w, f"{e}.{b}"), 2)
        if i is not None:
            branch(x, i)
    h = F.silu(_bn(F.conv2d(x, w[f"{e}.pwise_conv.convna.0.weight"], w[f"{e}.pwise_conv.convna.0.bias"]), w,
                   f"{e}.pwise_conv.convna.1"))
    x = h + x if h.shape == x.shape else h
    x = F.linear(x.mean((2, 3)), w[f"{e}.out_feats.weight"], w[f"{e}.out_feats.bias"])
    return torch.cat([*low, x], dim=1)


def _encoder_layer(x, w: dict, p: str):
    """torch's post-norm ``TransformerEncoderLayer`` (ReLU, eval): x (S, D) -> (S, D)."""
    import torch.nn.functional as F

    s, d = x.shape
    hd = d // N_HEADS
    q, k, v = F.linear(x, w[f"{p}.self_attn.in_proj_weight"], w[f"{p}.self_attn.in_proj_bias"]).chunk(3, dim=-1)
    q, k, v = (t.reshape(s, N_HEADS, hd).transpose(0, 1) for t in (q, k, v))
    att = ((q @ k.transpose(1, 2)) / hd ** 0.5).softmax(-1) @ v
    att = F.linear(att.transpose(0, 1).reshape(s, d), w[f"{p}.self_attn.out_proj.weight"], w[f"{p}.self_attn.out_proj.bias"])
    x = F.layer_norm(x + att, (d,), w[f"{p}.norm1.weight"], w[f"{p}.norm1.bias"], eps=1e-5)
    ff = F.linear(F.relu(F.linear(x, w[f"{p}.linear1.weight"], w[f"{p}.linear1.bias"])), w[f"{p}.linear2.weight"],
                  w[f"{p}.linear2.bias"])
    return F.layer_norm(x + ff, (d,), w[f"{p}.norm2.weight"], w[f"{p}.norm2.bias"], eps=1e-5)


def _position(n: int):
    """Sinusoidal encodings (n, 360): sin on even, cos on odd features."""
    import torch

    div = torch.exp(torch.arange(0, D_MODEL, 2) * -(torch.log(torch.tensor(10000.0)) / D_MODEL))
    pos = torch.arange(n).unsqueeze(1)
    pe = torch.zeros(n, D_MODEL)
    pe[:, 0::2] = torch.sin(pos * div)
    pe[:, 1::2] = torch.cos(pos * div)
    return pe


def features(views: Sequence[np.ndarray]) -> np.ndarray:
    """NVS-SQA's 384 quality features of one set of views.

    Parameters
    ----------
    views : sequence of V (H, W, 3) uint8
        The views, in order, of one shape; shorter side >= :data:`MIN_SIDE`.

    Returns
    -------
    (384,) float64
    """
    import torch
    import torch.nn.functional as F

    w, _ = _weights()
    with torch.inference_mode():
        f = torch.cat([_view_features(to_tensor(np.stack(views[k:k + 10])), w) for k in range(0, len(views), 10)])
        x = f + _position(len(views))
        for i in range(N_LAYERS):
            x = _encoder_layer(x, w, f"angular_encoder.layers.{i}")
        return F.linear(x[-1], w["fc.weight"], w["fc.bias"]).double().numpy()


def _check_views(views) -> list[np.ndarray]:
    views = list(views)
    if not views:
        raise InputError(param="views", expected="at least one view", got="none")
    shape = getattr(views[0], "shape", None)
    for k, v in enumerate(views):
        if not isinstance(v, np.ndarray) or v.dtype != np.uint8 or v.ndim != 3 or v.shape[2] != 3 or v.shape != shape:
            raise InputError(param="views", field=str(k), expected=f"uint8 (H, W, 3) RGB views of one shape {shape}",
                             got=getattr(v, "shape", type(v).__name__))
    if min(shape[:2]) < MIN_SIDE:
        raise InputError(param="views", expected=f"views whose shorter side is at least {MIN_SIDE} px (the network's "
                         "smallest input)", got=f"{shape[0]} x {shape[1]} px")
    return views


def nvs_sqa_views(views: Sequence[np.ndarray]) -> float:
    """NVS-SQA of one set of views, as the package's ``QualityAssessor`` scores one folder.

    Parameters
    ----------
    views : sequence of V (H, W, 3) uint8
        The views, in order, of one shape; shorter side >= :data:`MIN_SIDE` px.

    Returns
    -------
    float
        The regressor's score (higher is better).

    Raises
    ------
    InputError
        Weights not found, no views, views of several shapes or smaller than :data:`MIN_SIDE`.
    """
    views = _check_views(views)
    _, ridge = _weights()
    return float(features(views) @ ridge["coef"] + ridge["intercept"][0])


def _nvs_sqa(render: np.ndarray) -> float:
    """:func:`nvs_sqa` without the check: NaN below :data:`MIN_SIDE`."""
    if min(render.shape[:2]) < MIN_SIDE:
        return float("nan")
    _, ridge = _weights()
    return float(features([render]) @ ridge["coef"] + ridge["intercept"][0])


def nvs_sqa(render: np.ndarray) -> float:
    """NVS-SQA of one render crop, scored as a set of one view (module docstring).

    Parameters
    ----------
    render : (H, W, 3) uint8
        The raw render crop; shorter side >= :data:`MIN_SIDE` px.

    Returns
    -------
    float
        Higher is better.

    Raises
    ------
    InputError
        Weights not found, or a crop that is not (H, W, 3) uint8 or is too small.
    """
    return nvs_sqa_views([render])
