"""What the registry knows of one metric: :class:`MetricInfo` (a leaf module: it imports nothing
of :mod:`nvrq.metrics`, so the registry and the PyIQA bridge both build entries without an import
cycle).

>>> MetricInfo("mae", False, (0.0, 255.0)).reference
True
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

__all__ = ["MetricInfo"]


@dataclass(frozen=True)
class MetricInfo:
    """Metadata of one metric (or metric family, when ``needs_encoder`` or ``members``).

    ``higher_better``: the direction; ``value_range``: ``(low, high)``. ``fn`` is the per-crop
    function of an encoder-free metric. With ``reference`` (full reference):
    ``fn(gt, render) -> float``, ``gt`` and ``render`` uint8 RGB crops of equal shape (H, W, 3),
    the render crop resized to the GT crop's size. Without (no reference): ``fn(render) -> float``
    on the raw render crop. Encoder families and proxies computed elsewhere have ``fn = None``.
    ``kind`` {'metric', 'proxy'}: a metric ``nvrq score`` computes, or a downstream proxy
    (``nvrq proxy``). ``min_side``: the shorter crop side (px) below which the value is NaN;
    ``undefined``: when else it is NaN (run summaries count both). ``members(name)``: the entry
    of the column ``family:name`` of a family of external metrics.
    """

    name: str
    higher_better: bool
    value_range: tuple[float, float]
    needs_encoder: bool = False
    fn: Callable | None = None
    description: str = ""
    kind: str = "metric"  # {'metric', 'proxy'}
    reference: bool = True
    min_side: int = 1
    undefined: str = ""
    members: Callable[[str], MetricInfo] | None = None
