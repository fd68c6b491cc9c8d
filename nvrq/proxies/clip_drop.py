"""CLIP zero-shot confidence drop on the true category (paper Eq. 10): ``clip_drop`` per pair.

Layer: nvrq core, proxies (downstream quality proxies).

The K categories (automobile, person, animal, large vehicle, rail vehicle) each have one
descriptive prompt (``class_maps.json``). For an image ``x``,
``p(x, c) = softmax_c(logit_scale * cos(g(x), t_c))`` with ``g`` CLIP's projected image
embedding and ``t_c`` the prompt's projected text embedding. With ``c*`` the pair's true
category (``label_class`` -> category map): ``clip_drop = p(GT, c*) - p(render, c*)``;
empty (NaN) for a class mapped to no category.

Crops are black-padded to a square and bicubic-resized to CLIP's input size, then CLIP's
normalisation (docs/FORMATS.md §4).

Runtimes (``runtime``: ``torch``, ``openvino``, ``onnxruntime`` or ``auto``; fp32 only): the
image tower up to the projected embedding ``g`` is exported and cached by
:mod:`nvrq.encoders.runtimes` under ``clip-image``; the text vectors stay torch (embedded
once). The identity check is ``exp(logit_scale) * max ||g^ - g^'||`` over the identity
images (``g^`` = unit embedding): it bounds the change of every zero-shot logit for any
prompts, so of every probability by half of it and of ``clip_drop`` by it. ``auto`` picks
the first runtime with it <= ``IDENTITY_TOL`` (else torch; ``device='cuda'`` always torch).

>>> import numpy as np
>>> t = np.eye(2); g = np.array([[1.0, 0.0], [0.0, 1.0]])
>>> zero_shot_probs(g, t, logit_scale=np.log(2.0)).round(4).tolist()  # softmax([2, 0]), softmax([0, 2])
[[0.8808, 0.1192], [0.1192, 0.8808]]
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from data_schema.errors import InputError
from nvrq.proxies import mapped_labels
from nvrq.proxies.classifier_drop import _ExportableForward, drop_table, preprocessor_stats

__all__ = ["ZeroShotCLIP", "zero_shot_probs", "load_clip", "clip_drop", "true_category_index",
           "true_category_drop", "max_logit_change_bound"]


def zero_shot_probs(
    image_feats: np.ndarray, text_feats: np.ndarray, *, logit_scale: float
) -> np.ndarray:
    """``image_feats (N, D)``, ``text_feats (K, D)`` -> softmax over K of ``exp(logit_scale) * cos``
    (``logit_scale`` is CLIP's log-parameterised temperature) -> (N, K).

    Parameters
    ----------
    image_feats : (N, D) float
        Image embeddings (any norm).
    text_feats : (K, D) float
        Prompt embeddings.
    logit_scale : float
        CLIP's log temperature.

    Returns
    -------
    (N, K) float64
        Probabilities, rows sum to 1.
    """
    a = image_feats / np.linalg.norm(image_feats, axis=1, keepdims=True)
    b = text_feats / np.linalg.norm(text_feats, axis=1, keepdims=True)
    z = np.exp(logit_scale) * (a @ b.T)
    z = z - z.max(axis=1, keepdims=True)
    e = np.exp(z)
    return e / e.sum(axis=1, keepdims=True)


def _features(out):
    """Projected features from ``get_*_features`` (a tensor in transformers 4, an output in 5)."""
    return out if not hasattr(out, "pooler_output") else out.pooler_output


def max_logit_change_bound(ref: np.ndarray, other: np.ndarray, *, logit_scale: float) -> float:
    """``exp(logit_scale) * max_i ||ref_i/|ref_i| - other_i/|other_i|||``: a bound on the change
    of any zero-shot logit ``exp(s) * cos(g, t)`` (|t^| = 1, Cauchy-Schwarz) between two
    image-embedding sets (N, D).

    Parameters
    ----------
    ref, other : (N, D) float
        Embeddings of the same images from two runtimes.
    logit_scale : float
        CLIP's log temperature.

    Returns
    -------
    float

    >>> round(max_logit_change_bound(np.array([[1.0, 0.0]]), np.array([[0.0, 2.0]]), logit_scale=0.0), 6)
    1.414214
    """
    a = ref / np.linalg.norm(ref, axis=1, keepdims=True)
    b = other / np.linalg.norm(other, axis=1, keepdims=True)
    return float(np.exp(logit_scale) * np.max(np.linalg.norm(a - b, axis=1))) if len(a) else 0.0


def _image_features(model, pixel_values):
    return _features(model.get_image_features(pixel_values=pixel_values))


@dataclass
class ZeroShotCLIP(_ExportableForward):
    """A CLIP model with its K category prompts embedded once: ``text_feats (K, D)``.

    ``runtime``: where the image embeddings come from (``torch``, or an exported runtime
    after :meth:`on_runtime`); ``threads``: the CPU threads it runs on (set by :meth:`on_runtime`).

    Attributes
    ----------
    model : transformers.CLIPModel
        The CLIP model.
    categories : list of str
        The K categories.
    text_feats : (K, D) float32
        Their prompts' embeddings.
    input_size, mean, std, device, runtime, threads
        As for :class:`~nvrq.proxies.classifier_drop.ImageClassifier`, for the image tower.
    """

    model: object
    categories: list[str]
    text_feats: np.ndarray
    input_size: int
    mean: tuple[float, float, float]
    std: tuple[float, float, float]
    device: str = "cpu"
    runtime: str = "torch"
    threads: int | None = None
    _run: object = field(default=None, repr=False)

    @classmethod
    def from_model(
        cls,
        model,
        *,
        categories,
        input_ids,
        attention_mask=None,
        input_size,
        mean,
        std,
        device="cpu",
    ) -> ZeroShotCLIP:
        """Embed pre-tokenized prompts ``input_ids (K, L)`` (one per category) with ``model``."""
        import torch

        model = model.to(device).eval()
        with torch.inference_mode():
            ids = torch.as_tensor(np.asarray(input_ids), device=device)
            mask = (
                None
                if attention_mask is None
                else torch.as_tensor(np.asarray(attention_mask), device=device)
            )
            t = _features(model.get_text_features(input_ids=ids, attention_mask=mask))
        return cls(
            model,
            list(categories),
            t.double().cpu().numpy(),
            input_size,
            tuple(mean),
            tuple(std),
            device,
        )

    def image_features(self, images: np.ndarray) -> np.ndarray:
        """Projected image embeddings (B, D) float64 of uint8 RGB inputs (B, S, S, 3)."""
        return np.asarray(self._forward(images, _image_features, "float64"), np.float64)

    @property
    def logit_scale(self) -> float:
        return float(self.model.logit_scale.detach().cpu())

    def probabilities(self, images: np.ndarray) -> np.ndarray:
        """Zero-shot category probabilities (B, K)."""
        return zero_shot_probs(self.image_features(images), self.text_feats, logit_scale=self.logit_scale)

    def on_runtime(self, runtime: str = "auto", *, threads: int | None = None,
                   cache_dir=None) -> ZeroShotCLIP:
        """Run the image tower on ``runtime`` (module docstring); returns ``self``."""
        from functools import partial

        bound = partial(max_logit_change_bound, logit_scale=self.logit_scale)
        return self._use_runtime("clip-image", _image_features, ("max_dlogit_bound_vs_torch", bound),
                                 runtime=runtime, threads=threads, cache_dir=cache_dir)


def load_clip(
    clip: str | os.PathLike, *, prompts: dict[str, str], device: str = "cpu",
    runtime: str = "auto", threads: int | None = None, cache_dir=None,
) -> ZeroShotCLIP:
    """CLIPModel + tokenizer + preprocessor config from ``clip``, a local Hugging Face folder
    (never the hub); the image tower on ``runtime`` (:meth:`ZeroShotCLIP.on_runtime`).

    Parameters
    ----------
    clip : str or PathLike
        A local Hugging Face CLIP folder.
    prompts : dict
        Category -> prompt.
    device, runtime, threads, cache_dir
        As for :func:`~nvrq.proxies.classifier_drop.load_classifier`; ``runtime`` runs the
        image tower (the prompts are embedded once, by torch).

    Returns
    -------
    ZeroShotCLIP
        With its categories in ``prompts``' order.
    """
    folder = Path(clip)
    if not folder.is_dir():
        raise InputError(
            param="clip",
            expected="a local CLIP model folder (CLIPModel, tokenizer, "
            "preprocessor_config.json); nvrq never downloads",
            got=str(folder),
        )
    from transformers import AutoTokenizer, CLIPModel

    try:
        model = CLIPModel.from_pretrained(os.fspath(folder), local_files_only=True)
        tok = AutoTokenizer.from_pretrained(os.fspath(folder), local_files_only=True)
    except (OSError, ValueError) as exc:
        raise InputError(
            folder, None, "a CLIP model folder with its tokenizer", f"{type(exc).__name__}: {exc}"
        ) from None
    categories = list(prompts)
    enc = tok([prompts[c] for c in categories], padding=True, return_tensors="np")
    size, mean, std = preprocessor_stats(folder, int(model.config.vision_config.image_size))
    clip = ZeroShotCLIP.from_model(
        model,
        categories=categories,
        input_ids=enc["input_ids"],
        attention_mask=enc.get("attention_mask"),
        input_size=size,
        mean=mean,
        std=std,
        device=device,
    )
    return clip.on_runtime(runtime, threads=threads, cache_dir=cache_dir)


def true_category_index(
    labels, category_map: dict, categories: list[str], *, where: str = "pairs"
) -> np.ndarray:
    """Index (N,) into ``categories`` of each ``label_class``; -1 where the map says null.

    Parameters
    ----------
    labels : (N,) array-like of str
        ``label_class`` per pair.
    category_map : dict
        Lower-cased label class -> category or ``None``.
    categories : list of str
        The model's categories.
    where : str, optional
        The table named in errors.

    Returns
    -------
    (N,) int64
    """
    pos = {c: k for k, c in enumerate(categories)}
    low = mapped_labels(labels, category_map, "clip_category", where=where)
    return np.array(
        [-1 if category_map[x] is None else pos[category_map[x]] for x in low], dtype=np.int64
    )


def clip_drop(
    pairs: pd.DataFrame,
    clip: ZeroShotCLIP,
    *,
    category_map: dict,
    scene_root=None,
    batch_size: int = 32,
    progress: bool = True,
    where: str = "pairs",
    timings: dict | None = None,
) -> pd.DataFrame:
    """Eq. 10 for every pair -> DataFrame ``pair_id, clip_drop`` (pairs' order; NaN: no category);
    stage seconds added to ``timings`` (:func:`~nvrq.proxies.classifier_drop.pair_probabilities`).

    Parameters
    ----------
    pairs : pandas.DataFrame
        A pairs table (docs/FORMATS.md §3) with ``label_class``.
    clip : ZeroShotCLIP
        From :func:`load_clip`.
    category_map : dict
        Lower-cased label class -> category, or ``None`` for a class left unscored.
    scene_root, batch_size, progress, where, timings
        As for :func:`~nvrq.proxies.classifier_drop.imagenet_drop`.

    Returns
    -------
    pandas.DataFrame
        ``pair_id, clip_drop`` in ``pairs``' order, NaN where the class has no category.
    """
    c_star = true_category_index(pairs["label_class"], category_map, clip.categories, where=where)
    return drop_table(pairs, clip, "clip_drop",
                      lambda rows, p_gt, p_r: true_category_drop(p_gt, p_r, c_star[rows]),
                      scene_root=scene_root, batch_size=batch_size, progress=progress, desc="clip",
                      where=where, timings=timings)


def true_category_drop(p_gt: np.ndarray, p_render: np.ndarray, c_star: np.ndarray) -> np.ndarray:
    """Eq. 10 from probabilities: ``p_gt[c*] - p_render[c*]`` per row, NaN where ``c* < 0``.

    Parameters
    ----------
    p_gt, p_render : (N, K) float
        Zero-shot probabilities of the GT and render crops.
    c_star : (N,) int
        Each row's true category (:func:`true_category_index`; -1: none).

    Returns
    -------
    (N,) float64
        In [-1, 1]; NaN for the rows without a category.

    >>> true_category_drop(np.array([[0.9, 0.1], [0.5, 0.5]]), np.array([[0.6, 0.4], [0.2, 0.8]]),
    ...                    np.array([0, -1])).round(6).tolist()
    [0.3, nan]
    """
    drop = np.full(len(c_star), np.nan)
    ok = np.flatnonzero(c_star >= 0)
    drop[ok] = p_gt[ok, c_star[ok]] - p_render[ok, c_star[ok]]
    return drop
