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
    "drop_table",
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
        Logits of the same N images: torch's (the reference) and an exported runtime's.

    Returns
    -------
    float
        The largest change of any probability, in [0, 1]; 0 for identical logits.
    """
    return float(np.max(np.abs(_softmax64(ref_logits) - _softmax64(other_logits))))


def _logits(model, pixel_values):
    out = model(pixel_values)
    return out.logits if hasattr(out, "logits") else out


class _ExportableForward:
    """What the proxy models (:class:`ImageClassifier`, :class:`~nvrq.proxies.clip_drop.ZeroShotCLIP`)
    share: one graph ``forward(model, pixel_values)`` run by torch, or by the exported runtime
    :meth:`_use_runtime` chose. The class provides ``model``, ``input_size``, ``mean``, ``std``,
    ``device``, ``runtime``, ``threads`` and ``_run``."""

    def _forward(self, images: np.ndarray, forward, dtype: str) -> np.ndarray:
        """``forward``'s output (B, K) for uint8 RGB ``images`` (B, S, S, 3): the exported run's
        as it comes, or torch's cast to ``dtype`` (``'float32'``/``'float64'``)."""
        import torch

        if self._run is not None:
            return self._run(images)
        x = normalised_tensor(images, self.mean, self.std, device=self.device)
        with torch.inference_mode():
            return forward(self.model, x).to(getattr(torch, dtype)).cpu().numpy()

    def _use_runtime(self, graph_name: str, forward, identity: tuple, *, runtime: str, threads, cache_dir):
        """Export ``forward`` as ``graph_name`` (``identity``: its check's name and measure) and
        run it on ``runtime`` (:func:`~nvrq.encoders.runtimes.exported_forward`); returns ``self``."""
        from nvrq.encoders.runtimes import ExportableModel, exported_forward

        graph = ExportableModel(graph_name, self.model, input_size=self.input_size, mean=self.mean,
                                std=self.std, forward=forward, device=self.device, identity=identity)
        self.runtime, self.threads, self._run = exported_forward(graph, runtime=runtime, threads=threads,
                                                                 cache_dir=cache_dir)
        return self


@dataclass
class ImageClassifier(_ExportableForward):
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
        return self._forward(images, _logits, "float32")

    def probabilities(self, images: np.ndarray) -> np.ndarray:
        """Softmax probabilities (B, C) float64 of uint8 RGB inputs (B, S, S, 3)."""
        return _softmax64(self.logits(images))

    def on_runtime(self, runtime: str = "auto", *, threads: int | None = None,
                   cache_dir=None) -> ImageClassifier:
        """Run the logits on ``runtime`` (module docstring); returns ``self``."""
        return self._use_runtime(f"{self.name}-logits", _logits, ("max_dprob_vs_torch", max_softmax_change),
                                 runtime=runtime, threads=threads, cache_dir=cache_dir)


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
        A pairs table (docs/FORMATS.md §3) whose crop pairs are classified.
    classifier : ImageClassifier
        From :func:`load_classifier`.
    scene_root, batch_size, progress, where, timings
        Passed to :func:`pair_probabilities`: the image folder, crops per forward pass, whether
        to show a progress bar, the table named in errors, the stage seconds' dict.

    Returns
    -------
    pandas.DataFrame
        ``pair_id, imagenet_drop``, one row per pair in ``pairs``' order.
    """
    return drop_table(pairs, classifier, "imagenet_drop", lambda rows, p_gt, p_r: top_class_drop(p_gt, p_r),
                      scene_root=scene_root, batch_size=batch_size, progress=progress, desc="imagenet",
                      where=where, timings=timings)


def drop_table(pairs: pd.DataFrame, model, column: str, drop, **options) -> pd.DataFrame:
    """The loop of both confidence-drop proxies: ``drop(rows, p_gt, p_render) -> (P,)`` on each
    crop batch of :func:`pair_probabilities`, gathered into one column (NaN where no batch set it).

    Parameters
    ----------
    pairs : pandas.DataFrame
        A pairs table (docs/FORMATS.md §3), N rows.
    model : ImageClassifier or ZeroShotCLIP
        The proxy model, as :func:`pair_probabilities` takes it.
    column : str
        The output column's name, e.g. ``'imagenet_drop'``.
    drop : callable
        ``drop(rows (P,) int, p_gt (P, C), p_render (P, C)) -> (P,) float``: the proxy's formula.
    **options
        :func:`pair_probabilities`' keywords (``scene_root``, ``batch_size``, ``progress``,
        ``desc``, ``where``, ``timings``).

    Returns
    -------
    pandas.DataFrame
        ``pair_id, <column>``, N rows in ``pairs``' order.
    """
    out = np.full(len(pairs), np.nan)
    for rows, p_gt, p_r in pair_probabilities(pairs, model, **options):
        out[rows] = drop(rows, p_gt, p_r)
    return pd.DataFrame({"pair_id": pairs["pair_id"].to_numpy(), column: out})
