"""The one resolver: every question about a metrics-table column is answered here, once.

- :func:`column_info`: the registry entry behind a column (``nvrq:dinov2-small`` is the family
  ``nvrq`` with encoder ``dinov2-small``; ``pyiqa:musiq`` a member of the ``pyiqa`` family);
  :class:`InputError` when there is none, or ``default`` when asked for one.
- :func:`direction`: higher better (``True``), lower better (``False``) or unknown (``None``).
- :func:`resolve_metrics`: metric names as a user gives them -> the columns ``nvrq score`` writes;
  :func:`named_encoder`: the encoder they name (the one a column names, else the one given);
  :func:`encoder_for_metrics`: that one, else the default encoder (from the encoder specs,
  :mod:`nvrq.encoder_specs`: the metrics name encoders, they never load one).
- :func:`encoder_columns` (computed from encoder embeddings), :func:`reference_columns` (need the
  GT crop), :func:`needs_tau` (NVRQ-CA: needs the knee ``tau``).

>>> column_info("nvrq_ca:dinov2-reg-small").higher_better
True
>>> column_info("niqe").reference, column_info("psnr").reference
(False, True)
>>> column_info("not-a-metric", default=None) is None
True
>>> direction("s_det"), direction("mystery")
(True, None)
"""

from __future__ import annotations

import difflib
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from data_schema.errors import InputError
from nvrq.encoder_specs import get_spec
from nvrq.metrics.info import MetricInfo, MetricKind
from nvrq.metrics.registry import REGISTRY

__all__ = ["split_column", "column_info", "direction", "resolve_metrics", "named_encoder", "encoder_for_metrics",
           "encoder_columns", "reference_columns", "needs_tau", "metric_kind", "closest_metric",
           "metric_names", "ColumnSpec", "column_specs"]

_RAISE = object()
#: ``column_info``'s kinds, and how its error names them
_KINDS = {"metric": "metric columns", "proxy": "proxy columns", None: "metric or proxy columns"}


def split_column(column: str) -> tuple[str, str | None]:
    """A column name split into family and member.

    Parameters
    ----------
    column : str
        e.g. ``nvrq:dinov2-small`` (family ``nvrq``, member the encoder) or ``psnr``.

    Returns
    -------
    tuple of (str, str or None)
        ``(family, member)``; ``member`` is ``None`` for a column without ``:``.

    >>> split_column("nvrq:dinov2-small"), split_column("psnr")
    (('nvrq', 'dinov2-small'), ('psnr', None))
    """
    family, sep, member = str(column).partition(":")
    return (family, member) if sep else (family, None)


def metric_names(kind: str | None = "metric") -> list[str]:
    """The registered names of ``kind`` (``'metric'``, ``'proxy'`` or ``None`` for both), sorted.

    Parameters
    ----------
    kind : {'metric', 'proxy', None}
        The entries to list.

    Returns
    -------
    list of str
        Family names (``nvrq``, ``pyiqa``) stand for their columns.

    >>> "psnr" in metric_names(), "s_det" in metric_names()
    (True, False)
    """
    return sorted(n for n, i in REGISTRY.items() if kind is None or i.kind == kind)


def _pyiqa_knows(name: str) -> bool | None:
    """Whether PyIQA lists ``name`` (``None`` when pyiqa is not installed)."""
    import importlib

    try:
        pyiqa = importlib.import_module("pyiqa")
    except ImportError:
        return None
    return name in set(pyiqa.list_models())


