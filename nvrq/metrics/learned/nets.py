"""The ImageNet backbones of the learned metrics, in plain torch (no torchvision): AlexNet and
VGG16 as torchvision defines their ``features``, run functionally from the arrays
:func:`nvrq.metrics.learned.weights.component` gives.

- :func:`alexnet_taps`: the five ReLU outputs LPIPS compares (``relu1`` ... ``relu5``): conv
  11x11 stride 4 pad 2, max-pool 3/2, conv 5x5 pad 2, max-pool 3/2, three conv 3x3 pad 1.
- :func:`vgg16_taps`: ``relu1_2``, ``relu2_2``, ``relu3_3``, ``relu4_3``, ``relu5_3``; between
  blocks a 2x2 max-pool (LPIPS) or DISTS' L2 pooling (:func:`l2pool`).

- :func:`alexnet_st_taps`: ST-LPIPS' shift-tolerant AlexNet (Ghildyal and Liu 2022): conv1 at
  stride 1, every stride replaced by :func:`blurpool`, max-pools at stride 1.

Smallest input side (px) each network takes (a pooling needs at least its window):
:data:`MIN_SIDE` -- AlexNet 31 (conv1 gives ``(s - 7) // 4 + 1`` >= 7 so that both 3/2 max-pools
have a window), VGG16 with max-pools 16 (four halvings), with L2 pooling 1 (padded 3x3 windows),
the shift-tolerant AlexNet 21 (its last reflection pad of 2 needs 3 px after conv1, two blur
pools and two 3/1 max-pools).
"""

from __future__ import annotations

from functools import cache

import numpy as np

__all__ = ["MIN_SIDE", "tensors", "alexnet_taps", "vgg16_taps", "l2pool", "blurpool", "alexnet_st_taps"]

MIN_SIDE = {"alexnet": 31, "vgg16": 16, "vgg16_l2": 1, "alexnet_st": 21}

#: VGG16's convolutions per block (13 in all)
_VGG_BLOCKS = (2, 2, 3, 3, 3)


@cache
def tensors(name: str, weights_dir: str | None = None) -> dict:
    """Component ``name``'s arrays as torch tensors (float32, CPU), built once per process.

    Parameters
    ----------
    name : str
        A key of :data:`nvrq.metrics.learned.weights.COMPONENTS`.
    weights_dir : str, optional
        The user folder of weight files.

    Returns
    -------
    dict
        ``{key: torch.Tensor}``, keys as :func:`nvrq.metrics.learned.weights.convert`.
    """
    import torch

    from nvrq.metrics.learned.weights import component

    return {k: torch.from_numpy(np.ascontiguousarray(v, np.float32)) for k, v in component(name, weights_dir).items()}


def alexnet_taps(x, w: dict) -> list:
    """AlexNet's five ReLU outputs.

    Parameters
    ----------
    x : torch.Tensor, (B, 3, H, W) float32
        The scaled input; ``min(H, W) >= MIN_SIDE['alexnet']``.
    w : dict
        ``conv0.weight`` ... ``conv4.bias`` (:func:`tensors` of ``alexnet``).

    Returns
    -------
    list of 5 torch.Tensor
        (B, 64, h1, w1), (B, 192, h2, w2), (B, 384, h3, w3), (B, 256, h3, w3), (B, 256, h3, w3).
    """
    import torch.nn.functional as F

    out = []
    h = F.relu(F.conv2d(x, w["conv0.weight"], w["conv0.bias"], stride=4, padding=2))
    out.append(h)
    h = F.relu(F.conv2d(F.max_pool2d(h, 3, 2), w["conv1.weight"], w["conv1.bias"], padding=2))
    out.append(h)
    h = F.max_pool2d(h, 3, 2)
    for i in (2, 3, 4):
        h = F.relu(F.conv2d(h, w[f"conv{i}.weight"], w[f"conv{i}.bias"], padding=1))
        out.append(h)
    return out


