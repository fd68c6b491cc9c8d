"""What an engine computes per crop batch: metric columns (``nvrq score``) or a proxy column
(``nvrq proxy imagenet|clip``). Each scorer is a small picklable description; ``load()`` builds
its model once in an actor, ``score(model, batch, extra, timings)`` maps one
:class:`~nvrq.scoring.core.CropBatch` to ``{column: (P,) float64}``.

``pixel_columns`` are computed in the CPU tasks, ``model_columns`` in the actors, both with the
same core functions the local commands use (:func:`~nvrq.scoring.core.compute_columns`,
:func:`~nvrq.scoring.core.pair_outputs`).
"""

from __future__ import annotations

from dataclasses import dataclass

from nvrq.proxies.classifier_drop import load_classifier, top_class_drop
from nvrq.proxies.clip_drop import load_clip, true_category_drop, true_category_index
from nvrq.scoring.core import column_seconds, pair_outputs
from nvrq.scoring.plan import ScorePlan

__all__ = ["MetricScorer", "ImagenetScorer", "ClipScorer", "timing_per_column"]


#: ``nvrq score``'s scorer is its plan (:class:`~nvrq.scoring.plan.ScorePlan`: ``load``,
#: ``score``, ``options``, ``model_columns``, ``pixel_columns``); ``MetricScorer`` is its former
#: name, kept working (deprecated: build the plan with :func:`nvrq.scoring.plan.resolve_plan`).
MetricScorer = ScorePlan


@dataclass(frozen=True, kw_only=True)
class _ProxyScorer:
    """What both proxy scorers share: one model column computed in the actors from the GT and
    render crops' class probabilities (:func:`~nvrq.scoring.core.pair_outputs`)."""

    device: str = "cpu"
    batch_size: int = 32
    runtime: str = "auto"  # the proxy model's runtime on each worker (exported once, cached)
    cache_dir: str | None = None
    pixel_columns: tuple = ()

    @property
    def model_columns(self) -> list[str]:
        return list(self.columns)

    def _probabilities(self, model, batch, timings: dict):
        return pair_outputs(batch, model.probabilities, size=model.input_size,
                            batch_size=self.batch_size, timings=timings)


@dataclass(frozen=True)
class ImagenetScorer(_ProxyScorer):
    """``nvrq proxy imagenet``: Eq. 9, the ImageNet top-class confidence drop.

    Attributes
    ----------
    classifier : str
        Name of the ImageNet classifier to load.
    weights : str or None
        Classifier weights to load; None: the default ones.
    columns : tuple of str
        Output columns, ``("imagenet_drop",)``.
    extra_columns : tuple of str
        Pairs columns the scorer needs besides the crops (none).
    device, batch_size, runtime, cache_dir, pixel_columns
        The classifier's torch device, crops per forward pass, runtime and export cache; no
        pixel columns.
    """

    classifier: str
    weights: str | None = None
    columns: tuple = ("imagenet_drop",)
    extra_columns: tuple = ()

    def load(self):
        return load_classifier(self.classifier, weights=self.weights, device=self.device,
                               runtime=self.runtime, cache_dir=self.cache_dir)

    def score(self, model, batch, extra: dict, timings: dict) -> dict:
        return {"imagenet_drop": top_class_drop(*self._probabilities(model, batch, timings))}

    def options(self) -> dict:
        return {"columns": list(self.columns), "classifier": self.classifier, "weights": self.weights,
                "runtime": self.runtime}


@dataclass(frozen=True)
class ClipScorer(_ProxyScorer):
    """``nvrq proxy clip``: Eq. 10, the CLIP zero-shot true-category confidence drop.

    Attributes
    ----------
    clip : str
        The local CLIP folder each worker loads (:func:`~nvrq.proxies.clip_drop.load_clip`).
    prompts : tuple
        ``((category, prompt), ...)``: the zero-shot prompt of each category.
    category_map : tuple
        ``((label_class, category or None), ...)``: each label class's CLIP category.
    columns : tuple of str
        ``("clip_drop",)``, the one column it writes.
    extra_columns : tuple of str
        ``("label_class",)``: read from the pairs to find each pair's true category.
    device, batch_size, runtime, cache_dir, pixel_columns
        As for :class:`ImagenetScorer`; ``runtime`` runs CLIP's image tower.
    """

    clip: str
    prompts: tuple  # ((category, prompt), ...)
    category_map: tuple  # ((label_class, category or None), ...)
    columns: tuple = ("clip_drop",)
    extra_columns: tuple = ("label_class",)

    def load(self):
        return load_clip(self.clip, prompts=dict(self.prompts), device=self.device,
                         runtime=self.runtime, cache_dir=self.cache_dir)

    def score(self, model, batch, extra: dict, timings: dict) -> dict:
        c = true_category_index(extra["label_class"][batch.rows], dict(self.category_map), model.categories)
        return {"clip_drop": true_category_drop(*self._probabilities(model, batch, timings), c)}

    def options(self) -> dict:
        return {"columns": list(self.columns), "clip": self.clip, "prompts": [list(p) for p in self.prompts],
                "runtime": self.runtime}


def timing_per_column(scorer, timings: dict) -> dict:
    """Seconds per column, by the local engine's rule (:func:`nvrq.scoring.core.column_seconds`).

    Parameters
    ----------
    scorer : object
        The scorer (its ``columns`` and ``model_columns`` are read).
    timings : dict
        Seconds per stage recorded while scoring.

    Returns
    -------
    dict
        ``{column: seconds}`` for each of the scorer's columns.
    """
    return dict(zip(scorer.columns, column_seconds(scorer.columns, scorer.model_columns, timings), strict=True))
