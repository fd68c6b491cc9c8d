"""ImageNet confidence drop (paper Eq. 9): ``imagenet_drop`` per pair.

Layer: nvrq core, proxies (downstream quality proxies).

``c^ = argmax_c f(GT, c)``; ``imagenet_drop = f(GT, c^) - f(render, c^)`` with ``f`` the
classifier's softmax probabilities. Positive = the render lost confidence in what the GT
crop shows; 0 for an identical render. The GT crop is classified once and shared by every
render offset of the object.

Crops enter the classifier as the encoders' do (docs/FORMATS.md §4): black-padded to a square,
bicubic-resized to the model's input size, then the model's own normalisation.

Classifiers: ``efficientnet-lite0`` (default; ImageNet weights from the pip package, works
offline) or any ``transformers`` image classifier folder (``AutoModelForImageClassification``
with ``preprocessor_config.json``; e.g. the paper's EVA-02), loaded with
``local_files_only``.

Runtimes (``runtime``: ``torch``, ``openvino``, ``onnxruntime`` or ``auto``; fp32 only): the
classifier's logits graph (normalisation inside) is exported and cached by
:mod:`nvrq.encoders.runtimes` like an encoder, under ``CLASSIFIER-logits``; the export's
identity check is the max |softmax change| on the identity images, and ``auto`` picks the
first runtime with it <= ``IDENTITY_TOL`` (else torch; ``device='cuda'`` always torch). The
softmax and Eq. 9 run in float64 on the logits either way.

>>> import numpy as np
>>> top_class_drop(np.array([[0.7, 0.2, 0.1]]), np.array([[0.4, 0.5, 0.1]])).round(6).tolist()
[0.3]
"""

from __future__ import annotations

import json
import os
import sys
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
from tqdm import tqdm

from data_schema.errors import InputError, check_int
from nvrq.crops import normalised_tensor
from nvrq.encoders import load_encoder
from nvrq.scoring.batches import iter_crop_batches
from nvrq.scoring.core import pair_outputs

__all__ = [
    "ImageClassifier",
    "load_classifier",
    "top_class_drop",
    "pair_probabilities",
    "imagenet_drop",
    "DEFAULT_CLASSIFIER",
    "max_softmax_change",
]

DEFAULT_CLASSIFIER = "efficientnet-lite0"


def top_class_drop(p_gt: np.ndarray, p_render: np.ndarray) -> np.ndarray:
    """Eq. 9 from probabilities ``p_gt, p_render: (N, C)`` -> ``(N,)``.

    Parameters
    ----------
    p_gt, p_render : (N, C) float
        Softmax probabilities of the GT and render crops.

    Returns
    -------
    (N,) float64
        ``p_gt[c^] - p_render[c^]`` with ``c^ = argmax p_gt``, in [-1, 1].
    """
    c_hat = np.argmax(p_gt, axis=1)
    rows = np.arange(len(c_hat))
    return p_gt[rows, c_hat] - p_render[rows, c_hat]


def _softmax64(logits: np.ndarray) -> np.ndarray:
    import torch

    return torch.softmax(torch.as_tensor(logits).double(), dim=1).numpy()


def max_softmax_change(ref_logits: np.ndarray, other_logits: np.ndarray) -> float:
    """max |softmax(ref) - softmax(other)| over every image and class: the classifier export's
    identity measure (Eq. 9's drop then moves by at most twice it).

    Parameters
    ----------
    ref_logits, other_logits : (N, C) float
        Logits of the same images from two runtimes.

    Returns
    -------
    float
        In [0, 1].
    """
    return float(np.max(np.abs(_softmax64(ref_logits) - _softmax64(other_logits))))


def _logits(model, pixel_values):
    out = model(pixel_values)
    return out.logits if hasattr(out, "logits") else out