def l2pool(x):
    """DISTS' L2 pooling: ``sqrt(conv(x^2, g) + 1e-12)``, ``g`` the normalised outer product of
    Hann(5)[1:-1] = (0.5, 1, 0.5) with itself, per channel, stride 2, padding 1.

    Parameters
    ----------
    x : torch.Tensor, (B, C, H, W)

    Returns
    -------
    torch.Tensor, (B, C, (H - 1) // 2 + 1, (W - 1) // 2 + 1)
    """
    import torch
    import torch.nn.functional as F

    a = torch.tensor([0.5, 1.0, 0.5], dtype=x.dtype)
    g = (a[:, None] * a[None, :]) / 4.0
    c = x.shape[1]
    out = F.conv2d(x * x, g[None, None].repeat(c, 1, 1, 1), stride=2, padding=1, groups=c)
    return (out + 1e-12).sqrt()


def vgg16_taps(x, w: dict, *, pool: str = "max") -> list:
    """VGG16's ReLU outputs at the end of each block.

    Parameters
    ----------
    x : torch.Tensor, (B, 3, H, W) float32
        The normalised input; ``min(H, W) >= 16`` with ``pool='max'``.
    w : dict
        ``conv0.weight`` ... ``conv12.bias`` (:func:`tensors` of ``vgg16``).
    pool : {'max', 'l2'}
        Between blocks: 2x2 max-pool (LPIPS) or :func:`l2pool` (DISTS).

    Returns
    -------
    list of 5 torch.Tensor
        (B, 64, H, W), (B, 128, H/2, W/2), (B, 256, ...), (B, 512, ...), (B, 512, ...).
    """
    import torch.nn.functional as F

    out, h, i = [], x, 0
    for b, n in enumerate(_VGG_BLOCKS):
        if b:
            h = F.max_pool2d(h, 2, 2) if pool == "max" else l2pool(h)
        for _ in range(n):
            h = F.relu(F.conv2d(h, w[f"conv{i}.weight"], w[f"conv{i}.bias"], padding=1))
            i += 1
        out.append(h)
    return out


def blurpool(x):
    """ST-LPIPS' ``Downsample(filt_size=3, pad_more=True)``: reflection pad 2, the normalised
    outer product of (1, 2, 1) with itself per channel, stride 2.

    Parameters
    ----------
    x : torch.Tensor, (B, C, H, W)
        ``H, W >= 3``.

    Returns
    -------
    torch.Tensor, (B, C, (H + 1) // 2 + 1, (W + 1) // 2 + 1)
    """
    import torch
    import torch.nn.functional as F

    a = torch.tensor([1.0, 2.0, 1.0], dtype=x.dtype)
    g = (a[:, None] * a[None, :]) / 16.0
    c = x.shape[1]
    return F.conv2d(F.pad(x, (2, 2, 2, 2), mode="reflect"), g[None, None].repeat(c, 1, 1, 1), stride=2, groups=c)


def alexnet_st_taps(x, w: dict) -> list:
    """The shift-tolerant AlexNet's five ReLU outputs (ST-LPIPS' ``shift_tolerant`` variant).

    Parameters
    ----------
    x : torch.Tensor, (B, 3, H, W) float32
        The scaled input; ``min(H, W) >= MIN_SIDE['alexnet_st']``.
    w : dict
        ``conv0.weight`` ... ``conv4.bias`` (:func:`tensors` of ``stlpips_alex``).

    Returns
    -------
    list of 5 torch.Tensor
        (B, 64, ...), (B, 192, ...), (B, 384, ...), (B, 256, ...), (B, 256, ...).
    """
    import torch.nn.functional as F

    out = []
    h = F.relu(blurpool(F.conv2d(x, w["conv0.weight"], w["conv0.bias"], padding=2)))
    out.append(h)
    h = F.relu(F.conv2d(blurpool(F.max_pool2d(h, 3, 1)), w["conv1.weight"], w["conv1.bias"], padding=2))
    out.append(h)
    h = blurpool(F.max_pool2d(h, 3, 1))
    for i in (2, 3, 4):
        h = F.relu(F.conv2d(h, w[f"conv{i}.weight"], w[f"conv{i}.bias"], padding=1))
        out.append(h)
    return out
