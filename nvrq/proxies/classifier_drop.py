"""ImageNet confidence drop (paper Eq. 9): ``imagenet_drop`` per pair.

``c^ = argmax_c f(GT, c)``; ``imagenet_drop = f(GT, c^) - f(render, c^)`` with ``f`` the
classifier's softmax probabilities. Positive = the render lost confidence in what the GT
crop shows; 0 for an identical render. The GT crop is classified once and shared by every
render offset of the object.

Crops enter the classifier as the encoders' do (SPEC section 4): black-padded to a square,
bicubic-resized to the model's input size, then the model's own normalisation.

Classifiers: ``efficientnet-lite0`` (default; ImageNet weights from the pip package, works
offline) or any ``transformers`` image classifier folder (``AutoModelForImageClassification``
with ``preprocessor_config.json``; e.g. the paper's EVA-02), loaded with
``local_files_only``.

>>> import numpy as np
>>> top_class_drop(np.array([[0.7, 0.2, 0.1]]), np.array([[0.4, 0.5, 0.1]])).round(6).tolist()
[0.3]
"""

from __future__ import annotations

import json
import os
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from tqdm import tqdm

from data_schema.errors import InputError
from data_schema.tables import GT_BOX_COLUMNS, RENDER_BOX_COLUMNS, pair_boxes, pair_image_paths
from nvrq.crops import cut_box, encoder_input, normalised_tensor, read_rgb
from nvrq.encoders import load_encoder

__all__ = [
    "ImageClassifier",
    "load_classifier",
    "top_class_drop",
    "crop_pair_batches",
    "imagenet_drop",
    "DEFAULT_CLASSIFIER",
]

DEFAULT_CLASSIFIER = "efficientnet-lite0"


def top_class_drop(p_gt: np.ndarray, p_render: np.ndarray) -> np.ndarray:
    """Eq. 9 from probabilities ``p_gt, p_render: (N, C)`` -> ``(N,)``."""
    c_hat = np.argmax(p_gt, axis=1)
    rows = np.arange(len(c_hat))
    return p_gt[rows, c_hat] - p_render[rows, c_hat]


@dataclass
class ImageClassifier:
    """``model(pixel_values (B, 3, S, S)) -> logits (B, C)``; ``mean``/``std`` on [0, 1] RGB."""

    name: str
    model: object
    input_size: int
    mean: tuple[float, float, float]
    std: tuple[float, float, float]
    device: str = "cpu"

    def probabilities(self, images: np.ndarray) -> np.ndarray:
        """Softmax probabilities (B, C) float64 of uint8 RGB inputs (B, S, S, 3)."""
        import torch

        x = normalised_tensor(images, self.mean, self.std, device=self.device)
        with torch.inference_mode():
            out = self.model(x)
            logits = out.logits if hasattr(out, "logits") else out
            return torch.softmax(logits.double(), dim=1).cpu().numpy()


def preprocessor_stats(folder: Path, default_size: int | None) -> tuple[int, tuple, tuple]:
    """``(input_size, mean, std)`` of a Hugging Face model folder's ``preprocessor_config.json``."""
    path = folder / "preprocessor_config.json"
    if not path.is_file():
        raise InputError(
            folder,
            "preprocessor_config.json",
            "a Hugging Face model folder with its image preprocessor config",
            "no such file",
        )
    cfg = json.loads(path.read_text(encoding="utf-8"))
    size = default_size
    for key in ("crop_size", "size"):
        v = cfg.get(key)
        if size is None and isinstance(v, dict):
            size = v.get("height") or v.get("shortest_edge")
        elif size is None and isinstance(v, int):
            size = v
    if size is None:
        raise InputError(path, "size", "the model's input size", "none")
    mean = tuple(cfg.get("image_mean", (0.5, 0.5, 0.5)))
    std = tuple(cfg.get("image_std", (0.5, 0.5, 0.5)))
    return int(size), mean, std


