"""What the registry knows of one metric: :class:`MetricInfo` and the kinds of input a metric
consumes, :class:`MetricKind` (metrics layer; a leaf module: it imports nothing of
:mod:`nvrq.metrics`, so the registry and the PyIQA bridge both build entries without an import
cycle).

>>> MetricInfo("mae", False, (0.0, 255.0)).reference
True
>>> [k.value for k in MetricKind]
['pair', 'render', 'encoder', 'frame', 'set']
"""

from __future__ import annotations

import enum
from collections.abc import Callable
from dataclasses import dataclass

__all__ = ["MetricInfo", "MetricKind"]


class MetricKind(str, enum.Enum):
    """What a metric consumes, and so how the scoring core computes it.

    - ``PAIR``: the GT crop and the render crop resized to it, ``fn(gt, render) -> float``;
    - ``RENDER``: the raw render crop alone, ``fn(render) -> float`` (no reference);
    - ``ENCODER``: the GT and render crops' embeddings by the chosen encoder; the core computes
      their similarity ``S = (cos + 1) / 2`` (paper Eq. 4) once per pair and the entry's
      ``from_similarity(S, tau)`` turns it into the column (``needs_tau``: whether it uses tau);
    - ``FRAME``: a whole frame (e.g. a detector's boxes against the projected boxes);
    - ``SET``: two sets of items (e.g. a distance between two feature distributions).

    The scoring core of ``nvrq score`` computes the first three; ``FRAME`` and ``SET`` metrics
    are registered for the per-frame and per-set scorers.
    """

    PAIR = "pair"
    RENDER = "render"
    ENCODER = "encoder"
    FRAME = "frame"
    SET = "set"


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

    ``consumes``: the :class:`MetricKind` (default: ``encoder`` with ``needs_encoder``, else
    ``pair`` with ``reference``, else ``render``; :func:`nvrq.metrics.resolve.metric_kind`).
    ``compute``: ``fn`` without its input checks, for the scoring core, which checks its inputs
    once per run (default: ``fn`` itself). ``from_similarity(s, tau) -> (N,) float64``: an
    encoder metric's column from the similarities ``s`` (N,); ``needs_tau``: whether it uses
    the NVRQ-CA knee ``tau``. ``batch(gt_crops, gt_index, renders) -> (P,) float64``: a ``pair``
    metric computed over a whole batch at once (a network: each unique GT crop run once),
    ``renders`` resized to their GT crops; ``prepare()``: called once, before any crop is read,
    to load what the metric needs (its weights), raising InputError when it cannot.

    Attributes
    ----------
    name : str
        The metric's name (its column).
    higher_better : bool
        Whether a higher value means better quality.
    value_range : tuple of float
        ``(low, high)`` of the values.
    needs_encoder : bool
        Whether it is an encoder metric family.
    fn : callable or None
        The per-crop function of an encoder-free metric.
    description : str
        One-line description.
    kind : str
        ``'metric'`` or ``'proxy'``.
    reference : bool
        Whether it is a full-reference metric.
    min_side : int
        Shorter crop side (px) below which the value is NaN.
    undefined : str
        When else the value is NaN.
    members : callable or None
        ``members(name)``: the entry of the column ``family:name`` of an external family.
    consumes : MetricKind or None
        What the metric consumes; None: derived (see above).
    compute : callable or None
        ``fn`` without its input checks; None: ``fn``.
    from_similarity : callable or None
        An encoder metric's column from the similarities.
    needs_tau : bool
        Whether ``from_similarity`` uses the NVRQ-CA knee ``tau``.
    batch : callable or None
        A ``pair`` metric over a whole batch; None: ``compute`` pair by pair.
    prepare : callable or None
        Loads what the metric needs, once, before any crop is read.
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
    consumes: MetricKind | None = None
    compute: Callable | None = None
    from_similarity: Callable | None = None
    needs_tau: bool = False
    batch: Callable | None = None
    prepare: Callable | None = None