def closest_metric(name: str, kind: str | None = "metric") -> str | None:
    """The spelling of a registered metric closest to the unknown ``name``, for the error's hint.

    Parameters
    ----------
    name : str
        The name as given (``PSNR``, ``musiq``, ``nvrq-ca``, ``psrn``).
    kind : {'metric', 'proxy', None}
        The entries to look among.

    Returns
    -------
    str or None
        The same name in another case or with ``-`` for ``_`` (``PSNR`` -> ``psnr``), else the
        nearest registered name (:func:`difflib.get_close_matches`, cutoff 0.75), else
        ``pyiqa:NAME`` when the ``pyiqa`` family is registered and PyIQA knows ``NAME`` or is
        not installed (``musiq`` -> ``pyiqa:musiq``); ``None`` when nothing fits.

    >>> closest_metric("PSNR"), closest_metric("nvrq-ca"), closest_metric("psrn")
    ('psnr', 'nvrq_ca', 'psnr')
    """
    names = metric_names(kind)
    family, member = split_column(name.strip())
    folded = {n.lower().replace("-", "_"): n for n in names}
    key = family.lower().replace("-", "_")
    if key in folded:
        hit = folded[key]
        return hit if member is None else f"{hit}:{member}"
    near = difflib.get_close_matches(key, list(folded), n=1, cutoff=0.75)
    if near:
        return folded[near[0]] if member is None else f"{folded[near[0]]}:{member}"
    if "pyiqa" in names and member is None and _pyiqa_knows(family.lower()) is not False:
        return f"pyiqa:{family.lower()}"
    return None


def _unknown(raw: str, kind: str | None, expected: str) -> InputError:
    """The one-line error of an unknown metric name, with :func:`closest_metric`'s hint."""
    hint = closest_metric(raw, kind)
    got = raw if hint is None else f"{raw} (did you mean {hint}?)"
    return InputError(param="metrics", expected=expected, got=got)


def metric_kind(column: str) -> MetricKind:
    """What the column ``column`` consumes (:class:`~nvrq.metrics.info.MetricKind`).

    Parameters
    ----------
    column : str
        A metric column :func:`column_info` knows.

    Returns
    -------
    MetricKind
        The entry's ``consumes``; when it has none, ``ENCODER`` for an encoder family, ``PAIR``
        for a full-reference metric, ``RENDER`` for a no-reference one.

    >>> metric_kind("psnr").value, metric_kind("niqe").value, metric_kind("nvrq_ca:e").value
    ('pair', 'render', 'encoder')
    """
    info = column_info(column)
    if info.consumes is not None:
        return MetricKind(info.consumes)
    if info.needs_encoder:
        return MetricKind.ENCODER
    return MetricKind.PAIR if info.reference else MetricKind.RENDER


def column_info(column: str, *, kind: str | None = "metric", default=_RAISE) -> MetricInfo:
    """The registry entry behind the metrics-table column ``column``.

    Parameters
    ----------
    column : str
        A column name: ``psnr``, ``niqe``, ``nvrq:ENCODER`` (an encoder family takes its encoder
        after ``:``, and only it does), ``pyiqa:NAME`` (a ``members`` family resolves its member).
    kind : {'metric', 'proxy', None}
        The entries to look among: metrics ``nvrq score`` computes (default), downstream proxies,
        or both.
    default : optional
        Returned instead of raising when ``column`` has no entry of that kind (as ``getattr``'s
        default): unknown, spelled wrongly for its family, or a ``pyiqa:NAME`` that PyIQA does
        not know or that cannot be resolved because pyiqa is not installed. Any other failure of
        a member lookup (a broken pyiqa) propagates.

    Returns
    -------
    MetricInfo
        The entry (or ``default``).

    Raises
    ------
    InputError
        Naming ``metrics``, without ``default``, when there is no such entry.
    """
    family, member = split_column(column)
    info = REGISTRY.get(family)
    try:
        if info is None or (kind is not None and info.kind != kind):
            raise _unknown(column, kind, f"{_KINDS[kind]} among {', '.join(metric_names(kind))}")
        if info.members is not None:
            if member is None:
                raise InputError(param="metrics", field=column, expected=f"{family}:NAME", got=column)
            return info.members(member)
        if info.needs_encoder != (member is not None):
            raise InputError(param="metrics", field=column, expected=f"{family}:ENCODER" if info.needs_encoder else family, got=column)
        return info
    except InputError:  # unknown, or a member that is unknown or not installed
        if default is _RAISE:
            raise
        return default


def direction(column: str) -> bool | None:
    """Whether higher values of ``column`` are better.

    Parameters
    ----------
    column : str
        Any column of a metrics or proxy table.

    Returns
    -------
    bool or None
        ``True`` if higher is better, ``False`` if lower is better, ``None`` if the column is
        unknown (:func:`column_info` with ``default=None``).
    """
    info = column_info(column, kind=None, default=None)
    return None if info is None else info.higher_better