def load_classifier(
    name: str = DEFAULT_CLASSIFIER, *, weights: str | os.PathLike | None = None, device: str = "cpu"
) -> ImageClassifier:
    """``efficientnet-lite0`` (``weights``: optional ``.pth``) or a transformers classifier folder."""
    if name == DEFAULT_CLASSIFIER:
        enc = load_encoder(
            name, weights=weights, device=device
        )  # full model incl. the ImageNet head
        return ImageClassifier(
            name, enc.model, enc.spec.input_size, enc.spec.mean, enc.spec.std, device
        )
    folder = Path(weights if weights is not None else name)
    if not folder.is_dir():
        raise InputError(
            "--classifier",
            None,
            f"{DEFAULT_CLASSIFIER} or a Hugging Face image-classifier "
            "folder (AutoModelForImageClassification)",
            name,
        )
    os.environ["HF_HUB_OFFLINE"] = "1"
    from transformers import AutoModelForImageClassification

    try:
        model = AutoModelForImageClassification.from_pretrained(
            os.fspath(folder), local_files_only=True
        )
    except (OSError, ValueError) as exc:
        raise InputError(
            folder, None, "an image-classification model folder", f"{type(exc).__name__}: {exc}"
        ) from None
    cfg_size = getattr(model.config, "image_size", None)
    size, mean, std = preprocessor_stats(folder, cfg_size if isinstance(cfg_size, int) else None)
    return ImageClassifier(folder.name, model.to(device).eval(), size, mean, std, device)


def crop_pair_batches(
    pairs: pd.DataFrame, *, size: int, scene_root=None, chunk: int = 64, where: str = "pairs"
) -> Iterator[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]:
    """Encoder-style inputs of the pairs' crops, ``chunk`` pairs at a time, grouped by GT image.

    Yields ``(rows (n,), gt_inputs (g, S, S, 3), gt_index (n,), render_inputs (n, S, S, 3))``:
    ``gt_inputs[gt_index[k]]`` is the GT crop of pair ``rows[k]`` (each GT crop prepared once).
    """
    gt_paths = pair_image_paths(pairs, "gt_path", scene_root=scene_root, where=where)
    r_paths = pair_image_paths(pairs, "render_path", scene_root=scene_root, where=where)
    gt_boxes = pair_boxes(pairs, GT_BOX_COLUMNS, where=where)
    r_boxes = pair_boxes(pairs, RENDER_BOX_COLUMNS, where=where)
    order = np.argsort(gt_paths.astype(str), kind="stable")
    cache: dict[str, np.ndarray] = {}
    for start in range(0, len(order), chunk):
        rows = order[start : start + chunk]
        gt_keys: dict[tuple, int] = {}
        gt_inputs, gt_index, r_inputs = [], [], []
        for i in rows:
            for p in (gt_paths[i], r_paths[i]):
                if p not in cache:
                    if len(cache) > 16:
                        cache.pop(next(iter(cache)))
                    cache[p] = read_rgb(p)
            key = (gt_paths[i], *gt_boxes[i])
            if key not in gt_keys:
                gt_keys[key] = len(gt_inputs)
                crop = cut_box(
                    cache[gt_paths[i]], gt_boxes[i], where=f"{where}: pair {i + 2} GT box"
                )
                gt_inputs.append(encoder_input(crop, size))
            gt_index.append(gt_keys[key])
            crop = cut_box(cache[r_paths[i]], r_boxes[i], where=f"{where}: pair {i + 2} render box")
            r_inputs.append(encoder_input(crop, size))
        yield rows, np.stack(gt_inputs), np.asarray(gt_index), np.stack(r_inputs)


def imagenet_drop(
    pairs: pd.DataFrame,
    classifier: ImageClassifier,
    *,
    scene_root=None,
    batch_size: int = 32,
    progress: bool = True,
    where: str = "pairs",
) -> pd.DataFrame:
    """Eq. 9 for every pair -> DataFrame ``pair_id, imagenet_drop`` (pairs' order)."""
    drop = np.full(len(pairs), np.nan)
    with tqdm(
        total=len(pairs), unit="pair", file=sys.stderr, disable=not progress, desc="imagenet"
    ) as bar:
        for rows, gt, gt_index, rend in crop_pair_batches(
            pairs, size=classifier.input_size, scene_root=scene_root, chunk=batch_size, where=where
        ):
            probs = classifier.probabilities(np.concatenate([gt, rend]))
            p_gt, p_r = probs[: len(gt)][gt_index], probs[len(gt) :]
            drop[rows] = top_class_drop(p_gt, p_r)
            bar.update(len(rows))
    return pd.DataFrame({"pair_id": pairs["pair_id"].to_numpy(), "imagenet_drop": drop})