@dataclass
class ImageClassifier:
    """``model(pixel_values (B, 3, S, S)) -> logits (B, C)``; ``mean``/``std`` on [0, 1] RGB.

    ``runtime``: where the logits come from (``torch``, or an exported runtime after
    :meth:`on_runtime`); ``threads``: the CPU threads it runs on (set by :meth:`on_runtime`).

    Attributes
    ----------
    name : str
        The classifier, named in outputs.
    model : torch.nn.Module
        ``model(pixel_values (B, 3, S, S)) -> logits (B, C)``.
    input_size : int
        Input side ``S``, pixels.
    mean, std : (3,) float
        Normalisation of RGB in [0, 1].
    device : str
        A torch device.
    runtime : str
        ``{'torch', 'openvino', 'onnxruntime'}``.
    threads : int or None
        CPU threads of an exported runtime.
    """

    name: str
    model: object
    input_size: int
    mean: tuple[float, float, float]
    std: tuple[float, float, float]
    device: str = "cpu"
    runtime: str = "torch"
    threads: int | None = None
    _run: object = field(default=None, repr=False)

    def logits(self, images: np.ndarray) -> np.ndarray:
        """Logits (B, C) float32 of uint8 RGB inputs (B, S, S, 3) on :attr:`runtime`."""
        import torch

        if self._run is not None:
            return self._run(images)
        x = normalised_tensor(images, self.mean, self.std, device=self.device)
        with torch.inference_mode():
            return _logits(self.model, x).float().cpu().numpy()

    def probabilities(self, images: np.ndarray) -> np.ndarray:
        """Softmax probabilities (B, C) float64 of uint8 RGB inputs (B, S, S, 3)."""
        return _softmax64(self.logits(images))

    def on_runtime(self, runtime: str = "auto", *, threads: int | None = None,
                   cache_dir=None) -> ImageClassifier:
        """Run the logits on ``runtime`` (module docstring); returns ``self``."""
        from nvrq.encoders.runtimes import ExportableModel, exported_forward

        graph = ExportableModel(f"{self.name}-logits", self.model, input_size=self.input_size,
                                mean=self.mean, std=self.std, forward=_logits, device=self.device,
                                identity=("max_dprob_vs_torch", max_softmax_change))
        self.runtime, self.threads, self._run = exported_forward(graph, runtime=runtime, threads=threads,
                                                   cache_dir=cache_dir)
        return self


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
    classifier: str = DEFAULT_CLASSIFIER, *, weights: str | os.PathLike | None = None, device: str = "cpu",
    runtime: str = "auto", threads: int | None = None, cache_dir=None,
) -> ImageClassifier:
    """``classifier``: ``efficientnet-lite0`` (``weights``: optional ``.pth``) or a transformers
    classifier folder (or that folder given as ``weights``), its logits on ``runtime``
    (:meth:`ImageClassifier.on_runtime`; ``cache_dir``: the export cache, default
    ``$NVRQ_CACHE`` else ``~/.cache/nvrq``).

    Parameters
    ----------
    classifier : str, optional
        ``'efficientnet-lite0'`` or a transformers image-classifier folder.
    weights : str or PathLike, optional
        A ``.pth`` (efficientnet-lite0) or the classifier folder.
    device : str, optional
        A torch device.
    runtime : str, optional
        ``{'auto', 'torch', 'openvino', 'onnxruntime'}``.
    threads : int, optional
        CPU threads of an exported runtime.
    cache_dir : str or Path, optional
        The export cache.

    Returns
    -------
    ImageClassifier
    """
    clf = _load_torch_classifier(classifier, weights=weights, device=device)
    return clf.on_runtime(runtime, threads=threads, cache_dir=cache_dir)


def _load_torch_classifier(name: str, *, weights, device: str) -> ImageClassifier:
    if name == DEFAULT_CLASSIFIER:
        enc = load_encoder(
            name, weights=weights, device=device, runtime="torch"
        )  # full model incl. the ImageNet head (the encoder's export is the embedding only)
        return ImageClassifier(
            name, enc.model, enc.spec.input_size, enc.spec.mean, enc.spec.std, device
        )
    folder = Path(weights if weights is not None else name)
    if not folder.is_dir():
        raise InputError(
            param="classifier" if weights is None else "weights",
            expected=f"{DEFAULT_CLASSIFIER} or a Hugging Face image-classifier "
            "folder (AutoModelForImageClassification)",
            got=str(folder),
        )
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


