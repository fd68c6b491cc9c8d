"""How the learned metrics run over a batch of crop pairs (torch imported on first use).

Each pair is the GT crop and the render crop resized to it (docs/FORMATS.md §4), so the pairs of
one GT crop share its shape. :func:`score_pairs` groups the pairs by that shape, runs each unique
GT crop through the network once and the render crops ``chunk`` at a time, and gives NaN to the
pairs whose shorter side is below the network's minimum. :func:`check_pair` is the public
functions' input check.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from data_schema.errors import InputError

__all__ = ["score_pairs", "check_pair", "to_tensor", "CHUNK"]

#: images per forward pass
CHUNK = 16


def to_tensor(crops: np.ndarray):
    """uint8 (B, H, W, 3) RGB -> torch float32 (B, 3, H, W) in [0, 1].

    Parameters
    ----------
    crops : (B, H, W, 3) uint8

    Returns
    -------
    torch.Tensor, (B, 3, H, W) float32
    """
    import torch

    return torch.from_numpy(np.ascontiguousarray(crops)).permute(0, 3, 1, 2).float().div_(255.0)


def check_pair(gt: np.ndarray, render: np.ndarray, *, metric: str, min_side: int) -> None:
    """InputError unless ``gt`` and ``render`` are uint8 (H, W, 3) crops of one shape whose
    shorter side is at least ``min_side``.

    Parameters
    ----------
    gt, render : (H, W, 3) uint8
        The GT crop and the render crop resized to it.
    metric : str
        The metric (named in the message).
    min_side : int
        The network's smallest side (px).

    Raises
    ------
    InputError
        Naming ``gt`` or ``render``.

    >>> check_pair(np.zeros((8, 40, 3), np.uint8), np.zeros((8, 40, 3), np.uint8), metric="lpips", min_side=31)
    Traceback (most recent call last):
    ...
    data_schema.errors.InputError: gt: lpips: expected a crop whose shorter side is at least 31 px (the network's smallest input), got 8 x 40 px
    """
    for param, a in (("gt", gt), ("render", render)):
        if not isinstance(a, np.ndarray) or a.dtype != np.uint8 or a.ndim != 3 or a.shape[2] != 3:
            raise InputError(param=param, field=metric, expected="a uint8 (H, W, 3) RGB crop",
                             got=getattr(a, "shape", type(a).__name__))
    if render.shape != gt.shape:
        raise InputError(param="render", field=metric, expected=f"a crop of the GT crop's shape {gt.shape} (resized to it)",
                         got=render.shape)
    if min(gt.shape[:2]) < min_side:
        raise InputError(param="gt", field=metric, expected=f"a crop whose shorter side is at least {min_side} px "
                         "(the network's smallest input)", got=f"{gt.shape[0]} x {gt.shape[1]} px")


def _forward(crops: Sequence[np.ndarray], features: Callable, chunk: int) -> list:
    """``features`` of ``crops`` (one shape), ``chunk`` at a time, concatenated per tap."""
    import torch

    parts = [features(to_tensor(np.stack(crops[k:k + chunk]))) for k in range(0, len(crops), chunk)]
    return [torch.cat(taps) for taps in zip(*parts, strict=True)]


def score_pairs(gt_crops: Sequence[np.ndarray], gt_index: np.ndarray, renders: Sequence[np.ndarray], *,
                features: Callable, distance: Callable, min_side: int, chunk: int = CHUNK) -> np.ndarray:
    """A learned metric over pairs, each unique GT crop run once.

    Parameters
    ----------
    gt_crops : sequence of K (h, w, 3) uint8
        The unique GT crops.
    gt_index : (P,) int
        Pair k's GT crop is ``gt_crops[gt_index[k]]``.
    renders : sequence of P (h, w, 3) uint8
        Render crop k resized to its GT crop's shape.
    features : callable
        torch (B, 3, H, W) in [0, 1] -> list of taps (B, C, h, w).
    distance : callable
        ``(taps_gt, taps_render) -> (B,)`` torch, taps of B pairs.
    min_side : int
        Pairs whose shorter side is smaller get NaN.
    chunk : int
        Images per forward pass.

    Returns
    -------
    (P,) float64
    """
    import torch

    gt_index = np.asarray(gt_index, np.int64)
    out = np.full(len(renders), np.nan)
    groups: dict[tuple, list[int]] = {}
    for k, shape in enumerate(g.shape for g in gt_crops):
        if min(shape[:2]) >= min_side:
            groups.setdefault(tuple(shape), []).append(k)
    with torch.inference_mode():
        for gts in groups.values():
            pos = np.full(len(gt_crops), -1)
            pos[gts] = np.arange(len(gts))
            pairs = np.flatnonzero(pos[gt_index] >= 0)
            if not len(pairs):
                continue
            f_gt = _forward([gt_crops[k] for k in gts], features, chunk)
            for s in range(0, len(pairs), chunk):
                rows = pairs[s:s + chunk]
                f_r = features(to_tensor(np.stack([renders[k] for k in rows])))
                sel = torch.from_numpy(pos[gt_index[rows]])
                out[rows] = distance([t[sel] for t in f_gt], f_r).double().numpy()
    return out
