"""``nvrq score PAIRS --out METRICS.{csv,parquet}`` (docs/FORMATS.md §4)."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import TYPE_CHECKING

from data_schema.errors import InputError
from data_schema.text import plural
from nvrq.choices import DEFAULT_METRICS
from nvrq.cli_options import add_pairs_argument, add_scene_root_option
from nvrq.cli_types import LazyHelp, add_link_option, add_quiet_option, show_progress
from nvrq.commands.engine_options import add_engine_args, check_engine_args, report_sharded, run_ray
from nvrq.commands.model_options import add_encoder_arguments, prepare_device

if TYPE_CHECKING:
    from nvrq.scoring.plan import ScorePlan

__all__ = ["register", "run", "plan_from_args", "load_plan_encoder", "report_tau", "runtime_columns", "column_renames",
           "metrics_help"]

#: how the help names each kind of metric nvrq score computes
_KIND_HELP = {"pair": "full reference (GT and render crops)", "render": "no reference (render crop alone)",
              "encoder": "encoder embeddings (on --encoder)"}


#: what Ctrl-C says of a table output (written whole at the end) and of a sharded one
_RESUME_TABLE = ("nothing was written to {out} (a metrics table is written whole at the end, so a rerun "
                 "starts from zero); dataset outputs resume: write a pairs dataset with `nvrq pairs SCENE "
                 "--out PAIRS_DIR` (an --out without a suffix), score it with `nvrq score PAIRS_DIR --out "
                 "METRICS_DIR`, and a rerun of an interrupted run computes only the missing shards")
_RESUME_DATASET = ("the finished shards are kept in {out}; run the same command again to compute only the "
                   "missing ones")


def metrics_help() -> str:
    """``--metrics``' help: the default list and every metric of the registry, by kind.

    Returns
    -------
    str
        One paragraph (the registry read when the help is shown; it imports no OpenCV).
    """
    from nvrq.metrics.registry import REGISTRY

    groups: dict[str, list[str]] = {}
    for name, info in REGISTRY.items():
        if info.kind != "metric":
            continue
        if info.members is not None:
            groups.setdefault("family", []).append(f"{name}:NAME")
        elif info.consumes is not None:
            groups.setdefault(str(getattr(info.consumes, "value", info.consumes)), []).append(name)
    parts = [f"{_KIND_HELP.get(k, k)}: {', '.join(v)}" for k, v in groups.items() if k != "family"]
    family = ", ".join(groups.get("family", []))
    return (f"comma-separated metrics (default {','.join(DEFAULT_METRICS)}); " + "; ".join(parts)
            + (f"; {family} (with that package installed)" if family else ""))


def register(sub) -> None:
    """Add the ``nvrq score`` subparser (its arguments, and :func:`run` as its ``func``).

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The subparsers of the ``nvrq`` parser.
    """
    p = sub.add_parser("score", help="NVRQ, NVRQ-CA and pixel metrics per pair (docs/FORMATS.md §4)",
                       description="Score every GT/render crop pair of a pairs table. Writes "
                                   "METRICS and METRICS.timing.csv (metric, seconds, pairs).")
    add_pairs_argument(p, datasets=True)
    p.add_argument("--out", required=True, help="output metrics table (.csv or .parquet); for a pairs "
                                                "dataset or --engine ray a folder (resumable)")
    p.add_argument("--metrics", default=",".join(DEFAULT_METRICS), help=LazyHelp(metrics_help))
    add_encoder_arguments(p)
    add_scene_root_option(p)
    p.add_argument("--column-tag", default=None,
                   help="name encoder columns nvrq:ENCODER@TAG (default: @PRECISION for bf16/int8, "
                        "none for fp32), e.g. to keep two runtimes' scores apart")
    p.add_argument("--save-crop-features", default=None, metavar="F.npz",
                   help="also write the encoder's embedding of every GT and render crop, which "
                        "nvrq score-sets --crop-features takes instead of embedding them again "
                        "(a pairs table scored in this process, with nvrq or nvrq_ca)")
    add_quiet_option(p)
    add_link_option(p)
    add_engine_args(p)
    p.set_defaults(func=run)


def run(args) -> int:
    """``nvrq score``: make the plan once (:func:`plan_from_args`), then score
    the pairs table (this process), a pairs dataset (the local engine) or either on Ray.

    Parameters
    ----------
    args : argparse.Namespace
        ``pairs`` (a table or a dataset folder), ``out``, ``metrics``, the encoder options,
        ``scene``, ``column_tag`` and the engine options.

    Returns
    -------
    int
        0 once every pair is scored and the metrics (and timing) are written.
    """
    from data_schema.datasets import is_dataset
    plan = plan_from_args(args)
    check_engine_args(args, local_datasets=True)
    report_tau(plan)
    if getattr(args, "save_crop_features", None) is not None:
        _check_crop_features(args, plan, dataset=is_dataset(args.pairs))
    if args.engine == "ray":
        return run_ray(args, plan)
    if is_dataset(args.pairs):
        return _local_dataset(args, plan)
    return _local_table(args, plan)


def _check_crop_features(args, plan: ScorePlan, *, dataset: bool) -> None:
    """``--save-crop-features``: a ``.npz`` file, an encoder column to make the embeddings, and
    a pairs table scored in this process; before anything is read."""
    from data_schema.outputs import check_output_file

    path = args.save_crop_features
    if not str(path).endswith(".npz"):
        raise InputError("--save-crop-features", None, "a file ending in .npz", path)
    if not plan.encoder_specs:
        raise InputError("--save-crop-features", None, "an encoder metric in --metrics (nvrq, nvrq_ca) "
                         "to make the embeddings", ",".join(plan.columns))
    if args.engine == "ray" or dataset:
        raise InputError("--save-crop-features", None, "a pairs table scored in this process (not a "
                         "pairs dataset, not --engine ray)", args.pairs)
    check_output_file(path, inputs=[args.pairs, args.out], option="--save-crop-features")


def plan_from_args(args) -> ScorePlan:
    """The :class:`ScorePlan` of ``nvrq score``'s options (``--metrics``, ``--encoder``,
    ``--weights``, ``--device``, ``--runtime``, ``--precision``, ``--threads``, ``--cache-dir``,
    ``--min-spearman``, ``--tau``, ``--config``, ``--batch-size``).

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options.

    Returns
    -------
    ScorePlan
    """
    options = {"weights": args.weights, "device": args.device, "runtime": args.runtime,
               "precision": args.precision, "threads": args.threads, "cache_dir": args.cache_dir,
               "min_spearman": args.min_spearman}
    from nvrq.scoring.plan import resolve_plan  # the encoder registry: not for `nvrq score --help`

    return resolve_plan(args.metrics, encoder=args.encoder, encoder_options=options, tau=args.tau,
                        tau_config=args.config, batch_size=args.batch_size)


def report_tau(plan: ScorePlan) -> None:
    """The plan's tau on stderr, with where it came from (``--tau``, the config file or the
    registry); nothing when no column needs it.

    Parameters
    ----------
    plan : ScorePlan
        From :func:`plan_from_args`.
    """
    if plan.tau is not None:
        source = "--tau" if plan.tau_source == "argument" else plan.tau_source
        print(f"tau = {plan.tau:.3f} for {plan.encoder.name} (from {source})", file=sys.stderr)


def load_plan_encoder(args, plan: ScorePlan):
    """The plan's encoder, loaded (``None`` without encoder columns), after ``--threads`` and
    the device are applied (:func:`nvrq.commands.model_options.prepare_device`).

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options (``threads``, ``device``).
    plan : ScorePlan
        From :func:`plan_from_args`.

    Returns
    -------
    Encoder or None
    """
    if not plan.encoder_specs:
        return None
    from nvrq import encoders

    prepare_device(args)
    return encoders.load_encoder(plan.encoder)  # through the module: tests patch nvrq.encoders.load_encoder


def _local_table(args, plan: ScorePlan) -> int:
    """A pairs table scored in this process into one metrics table and its timing table."""
    import cv2

    from data_schema.tables import TableKind, pairs_table, read_table, timing_path, write_table
    from nvrq.scoring.driver import REQUIRED_COLUMNS, score_pairs

    if not str(args.out).lower().endswith((".csv", ".parquet")):
        raise InputError(args.out, None, "an output file ending in .csv or .parquet", args.out)
    frame = read_table(args.pairs, required=REQUIRED_COLUMNS, kind=TableKind.PAIRS)
    encoder = load_plan_encoder(args, plan)  # a missing model is said before the images are looked for
    pairs = pairs_table(frame, scene_root=args.scene, base=Path(args.pairs).resolve().parent, where=str(args.pairs))
    cv2.setNumThreads(1)  # crops are small; leave the cores to the encoder and the decode thread
    try:
        res = score_pairs(pairs, plan, encoder=encoder, progress=show_progress(args), where=str(args.pairs),
                          keep_features=getattr(args, "save_crop_features", None) is not None)
    except KeyboardInterrupt:
        raise KeyboardInterrupt(_RESUME_TABLE.format(out=args.out)) from None
    table, timing = runtime_columns(res.table, res.timing, encoder, tag=args.column_tag,
                                    model_columns=plan.model_columns)
    write_table(table, args.out)
    tpath = write_table(timing, timing_path(args.out))
    saved = ""
    if getattr(args, "save_crop_features", None) is not None:  # no pair: a file with no crop
        import numpy as np

        from nvrq.sets import save_crop_features

        save_crop_features(args.save_crop_features, pairs, res.features or (np.zeros((0, 0), np.float32),) * 2,
                           encoder)
        saved = f", {args.save_crop_features}"
    _report(res, uses_encoder=encoder is not None, file=sys.stderr)
    print(f"-> {args.out}, {tpath}{saved}")
    return 0


def _report(res, *, uses_encoder: bool, file) -> None:
    """One summary line: pairs/s, images decoded, encoder images per pair; then one line per
    metric and reason with NaN values (:attr:`nvrq.scoring.driver.ScoreResult.undefined`), and a
    ``warning:`` line per metric NaN on every pair (:func:`~nvrq.scoring.driver.empty_column_warnings`)."""
    wall = res.timing.attrs.get("wall_seconds", float("nan"))
    msg = f"scored {plural(res.n_pairs, 'pair')} in {wall:.1f} s ({res.n_pairs / max(wall, 1e-9):.1f} pairs/s); " \
          f"decoded {plural(res.n_images_decoded, 'image')}"
    if uses_encoder:
        per = res.n_encoder_images / max(res.n_pairs, 1)
        msg += (f"; encoder images: {res.n_encoder_images} ({per:.2f} per pair, "
                f"{2 * res.n_pairs} without GT reuse)")
    print(msg, file=file)
    for row in (res.undefined.itertuples(index=False) if res.undefined is not None else ()):
        print(f"{row.metric}: {row.pairs} of {plural(res.n_pairs, 'pair')} NaN ({row.reason})", file=file)
    from nvrq.scoring.driver import empty_column_warnings

    for line in empty_column_warnings(res.undefined, res.n_pairs):
        print(line, file=file)


def _local_dataset(args, plan: ScorePlan) -> int:
    """A pairs dataset on the local engine: the Ray engine's sharded output and resume, scored
    shard by shard in this process (:func:`nvrq.engines.local.score_dataset`)."""
    import cv2

    from data_schema.tables import timing_path
    from nvrq.engines.local import score_dataset

    rename = column_renames(plan.model_columns, tag=args.column_tag, precision=args.precision)

    def load():  # only when a shard is left to do
        return load_plan_encoder(args, plan)

    cv2.setNumThreads(1)  # as for a table: the cores go to the encoder and the decode thread
    try:
        res = score_dataset(args.pairs, args.out, plan, timing_path=timing_path(args.out),
                            load_encoder=load if plan.encoder_specs else None, shard_pairs=args.shard_pairs,
                            rename=rename, progress=show_progress(args))
    except KeyboardInterrupt:
        raise KeyboardInterrupt(_RESUME_DATASET.format(out=args.out)) from None
    report_sharded(res, args.out, engine="the local engine")
    return 0


def column_renames(columns, *, tag: str | None, precision: str) -> dict[str, str]:
    """``{nvrq:E: nvrq:E@TAG}`` for the encoder columns of ``columns``: TAG is ``tag``, else a
    reduced ``precision`` (bf16/int8), else no renaming (fp32).

    Parameters
    ----------
    columns : iterable of str
        Column names of a metrics table.
    tag : str or None
        ``--column-tag``; None to derive it from ``precision``.
    precision : str
        The encoder's precision (``fp32``, ``bf16`` or ``int8``).

    Returns
    -------
    dict of str to str
        Old encoder column name to tagged name; empty when there is no tag.

    >>> column_renames(["psnr", "nvrq:e"], tag=None, precision="int8")
    {'nvrq:e': 'nvrq:e@int8'}
    """
    from nvrq.metrics.resolve import encoder_columns

    tag = tag if tag is not None else (precision if precision != "fp32" else None)
    return {c: f"{c}@{tag}" for c in encoder_columns(columns)} if tag else {}


def runtime_columns(table, timing, encoder, *, tag: str | None, model_columns=None):
    """Tag encoder columns (``nvrq:E`` -> ``nvrq:E@TAG``) and add ``runtime, precision,
    threads, device`` to the timing rows (empty runtime/precision for encoder-free metrics,
    which run in the one decode thread).

    Parameters
    ----------
    table, timing : pandas.DataFrame
        The metrics table and its timing table.
    encoder : Encoder or None
        The encoder that ran (its precision picks the default tag).
    tag : str, optional
        ``--column-tag``.
    model_columns : sequence of str, optional
        The encoder columns (the plan's; default: looked up in the registry).

    Returns
    -------
    tuple of two pandas.DataFrame
        The renamed table and the timing table with the runtime columns.
    """
    from nvrq.scoring.driver import runtime_timing

    timing = timing.copy()
    if model_columns is None:
        from nvrq.metrics.resolve import encoder_columns

        model_columns = encoder_columns(timing["metric"].tolist())
    enc_cols = list(model_columns)
    rename = column_renames(enc_cols, tag=tag, precision="fp32" if encoder is None else encoder.precision)
    if rename:
        table, timing["metric"] = table.rename(columns=rename), timing["metric"].replace(rename)
        enc_cols = [rename[m] for m in enc_cols]
    return table, runtime_timing(timing, encoder, enc_cols)