def resolve_metrics(metrics: Sequence[str], encoder: str) -> list[str]:
    """Output column names for metric names: ``nvrq`` -> ``nvrq:ENCODER`` (``encoder``'s name).

    Parameters
    ----------
    metrics : sequence of str
        Metric names (``psnr``, ``nvrq``, ``pyiqa:NAME``) or columns (``nvrq:ENCODER``);
        repeats are kept once.
    encoder : str
        The encoder the encoder metrics use (:func:`encoder_for_metrics`).

    Returns
    -------
    list of str
        The columns, in the order first given.

    Raises
    ------
    InputError
        Naming ``metrics``: an unknown name, a proxy, a column of another encoder, or none.

    >>> resolve_metrics(["psnr", "nvrq", "nvrq_ca"], "dinov2-small")
    ['psnr', 'nvrq:dinov2-small', 'nvrq_ca:dinov2-small']
    """
    known = metric_names()
    columns: list[str] = []
    for raw in metrics:
        family, enc = split_column(raw.strip())
        info = REGISTRY.get(family)
        if info is None or info.kind != "metric" or (enc is not None and not info.needs_encoder
                                                      and info.members is None):
            raise _unknown(raw, "metric", f"metric names among {', '.join(known)}")
        if info.members is not None:  # pyiqa:NAME, checked by its family
            col = column_info(f"{family}:{enc}" if enc else family).name
        elif info.needs_encoder:
            if enc not in (None, encoder):
                raise InputError(param="metrics", field=raw, expected=f"the encoder given as encoder ({encoder})", got=enc)
            col = f"{family}:{encoder}"
        else:
            col = family
        if col not in columns:
            columns.append(col)
    if not columns:
        raise InputError(param="metrics", expected="at least one metric", got="none")
    return columns


def named_encoder(metrics: Sequence[str], encoder: str | None = None) -> str | None:
    """The encoder that ``metrics`` name, if any: the one a column names, else ``encoder``.

    :func:`encoder_for_metrics` turns ``None`` into the default encoder and checks the name.

    Parameters
    ----------
    metrics : sequence of str
        Metric names or columns, as :func:`resolve_metrics` takes them.
    encoder : str, optional
        The encoder asked for, if any.

    Returns
    -------
    str or None
        The one a column names (``nvrq:ENC``), else ``encoder`` (``None`` when neither names one).

    Raises
    ------
    InputError
        Naming ``metrics`` for two different encoders in ``metrics``, or one that contradicts
        ``encoder``.

    >>> named_encoder(["psnr", "nvrq_ca:dinov2-small"])
    'dinov2-small'
    >>> named_encoder(["nvrq"], "dinov2-small"), named_encoder(["psnr"])
    ('dinov2-small', None)
    """
    families = {name for name, info in REGISTRY.items() if info.needs_encoder or info.consumes == MetricKind.ENCODER}
    named = {enc for fam, enc in map(split_column, (m.strip() for m in metrics)) if fam in families} - {None}
    if len(named) > 1:
        raise InputError(param="metrics", expected="one encoder for all nvrq/nvrq_ca metrics", got=", ".join(sorted(named)))
    if named and encoder is not None and named != {encoder}:
        raise InputError(param="metrics", expected=f"the encoder given as encoder ({encoder})", got=named.pop())
    return named.pop() if named else encoder


def encoder_for_metrics(metrics, encoder: str | None = None) -> str:
    """The encoder that ``metrics`` use: the one they name, else the default encoder (:data:`nvrq.encoder_specs.DEFAULT_ENCODER`).

    Parameters
    ----------
    metrics : sequence of str
        Metric names or columns (:func:`named_encoder`).
    encoder : str, optional
        The encoder asked for, if any.

    Returns
    -------
    str
        The one a column names (``nvrq:ENC``), else ``encoder``, else the default
        (:func:`nvrq.encoder_specs.get_spec`, the one place that applies it).

    Raises
    ------
    InputError
        Naming ``metrics`` for two different encoders in ``metrics``, or one that contradicts
        ``encoder``; naming ``encoder`` for an encoder the registry does not know.

    >>> encoder_for_metrics(["psnr", "nvrq_ca:dinov2-small"])
    'dinov2-small'
    >>> encoder_for_metrics(["psnr"])
    'efficientnet-lite0'
    """
    return get_spec(named_encoder(metrics, encoder)).name


