"""DISTS (Ding et al. 2020), as ``DISTS_pytorch`` computes it, in plain torch.

Convention: a crop (H, W, 3) uint8 in [0, 1] (``x / 255``); ImageNet normalisation (mean
``(0.485, 0.456, 0.406)``, std ``(0.229, 0.224, 0.225)``) before VGG16, whose max-pools are
replaced by L2 pooling (:func:`nvrq.metrics.learned.nets.l2pool`). Six feature sets -- the
un-normalised input and the five blocks' last ReLU outputs (3 + 64 + 128 + 256 + 512 + 512 =
1475 channels) -- compared per channel by their global means (``S1 = (2 mx my + c) / (mx^2 +
my^2 + c)``) and covariance (``S2 = (2 cov + c) / (vx + vy + c)``), ``c = 1e-6``, weighted by
the learned alpha and beta (normalised to sum 1): ``DISTS = 1 - sum(alpha S1 + beta S2)``.
0 for identical crops; lower is better. Any side >= 1 px runs (L2 pooling pads).
"""

from __future__ import annotations

from functools import cache

import numpy as np

from nvrq.metrics.learned.batch import check_pair, score_pairs
from nvrq.metrics.learned.nets import MIN_SIDE, tensors, vgg16_taps

__all__ = ["dists", "dists_batch", "prepare", "MIN_SIDE_DISTS"]

MIN_SIDE_DISTS = MIN_SIDE["vgg16_l2"]
_MEAN = (0.485, 0.456, 0.406)
_STD = (0.229, 0.224, 0.225)
_CHNS = (3, 64, 128, 256, 512, 512)


@cache
def _model():
    """``(features, distance)`` of DISTS, its weights loaded once."""
    import torch

    ab = tensors("dists")
    w = tensors("vgg16")
    total = ab["alpha"].sum() + ab["beta"].sum()
    alpha = torch.split((ab["alpha"] / total).view(1, -1), list(_CHNS), dim=1)
    beta = torch.split((ab["beta"] / total).view(1, -1), list(_CHNS), dim=1)
    mean = torch.tensor(_MEAN).view(1, 3, 1, 1)
    std = torch.tensor(_STD).view(1, 3, 1, 1)

    def features(x01):
        return [x01, *vgg16_taps((x01 - mean) / std, w, pool="l2")]

    def distance(fa, fb):
        c = 1e-6
        d1 = d2 = 0
        for k, (x, y) in enumerate(zip(fa, fb, strict=True)):
            mx, my = x.mean((2, 3)), y.mean((2, 3))
            s1 = (2 * mx * my + c) / (mx ** 2 + my ** 2 + c)
            vx = ((x - mx[..., None, None]) ** 2).mean((2, 3))
            vy = ((y - my[..., None, None]) ** 2).mean((2, 3))
            cov = (x * y).mean((2, 3)) - mx * my
            s2 = (2 * cov + c) / (vx + vy + c)
            d1 = d1 + (alpha[k] * s1).sum(1)
            d2 = d2 + (beta[k] * s2).sum(1)
        return 1 - (d1 + d2)

    return features, distance


def prepare() -> None:
    """Load DISTS' weights now (the scoring plan calls it before any crop is read).

    Raises
    ------
    InputError
        When the VGG16 or DISTS weights are not found (the message names the install command).
    """
    from nvrq.metrics.learned.weights import for_metric

    for_metric("dists", _model)


def dists_batch(gt_crops, gt_index, renders) -> np.ndarray:
    """DISTS of P pairs, each unique GT crop run once.

    Parameters
    ----------
    gt_crops : sequence of K (h, w, 3) uint8
        The unique GT crops.
    gt_index : (P,) int
        Pair k's GT crop.
    renders : sequence of P (h, w, 3) uint8
        The render crops resized to their GT crops' shapes.

    Returns
    -------
    (P,) float64
    """
    features, distance = _model()
    return score_pairs(gt_crops, gt_index, renders, features=features, distance=distance, min_side=MIN_SIDE_DISTS)


def dists(gt: np.ndarray, render: np.ndarray) -> float:
    """DISTS between two crops (module docstring).

    Parameters
    ----------
    gt, render : (H, W, 3) uint8
        The GT crop and the render crop resized to it.

    Returns
    -------
    float
        Lower is better; 0 for identical crops.

    Raises
    ------
    InputError
        Weights not found, or crops of other shapes.
    """
    check_pair(gt, render, metric="dists", min_side=MIN_SIDE_DISTS)
    return float(dists_batch([gt], np.zeros(1, np.int64), [render])[0])
