"""The one resolver: every question about a metrics-table column is answered here, once.

- :func:`column_info`: the registry entry behind a column (``nvrq:dinov2-small`` is the family
  ``nvrq`` with encoder ``dinov2-small``; ``pyiqa:lpips`` a member of the ``pyiqa`` family);
  :class:`InputError` when there is none, or ``default`` when asked for one.
- :func:`direction`: higher better (``True``), lower better (``False``) or unknown (``None``).
- :func:`resolve_metrics`: metric names as a user gives them -> the columns ``nvrq score`` writes;
  :func:`encoder_for_metrics`: the encoder they use (the one a column names, else the one given,
  else the encoder registry's default, :func:`nvrq.encoders.get_spec`).
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

from collections.abc import Sequence

from data_schema.errors import InputError
from nvrq.encoders.registry import get_spec
from nvrq.metrics.info import MetricInfo
from nvrq.metrics.registry import REGISTRY

__all__ = ["split_column", "column_info", "direction", "resolve_metrics", "encoder_for_metrics",
           "encoder_columns", "reference_columns", "needs_tau"]

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
            known = ", ".join(sorted(n for n, i in REGISTRY.items() if kind is None or i.kind == kind))
            raise InputError(param="metrics", expected=f"{_KINDS[kind]} among {known}", got=column)
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
    known = sorted(n for n, i in REGISTRY.items() if i.kind == "metric")
    columns: list[str] = []
    for raw in metrics:
        family, enc = split_column(raw.strip())
        info = REGISTRY.get(family)
        if info is None or info.kind != "metric" or (enc is not None and not info.needs_encoder
                                                      and info.members is None):
            raise InputError(param="metrics", expected=f"metric names among {', '.join(known)}", got=raw)
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


def encoder_for_metrics(metrics: Sequence[str], encoder: str | None = None) -> str:
    """The encoder that ``metrics`` use.

    Parameters
    ----------
    metrics : sequence of str
        Metric names or columns, as :func:`resolve_metrics` takes them.
    encoder : str, optional
        The encoder asked for, if any.

    Returns
    -------
    str
        The one a column names (``nvrq:ENC``), else ``encoder``, else the encoder registry's
        default (:func:`nvrq.encoders.get_spec`, the one place that applies it).

    Raises
    ------
    InputError
        Naming ``metrics`` for two different encoders in ``metrics``, or one that contradicts
        ``encoder``; naming ``encoder`` for an encoder the registry does not know.

    >>> encoder_for_metrics(["psnr", "nvrq_ca:dinov2-small"])
    'dinov2-small'
    >>> encoder_for_metrics(["nvrq"], "dinov2-small")
    'dinov2-small'
    """
    families = {name for name, info in REGISTRY.items() if info.needs_encoder}  # not pyiqa:NAME
    named = {enc for fam, enc in map(split_column, (m.strip() for m in metrics)) if fam in families} - {None}
    if len(named) > 1:
        raise InputError(param="metrics", expected="one encoder for all nvrq/nvrq_ca metrics", got=", ".join(sorted(named)))
    if named and encoder is not None and named != {encoder}:
        raise InputError(param="metrics", expected=f"the encoder given as encoder ({encoder})", got=named.pop())
    return get_spec(named.pop() if named else encoder).name


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
    return [m for m in metrics if column_info(m).needs_encoder]


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
    infos = [column_info(m) for m in metrics]
    return [m for m, info in zip(metrics, infos, strict=True) if info.needs_encoder or info.reference]


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
    return any(split_column(m)[0] == "nvrq_ca" for m in metrics)
