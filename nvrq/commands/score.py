"""``nvrq score PAIRS --out METRICS.{csv,parquet}`` (docs/FORMATS.md §4)."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import TYPE_CHECKING

from data_schema.errors import InputError
from nvrq.choices import DEFAULT_METRICS
from nvrq.commands.args import add_link_option, show_progress
from nvrq.commands.engine_options import add_engine_args, check_engine_args, report_sharded, run_ray
from nvrq.commands.model_options import (
    add_encoder_arguments,
    command_tau,
    encoder_for_columns,
    encoder_options,
    load_encoder_and_tau,
    metric_columns,
)

if TYPE_CHECKING:
    from nvrq.engines.scorers import MetricScorer

__all__ = ["register", "run", "runtime_columns", "column_renames"]


def register(sub) -> None:
    p = sub.add_parser("score", help="NVRQ, NVRQ-CA and pixel metrics per pair (docs/FORMATS.md §4)",
                       description="Score every GT/render crop pair of a pairs table. Writes "
                                   "METRICS and METRICS.timing.csv (metric, seconds, pairs).")
    p.add_argument("pairs", help="pairs table from `nvrq pairs` (.csv or .parquet), or a pairs "
                                 "dataset folder (several clips)")
    p.add_argument("--out", required=True, help="output metrics table (.csv or .parquet); for a pairs "
                                                "dataset or --engine ray a folder (resumable)")
    p.add_argument("--metrics", default=",".join(DEFAULT_METRICS),
                   help=f"comma-separated metrics (default {','.join(DEFAULT_METRICS)}; also ms_ssim, "
                        "gmsd, mse, mae; no-reference: brisque, niqe, piqe, entropy; pyiqa:NAME "
                        "with pyiqa installed)")
    add_encoder_arguments(p)
    p.add_argument("--scene", default=None, help="scene folder the image paths are relative to "
                                                 "(default: the pairs table's scene_root column)")
    p.add_argument("--column-tag", default=None,
                   help="name encoder columns nvrq:ENCODER@TAG (default: @PRECISION for bf16/int8, "
                        "none for fp32), e.g. to keep two runtimes' scores apart")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    add_link_option(p)
    add_engine_args(p)
    p.set_defaults(func=run)


def run(args) -> int:
    import cv2

    from data_schema.datasets import is_dataset
    from data_schema.tables import read_table, timing_path, write_table
    from nvrq.scoring.driver import REQUIRED_COLUMNS, score_pairs

    columns, encoder_name = metric_columns(args)
    check_engine_args(args, local_datasets=True)
    if args.engine == "ray":
        return _ray(args, columns, encoder_name)
    if is_dataset(args.pairs):
        return _local_dataset(args, columns, encoder_name)
    if not str(args.out).lower().endswith((".csv", ".parquet")):
        raise InputError(args.out, None, "an output file ending in .csv or .parquet", args.out)
    pairs = read_table(args.pairs, required=REQUIRED_COLUMNS, what="pairs table")
    encoder, tau = encoder_for_columns(args, columns, encoder_name)
    cv2.setNumThreads(1)  # crops are small; leave the cores to the encoder and the decode thread
    res = score_pairs(pairs, metrics=columns, encoder=encoder, tau=tau, scene_root=args.scene,
                      base=Path(args.pairs).resolve().parent, batch_size=args.batch_size,
                      progress=show_progress(args), where=str(args.pairs))
    table, timing = runtime_columns(res.table, res.timing, encoder, tag=args.column_tag)
    write_table(table, args.out)
    tpath = write_table(timing, timing_path(args.out))
    _report(res, uses_encoder=encoder is not None, file=sys.stderr)
    print(f"-> {args.out}, {tpath}")
    return 0


def _report(res, *, uses_encoder: bool, file) -> None:
    """One summary line: pairs/s, images decoded, encoder images per pair; then one line per
    metric and reason with NaN values (:func:`nvrq.scoring.driver.undefined_counts`), and a
    ``warning:`` line per metric NaN on every pair (:func:`~nvrq.scoring.driver.empty_column_warnings`)."""
    wall = res.timing.attrs.get("wall_seconds", float("nan"))
    msg = f"scored {res.n_pairs} pairs in {wall:.1f} s ({res.n_pairs / max(wall, 1e-9):.1f} pairs/s); " \
          f"decoded {res.n_images_decoded} images"
    if uses_encoder:
        per = res.n_encoder_images / max(res.n_pairs, 1)
        msg += (f"; encoder images: {res.n_encoder_images} ({per:.2f} per pair, "
                f"{2 * res.n_pairs} without GT reuse)")
    print(msg, file=file)
    for row in (res.undefined.itertuples(index=False) if res.undefined is not None else ()):
        print(f"{row.metric}: {row.pairs} of {res.n_pairs} pairs NaN ({row.reason})", file=file)
    from nvrq.scoring.driver import empty_column_warnings

    for line in empty_column_warnings(res.undefined, res.n_pairs):
        print(line, file=file)


def _scorer(args, columns, encoder_name, tau) -> MetricScorer:
    """What a sharded run computes; its ``options()`` go to ``_plan.json`` (either engine)."""
    from nvrq.engines.scorers import MetricScorer

    return MetricScorer(tuple(columns), encoder=encoder_options(args, encoder_name), tau=tau,
                        batch_size=args.batch_size)


def _ray(args, columns, encoder_name) -> int:
    from nvrq.metrics.resolve import needs_tau

    tau = command_tau(encoder_name, args) if needs_tau(columns) else None
    return run_ray(args, _scorer(args, columns, encoder_name, tau))


def _local_dataset(args, columns, encoder_name) -> int:
    """A pairs dataset on the local engine: the Ray engine's sharded output and resume, scored
    shard by shard in this process (:func:`nvrq.engines.local.score_dataset`)."""
    import cv2

    from data_schema.tables import timing_path
    from nvrq.engines.local import score_dataset
    from nvrq.metrics.resolve import encoder_columns, needs_tau

    tau = command_tau(encoder_name, args) if needs_tau(columns) else None
    rename = column_renames(columns, tag=args.column_tag, precision=args.precision)
    options = _scorer(args, columns, encoder_name, tau).options()
    options["columns"] = [rename.get(c, c) for c in columns]

    def load():  # only when a shard is left to do
        return load_encoder_and_tau(args, needs_tau=False, name=encoder_name)[0]

    cv2.setNumThreads(1)  # as for a table: the cores go to the encoder and the decode thread
    res = score_dataset(args.pairs, args.out, metrics=columns, options=options,
                        timing_path=timing_path(args.out), load_encoder=load if encoder_columns(columns) else None,
                        tau=tau, batch_size=args.batch_size, shard_pairs=args.shard_pairs, rename=rename,
                        progress=show_progress(args))
    report_sharded(res, args.out, engine="the local engine")
    return 0


def column_renames(columns, *, tag: str | None, precision: str) -> dict[str, str]:
    """``{nvrq:E: nvrq:E@TAG}`` for the encoder columns of ``columns``: TAG is ``tag``, else a
    reduced ``precision`` (bf16/int8), else no renaming (fp32).

    >>> column_renames(["psnr", "nvrq:e"], tag=None, precision="int8")
    {'nvrq:e': 'nvrq:e@int8'}
    """
    from nvrq.metrics.resolve import encoder_columns

    tag = tag if tag is not None else (precision if precision != "fp32" else None)
    return {c: f"{c}@{tag}" for c in encoder_columns(columns)} if tag else {}


def runtime_columns(table, timing, encoder, *, tag: str | None):
    """Tag encoder columns (``nvrq:E`` -> ``nvrq:E@TAG``) and add ``runtime, precision,
    threads, device`` to the timing rows (empty runtime/precision for encoder-free metrics,
    which run in the one decode thread)."""
    from nvrq.metrics.resolve import encoder_columns
    from nvrq.scoring.driver import runtime_timing

    timing = timing.copy()
    enc_cols = encoder_columns(timing["metric"].tolist())
    rename = column_renames(enc_cols, tag=tag, precision="fp32" if encoder is None else encoder.precision)
    if rename:
        table, timing["metric"] = table.rename(columns=rename), timing["metric"].replace(rename)
        enc_cols = [rename[m] for m in enc_cols]
    return table, runtime_timing(timing, encoder, enc_cols)
