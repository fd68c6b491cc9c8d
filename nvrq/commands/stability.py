"""``nvrq stability PAIRS --metrics ... --out DIR``: the stability study (see :mod:`nvrq.stability`).

Layer: commands (CLI shell).

Writes ``DIR/stability.csv`` (metric, nuisance_or_artefact, kind, strength, mean_abs_change, n),
``DIR/snr.csv`` (metric, nuisance, snr, nuisance_change, artefact_change; ``nuisance = 'all'``
is the overall ratio), ``DIR/samples.csv`` (every scored sample: raw value and change) and
``DIR/stability.png`` / ``.svg``. ``analyze --stability DIR`` adds them to its report.
"""

from __future__ import annotations

import sys
from pathlib import Path

from data_schema.defaults import MIN_SIDE_PX
from data_schema.errors import InputError
from data_schema.outputs import mark_report, replacing_note
from nvrq.cli_options import add_pairs_argument, add_seed_option
from nvrq.cli_types import add_link_option, add_quiet_option, int_arg, show_progress
from nvrq.commands.model_options import add_encoder_arguments
from nvrq.commands.score import load_plan_encoder, plan_from_args, report_tau

__all__ = ["register", "run"]


def register(sub) -> None:
    """Add ``stability``: the metrics compared, the encoder options and how many GT crops
    are perturbed.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The ``nvrq`` subcommands; ``stability`` joins them.
    """
    p = sub.add_parser(
        "stability",
        help="how far nuisances vs artefacts move each metric (paper Fig. 4)",
        description="Stability study: nuisances (box/scale jitter, occlusion, exposure, "
        "JPEG, view shift) and synthetic artefacts applied to GT crops.",
    )
    add_pairs_argument(p)
    p.add_argument("--out", required=True, help="output directory")
    p.add_argument(
        "--metrics",
        default="psnr,ssim,nvrq",
        help="comma-separated metrics (default psnr,ssim,nvrq; e.g. "
        "psnr,ssim,gmsd,nvrq:dinov2-small,nvrq_ca:dinov2-small)",
    )
    add_encoder_arguments(p)
    p.add_argument("--n-objects", type=int_arg(low=2), default=60, help="GT crops sampled (default 60)")
    add_seed_option(p, "sampling and perturbation seed")
    p.add_argument(
        "--min-side", type=int_arg(), default=MIN_SIDE_PX,
        help=f"smallest GT crop side used (default {MIN_SIDE_PX}, as nvrq pairs)"
    )
    add_quiet_option(p)
    add_link_option(p)
    p.set_defaults(func=run)


def run(args) -> int:
    """``nvrq stability``: run the stability study on a pairs table
    (:func:`nvrq.stability.run_stability`) and write the report folder (samples, stability and
    SNR tables, plots); prints the overall signal-to-nuisance ratio per metric.

    Parameters
    ----------
    args : argparse.Namespace
        ``pairs``, ``metrics``, the encoder options, ``n_objects``, ``seed``, ``min_side``
        and ``out`` (a folder, replaced whole).

    Returns
    -------
    int
        0 once the report folder is in place.
    """
    from data_schema.tables import GT_BOX_COLUMNS, TableKind, atomic_folder, read_table, write_table
    from nvrq.stability import (  # SciPy, matplotlib: not for --help
        StabilityOptions,
        plot_stability,
        run_stability,
    )

    plan = plan_from_args(args)  # the metrics, the encoder, tau and the batch size, checked once
    columns = list(plan.columns)
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise InputError(out, None, "an output directory", "an existing file")
    pairs = read_table(args.pairs, required=("pair_id", "clip_id", "camera", "track_id", "timestamp_us",
                                             "gt_path", *GT_BOX_COLUMNS), kind=TableKind.PAIRS)
    report_tau(plan)
    encoder = load_plan_encoder(args, plan)
    options = StabilityOptions(n_objects=args.n_objects, seed=args.seed, min_side=args.min_side,
                               batch_size=plan.batch_size)
    samples, stab, snr = run_stability(pairs, options, metrics=columns, encoder=encoder, tau=plan.tau,
                                       progress=show_progress(args), where=str(args.pairs))
    inputs = {"PAIRS": Path(args.pairs), "--metrics": columns, "--n-objects": args.n_objects, "--seed": args.seed}
    note = replacing_note(out, command="stability", inputs=inputs)
    with atomic_folder(out) as tmp:  # the whole folder or nothing: no file of an older run stays
        mark_report(tmp, command="stability", inputs=inputs)  # a later stability run may replace it
        write_table(samples, tmp / "samples.csv")
        write_table(stab, tmp / "stability.csv")
        write_table(snr, tmp / "snr.csv")
        plot_stability(stab, snr, tmp / "stability")
    if note:
        print(note, file=sys.stderr)
    overall = snr[snr.nuisance == "all"].set_index("metric")["snr"]
    print(
        "signal-to-nuisance ratio (all nuisances): "
        + ", ".join(f"{m} {v:.2f}" for m, v in overall.items()),
        file=sys.stderr,
    )
    return 0