def pair_probabilities(
    pairs: pd.DataFrame,
    model,
    *,
    scene_root=None,
    batch_size: int = 32,
    progress: bool = True,
    desc: str = "proxy",
    where: str = "pairs",
    timings: dict | None = None,
) -> Iterator[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """``(rows (P,), p_gt (P, C), p_render (P, C))`` per crop batch of ``pairs``, through the one
    scoring core (:mod:`nvrq.scoring.core`): ``model.probabilities(uint8 (B, S, S, 3))`` with
    ``S = model.input_size``, each GT crop run once, ``batch_size`` crops per forward pass.
    Adds ``decode``, ``prepare`` and ``forward`` seconds to ``timings`` (as ``nvrq score``;
    :func:`nvrq.scoring.driver.timing_table` turns them into the timing file's rows).

    Parameters
    ----------
    pairs : pandas.DataFrame
        A pairs table (docs/FORMATS.md §3).
    model : ImageClassifier or ZeroShotCLIP
        Anything with ``probabilities(uint8 (B, S, S, 3)) -> (B, C)`` and ``input_size``.
    scene_root : str or Path, optional
        Where image paths are resolved from.
    batch_size : int, optional
        Crops per forward pass.
    progress : bool, optional
        Show a progress bar.
    desc : str, optional
        The progress bar's label.
    where : str, optional
        The table named in errors.
    timings : dict, optional
        Stage seconds are added to it.

    Yields
    ------
    rows : (P,) int
        Row positions in ``pairs``.
    p_gt, p_render : (P, C) float
        Probabilities of the GT and render crops.
    """
    check_int("batch_size", batch_size)
    times = timings if timings is not None else {}
    batches = iter_crop_batches(pairs, scene_root=scene_root, where=where)
    with tqdm(total=len(pairs), unit="pair", file=sys.stderr, disable=not progress, desc=desc) as bar:
        for batch in batches:
            times["decode"] = times.get("decode", 0.0) + batch.decode_seconds
            p_gt, p_r = pair_outputs(batch, model.probabilities, size=model.input_size,
                                     batch_size=batch_size, timings=times)
            yield batch.rows, p_gt, p_r
            bar.update(len(batch.rows))


def imagenet_drop(
    pairs: pd.DataFrame,
    classifier: ImageClassifier,
    *,
    scene_root=None,
    batch_size: int = 32,
    progress: bool = True,
    where: str = "pairs",
    timings: dict | None = None,
) -> pd.DataFrame:
    """Eq. 9 for every pair -> DataFrame ``pair_id, imagenet_drop`` (pairs' order); stage seconds
    added to ``timings`` (:func:`pair_probabilities`).

    Parameters
    ----------
    pairs : pandas.DataFrame
        A pairs table (docs/FORMATS.md §3).
    classifier : ImageClassifier
        The classifier.
    scene_root : str or Path, optional
        Where image paths are resolved from.
    batch_size : int, optional
        Crops per forward pass.
    progress : bool, optional
        Show a progress bar.
    where : str, optional
        The table named in errors.
    timings : dict, optional
        Stage seconds are added to it.

    Returns
    -------
    pandas.DataFrame
        ``pair_id, imagenet_drop``.
    """
    drop = np.full(len(pairs), np.nan)
    for rows, p_gt, p_r in pair_probabilities(pairs, classifier, scene_root=scene_root,
                                              batch_size=batch_size, progress=progress,
                                              desc="imagenet", where=where, timings=timings):
        drop[rows] = top_class_drop(p_gt, p_r)
    return pd.DataFrame({"pair_id": pairs["pair_id"].to_numpy(), "imagenet_drop": drop})
