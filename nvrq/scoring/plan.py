"""The scoring plan: what a scoring run computes, resolved and checked once, at the boundary.

Scoring layer, above :mod:`nvrq.metrics` and below the commands, the Python API and the engines.
:func:`resolve_plan` is the one place that parses and checks the metric list, the encoder, tau
and the batch options, and makes a :class:`ScorePlan` (``nvrq score`` makes it from its options,
:func:`nvrq.commands.score.plan_from_args`; an in-memory run of columns already resolved, with a
loaded encoder, from :meth:`ScorePlan.for_columns`, which checks its arguments once). The CLI, the Python API (:func:`nvrq.score_crops`,
:func:`nvrq.score_frame`, :class:`nvrq.Evaluator`), the local engine and Ray all build this one
plan and pass it down: nothing below it validates again, and the core
(:func:`nvrq.scoring.core.compute_columns`) dispatches on each column's
:class:`~nvrq.metrics.info.MetricKind`, never on its name. A plan is also the scorer the engines
run (``load``, ``score``, ``options``), and it serialises to JSON (:meth:`ScorePlan.to_json`)
for the shard manifests.

>>> plan = resolve_plan("psnr,entropy")
>>> plan.columns, [c.kind.value for c in plan.specs], plan.tau
(('psnr', 'entropy'), ['pair', 'render'], None)
>>> ScorePlan.from_json(plan.to_json()) == plan
True
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field

from data_schema.errors import InputError, check_int
from data_schema.text import comma_list
from nvrq.encoder_specs import EncoderConfig, encoder_config, get_spec
from nvrq.metrics.formulas import check_tau
from nvrq.metrics.info import MetricKind
from nvrq.metrics.resolve import (
    ColumnSpec,
    column_info,
    column_specs,
    encoder_columns,
    encoder_for_metrics,
    needs_tau,
    resolve_metrics,
)
from nvrq.metrics.tau_config import require_tau

__all__ = ["ColumnSpec", "ScorePlan", "resolve_plan", "COMPUTED_KINDS"]

#: the kinds the crop-pair core computes; ``frame`` and ``set`` metrics have their own scorers
COMPUTED_KINDS = (MetricKind.PAIR, MetricKind.RENDER, MetricKind.ENCODER)


@dataclass(frozen=True)
class ScorePlan:
    """What a scoring run computes, resolved once (:func:`resolve_plan`).

    Parameters
    ----------
    columns : tuple of str
        The metric columns, as :func:`nvrq.metrics.resolve_metrics` names them.
    encoder : EncoderConfig, optional
        The encoder of the ``encoder`` columns (``None`` without any).
    tau : float, optional
        NVRQ-CA's knee when a column needs it, else ``None``.
    batch_size : int
        Crops per encoder pass.
    max_pairs : int
        Pairs per crop batch (whole GT images kept together).
    extra_columns : tuple of str
        Pairs-table columns an engine hands to :meth:`score` (none for metrics).
    tau_source : str, optional
        Where tau came from (``argument``, a config file, ``registry``); not serialised.
    specs : tuple of ColumnSpec, optional
        One per column, in order (:func:`nvrq.metrics.resolve.column_specs`; looked up when
        not given).
    loader : callable, optional
        ``loader(encoder) -> Encoder``, what :meth:`load` calls (picklable; not serialised):
        the caller that runs the encoder hands it over (the Ray engine gives
        :func:`nvrq.encoders.registry.load_for_worker`), so the plan never imports an encoder.

    Attributes
    ----------
    encoder_specs, pixel_specs : tuple of ColumnSpec
        The ``encoder`` columns' specs, and the others'.
    model_columns, pixel_columns, reference_columns : tuple of str
        The columns an encoder computes (the engines' model actors), the encoder-free ones
        (their CPU tasks), and those that need the GT crop (``pair`` and ``encoder``).
    """

    columns: tuple
    encoder: EncoderConfig | None = None
    tau: float | None = None
    batch_size: int = 32
    max_pairs: int = 256
    extra_columns: tuple = ()
    tau_source: str | None = field(default=None, compare=False)
    specs: tuple | None = field(default=None, repr=False, compare=False)
    loader: Callable | None = field(default=None, repr=False, compare=False)
    encoder_specs: tuple = field(init=False, repr=False, compare=False)
    pixel_specs: tuple = field(init=False, repr=False, compare=False)
    model_columns: tuple = field(init=False, repr=False, compare=False)
    pixel_columns: tuple = field(init=False, repr=False, compare=False)
    reference_columns: tuple = field(init=False, repr=False, compare=False)
    device: str = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        columns = tuple(self.columns)
        specs = tuple(self.specs) if self.specs is not None else column_specs(columns)
        enc = tuple(s for s in specs if s.kind is MetricKind.ENCODER)
        pixel = tuple(s for s in specs if s.kind is not MetricKind.ENCODER)
        for key, value in (("columns", columns), ("specs", specs), ("encoder_specs", enc), ("pixel_specs", pixel),
                           ("model_columns", tuple(s.name for s in enc)),
                           ("pixel_columns", tuple(s.name for s in pixel)),
                           ("reference_columns", tuple(s.name for s in specs if s.kind is not MetricKind.RENDER)),
                           ("device", self.encoder.device if self.encoder is not None else "cpu")):
            object.__setattr__(self, key, value)

    def load(self):
        """The loaded encoder of :attr:`encoder`, by :attr:`loader` (an engine's model actor
        calls it once).

        Returns
        -------
        Encoder

        Raises
        ------
        InputError
            Naming ``loader`` when the plan was given none.
        """
        if self.loader is None:
            raise InputError(param="loader", expected="the loader of the plan's encoder (e.g. "
                             "nvrq.encoders.registry.load_for_worker)", got=None)
        return self.loader(self.encoder)

    def score(self, model, batch, extra: dict, timings: dict) -> dict:
        """The encoder columns of one crop batch (an engine's model actor).

        Parameters
        ----------
        model : Encoder
            From :meth:`load`.
        batch : CropBatch
            The crops.
        extra : dict
            Unused (metrics need no extra pairs columns).
        timings : dict
            Gains ``prepare`` and ``forward`` seconds.

        Returns
        -------
        dict
            ``{column: (P,) float64}``.
        """
        from nvrq.scoring.core import compute_columns

        return compute_columns(batch, self.encoder_specs, encoder=model, tau=self.tau,
                               batch_size=self.batch_size, timings=timings)

    def options(self) -> dict:
        """What a resumed sharded run must share with the first (``_plan.json``'s keys).

        Returns
        -------
        dict
            ``columns, encoder, weights, tau, runtime`` (and ``precision`` when not fp32).
        """
        enc = bool(self.model_columns) and self.encoder is not None
        opts = {"columns": list(self.columns), "encoder": self.encoder.name if enc else None,
                "weights": self.encoder.weights if enc else None, "tau": self.tau if enc else None,
                "runtime": self.encoder.runtime if enc else None}
        if enc and self.encoder.precision != EncoderConfig.precision:  # fp32 plans (all of Ray's) have no such key
            opts["precision"] = self.encoder.precision
        return opts

    def to_dict(self) -> dict:
        """The plan as JSON-ready values (:meth:`from_dict` reads them back).

        Returns
        -------
        dict
        """
        return {"columns": list(self.columns), "encoder": None if self.encoder is None else asdict(self.encoder),
                "tau": self.tau, "batch_size": self.batch_size, "max_pairs": self.max_pairs,
                "extra_columns": list(self.extra_columns)}

    def to_json(self) -> str:
        """The plan as a JSON text.

        Returns
        -------
        str
        """
        return json.dumps(self.to_dict(), sort_keys=True)

    @classmethod
    def from_dict(cls, doc: Mapping) -> ScorePlan:
        """A plan from :meth:`to_dict`'s values.

        Parameters
        ----------
        doc : mapping
            As :meth:`to_dict` writes it.

        Returns
        -------
        ScorePlan
        """
        enc = doc.get("encoder")
        return cls(tuple(doc["columns"]), None if enc is None else EncoderConfig(**enc), doc.get("tau"),
                   int(doc.get("batch_size", 32)), int(doc.get("max_pairs", 256)),
                   tuple(doc.get("extra_columns", ())))

    @classmethod
    def for_columns(cls, columns: Sequence[str], *, encoder=None, tau: float | None = None,
                    batch_size: int = 32, max_pairs: int = 256) -> ScorePlan:
        """The plan of metric columns already resolved, for a run in memory with a loaded
        encoder (``nvrq stability``'s study, a scorer of crop batches); checked once here.

        Parameters
        ----------
        columns : sequence of str
            Metric columns as :func:`nvrq.metrics.resolve_metrics` names them, at least one.
        encoder : Encoder, optional
            The loaded encoder the run will use; needed (not None) for encoder columns.
        tau : float, optional
            NVRQ-CA's knee, needed (and kept) when a column is NVRQ-CA.
        batch_size : int
            Crops per encoder pass (positive).
        max_pairs : int
            Pairs per crop batch.

        Returns
        -------
        ScorePlan
            ``encoder`` is ``None`` (the run hands its loaded encoder over itself).

        Raises
        ------
        InputError
            Naming ``metrics``, ``encoder``, ``tau`` or ``batch_size``.
        """
        columns = list(columns)
        check_metric_args(columns, encoder=encoder, tau=tau, batch_size=batch_size)
        specs = column_specs(columns)
        return cls(tuple(columns), tau=tau if any(s.needs_tau for s in specs) else None,
                   batch_size=batch_size, max_pairs=max_pairs, specs=specs)

    @classmethod
    def from_json(cls, text: str) -> ScorePlan:
        """A plan from :meth:`to_json`'s text.

        Parameters
        ----------
        text : str

        Returns
        -------
        ScorePlan
        """
        return cls.from_dict(json.loads(text))


def check_metric_args(metrics: Sequence[str], *, encoder=None, tau=None, batch_size: int = 32) -> None:
    """Check the arguments of :meth:`ScorePlan.for_columns` once, before any crop is read.

    Parameters
    ----------
    metrics : sequence of str
        Metric columns, at least one.
    encoder : optional
        Needed (not None) for encoder columns; a loaded encoder, or a loader standing for one.
    tau : float, optional
        Checked (:func:`nvrq.metrics.check_tau`) when a column is NVRQ-CA.
    batch_size : int
        A positive integer.

    Raises
    ------
    InputError
        Naming the parameter that is wrong.
    """
    for m in metrics:
        column_info(m)
    if not metrics:
        raise InputError(param="metrics", expected="at least one metric", got="none")
    check_int("batch_size", batch_size)
    enc_cols = encoder_columns(metrics)
    if enc_cols and encoder is None:
        raise InputError(param="encoder", expected=f"a loaded encoder for {', '.join(enc_cols)}", got=None)
    if needs_tau(metrics):
        check_tau(tau)


def _plan_tau(specs: Sequence[ColumnSpec], name: str, tau, config) -> tuple[float | None, str | None]:
    """``(tau, source)`` when a column needs tau (:func:`nvrq.metrics.tau_config.require_tau`:
    ``tau`` > user config > registry; ``config=False``: only the ``tau`` given, checked), else
    ``(None, None)``."""
    if not any(s.needs_tau for s in specs):
        return None, None
    if config is False:
        check_tau(tau)
        return float(tau), "argument"
    return require_tau(name, tau=tau, config=config, registry_tau=get_spec(name).tau)


def resolve_plan(metrics, *, encoder: EncoderConfig | str | None = None, encoder_options: Mapping | None = None,
                 tau: float | None = None, tau_config=None, batch_size: int = 32,
                 max_pairs: int = 256) -> ScorePlan:
    """Parse and check everything a scoring run needs, once, and make its :class:`ScorePlan`.

    Parameters
    ----------
    metrics : str or sequence of str
        Metric names or columns (``psnr``, ``nvrq``, ``nvrq_ca:dinov2-small``, ``pyiqa:NAME``),
        or one comma-separated text.
    encoder : EncoderConfig or str, optional
        The encoder of ``nvrq``/``nvrq_ca`` (default: the one a column names, else the
        registry's default encoder).
    encoder_options : mapping, optional
        :class:`~nvrq.encoders.EncoderConfig` fields (``weights``, ``device``, ``runtime``,
        ...) for an encoder given by name.
    tau : float, optional
        NVRQ-CA's knee; default the user config's, then the registry's.
    tau_config : path or False, optional
        The tau config file (default ``$NVRQ_CONFIG`` or ``~/.config/nvrq/tau.json``);
        ``False``: no default, ``tau`` must be given when a column needs it.
    batch_size : int
        Crops per encoder pass (positive).
    max_pairs : int
        Pairs per crop batch (positive).

    Returns
    -------
    ScorePlan
        ``encoder`` is ``None`` and ``tau`` is ``None`` when no column needs them.

    Raises
    ------
    InputError
        Naming ``metrics`` (an unknown name, with the closest spelling; two encoders),
        ``encoder``, ``tau``, ``batch_size`` or ``max_pairs``; or ``weights`` when a learned
        metric's weights are not found (the message names the install command).
    """
    raw = comma_list(metrics) if isinstance(metrics, str) else [str(m) for m in metrics]
    given = encoder.name if isinstance(encoder, EncoderConfig) else encoder
    name = encoder_for_metrics(raw, given)
    columns = resolve_metrics(raw, name)
    check_int("batch_size", batch_size)
    check_int("max_pairs", max_pairs)
    specs = column_specs(columns)
    for spec in specs:
        if spec.prepare is not None:  # learned metrics: their weights found and loaded now
            spec.prepare()
    tau, source = _plan_tau(specs, name, tau, tau_config)
    config = None
    if any(s.kind is MetricKind.ENCODER for s in specs):
        config = encoder if isinstance(encoder, EncoderConfig) else encoder_config(name, **dict(encoder_options or {}))
    return ScorePlan(tuple(columns), config, tau, batch_size, max_pairs, tau_source=source, specs=specs)