def encoder_columns(metrics: Sequence[str]) -> list[str]:
    """The columns of ``metrics`` computed from encoder embeddings (``nvrq:*``, ``nvrq_ca:*``):
    the one rule of "is this an encoder column".

    Parameters
    ----------
    metrics : sequence of str
        Column names, each one :func:`column_info` knows (a tag ``@TAG`` may follow the encoder).

    Returns
    -------
    list of str
        The encoder columns, in the order of ``metrics``.

    >>> encoder_columns(["psnr", "nvrq:e", "nvrq_ca:e@int8"])
    ['nvrq:e', 'nvrq_ca:e@int8']
    """
    return [m for m in metrics if metric_kind(m) is MetricKind.ENCODER]


def reference_columns(metrics: Sequence[str]) -> list[str]:
    """The columns of ``metrics`` that need the GT crop (full-reference and encoder metrics);
    the others score the render crop alone.

    Parameters
    ----------
    metrics : sequence of str
        Metric columns known to :func:`column_info`.

    Returns
    -------
    list of str
        Those that compare with the GT crop, in order.

    >>> reference_columns(["psnr", "niqe", "nvrq:e", "entropy"])
    ['psnr', 'nvrq:e']
    """
    return [m for m in metrics if metric_kind(m) in (MetricKind.PAIR, MetricKind.ENCODER)]


def needs_tau(metrics: Sequence[str]) -> bool:
    """Whether ``metrics`` hold an NVRQ-CA column (which needs the knee ``tau``).

    Parameters
    ----------
    metrics : sequence of str
        Metric columns.

    Returns
    -------
    bool

    >>> needs_tau(["psnr", "nvrq:e"]), needs_tau(["nvrq_ca:e"])
    (False, True)
    """
    return any(column_info(m).needs_tau for m in metrics)


@dataclass(frozen=True)
class ColumnSpec:
    """One metric column as the scoring core runs it, looked up once (:func:`column_specs`).

    Attributes
    ----------
    name : str
        The column (``psnr``, ``nvrq:ENCODER``).
    kind : MetricKind
        What it consumes (:func:`metric_kind`).
    kernel : callable or None
        ``pair``: ``kernel(gt, render) -> float``; ``render``: ``kernel(render) -> float`` (the
        entry's unchecked ``compute``, else its ``fn``); ``None`` for ``encoder``.
    from_similarity : callable or None
        ``encoder``: ``(S (N,), tau) -> (N,)`` float64, ``S`` the similarities (paper Eq. 4).
    needs_tau : bool
        Whether it uses NVRQ-CA's knee.
    min_side : int
        Shorter crop side (px) below which the value is NaN.
    undefined : str
        When else it is NaN.
    batch : callable or None
        ``pair``: ``batch(gt_crops, gt_index, renders) -> (P,)`` over a whole batch (else None).
    prepare : callable or None
        Loads the metric's weights, once, before any crop is read (else None).
    """

    name: str
    kind: MetricKind
    kernel: Callable | None
    from_similarity: Callable | None
    needs_tau: bool
    min_side: int
    undefined: str
    batch: Callable | None = None
    prepare: Callable | None = None


def column_specs(columns: Sequence[str]) -> tuple[ColumnSpec, ...]:
    """The :class:`ColumnSpec` of each column, every registry fact the core needs, in one call.

    Parameters
    ----------
    columns : sequence of str
        Metric columns :func:`column_info` knows.

    Returns
    -------
    tuple of ColumnSpec
        In order.

    >>> [(s.name, s.kind.value, s.needs_tau) for s in column_specs(["psnr", "nvrq_ca:e"])]
    [('psnr', 'pair', False), ('nvrq_ca:e', 'encoder', True)]
    """
    out = []
    for c in columns:
        info = column_info(c)
        out.append(ColumnSpec(c, metric_kind(c), info.compute or info.fn, info.from_similarity, info.needs_tau,
                              info.min_side, info.undefined, info.batch, info.prepare))
    return tuple(out)
