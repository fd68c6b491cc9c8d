"""``nvrq stability PAIRS --metrics ... --out DIR``: the stability study (see :mod:`nvrq.stability`).

Writes ``DIR/stability.csv`` (metric, nuisance_or_artefact, kind, strength, mean_abs_change, n),
``DIR/snr.csv`` (metric, nuisance, snr, nuisance_change, artefact_change; ``nuisance = 'all'``
is the overall ratio), ``DIR/samples.csv`` (every scored sample: raw value and change) and
``DIR/stability.png`` / ``.svg``. ``analyze --stability DIR`` adds them to its report.
"""

from __future__ import annotations

import sys
from pathlib import Path

from data_schema.errors import InputError
from data_schema.tables import read_table, write_table
from nvrq.calibrate import resolve_tau
from nvrq.encoders import DEFAULT_ENCODER, load_encoder
from nvrq.metrics import REGISTRY, split_column
from nvrq.scoring import resolve_metrics
from nvrq.stability import plot_stability, run_stability

__all__ = ["register", "run"]


def register(sub) -> None:
    p = sub.add_parser(
        "stability",
        help="how far nuisances vs artefacts move each metric (paper Fig. 4)",
        description="Stability study: nuisances (box/scale jitter, occlusion, exposure, "
        "JPEG, view shift) and synthetic artefacts applied to GT crops.",
    )
    p.add_argument("pairs", help="pairs table from `nvrq pairs` (.csv or .parquet)")
    p.add_argument("--out", required=True, help="output directory")
    p.add_argument(
        "--metrics",
        default="psnr,ssim,nvrq",
        help="comma-separated metrics (default psnr,ssim,nvrq; e.g. "
        "psnr,ssim,gmsd,nvrq:efficientnet-lite0,nvrq_ca:dinov2-small)",
    )
    p.add_argument(
        "--encoder", default=None, help="encoder for nvrq/nvrq_ca (default efficientnet-lite0)"
    )
    p.add_argument("--weights", default=None, help="local encoder weights (HF folder or .pth)")
    p.add_argument(
        "--tau", type=float, default=None, help="NVRQ-CA tau (default: user config, then registry)"
    )
    p.add_argument("--n-objects", type=int, default=60, help="GT crops sampled (default 60)")
    p.add_argument("--seed", type=int, default=0, help="sampling and perturbation seed (default 0)")
    p.add_argument(
        "--min-side", type=int, default=32, help="smallest GT crop side used (default 32)"
    )
    p.add_argument("--batch-size", type=int, default=32, help="encoder batch size (default 32)")
    p.add_argument("--device", default="cpu", help="torch device (default cpu)")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    p.set_defaults(func=run)


def _encoder_name(raw: list[str], default: str | None) -> str:
    named = {split_column(m)[1] for m in raw} - {None}
    if len(named) > 1:
        raise InputError(
            "--metrics", None, "one encoder for all nvrq/nvrq_ca metrics", ", ".join(sorted(named))
        )
    if named and default is not None and named != {default}:
        raise InputError(
            "--metrics", None, f"the encoder given by --encoder ({default})", named.pop()
        )
    return named.pop() if named else (default or DEFAULT_ENCODER)


def run(args) -> int:
    raw = [m.strip() for m in args.metrics.split(",") if m.strip()]
    encoder_name = _encoder_name(raw, args.encoder)
    columns = resolve_metrics(raw, encoder_name)
    for name, v in (
        ("--n-objects", args.n_objects),
        ("--batch-size", args.batch_size),
        ("--min-side", args.min_side),
    ):
        if v < 2 if name == "--n-objects" else v < 1:
            raise InputError(name, None, "a positive integer (--n-objects at least 2)", v)
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise InputError(out, None, "an output directory", "an existing file")
    pairs = read_table(
        args.pairs,
        required=(
            "pair_id",
            "clip_id",
            "camera",
            "track_id",
            "timestamp_us",
            "gt_path",
            "gt_x0",
            "gt_y0",
            "gt_x1",
            "gt_y1",
        ),
        what="pairs table",
    )
    encoder = tau = None
    if any(REGISTRY[split_column(c)[0]].needs_encoder for c in columns):
        if any(split_column(c)[0] == "nvrq_ca" for c in columns):
            tau, _ = resolve_tau(encoder_name, tau=args.tau, config=None)
            if tau is None:
                raise InputError(
                    "--tau",
                    None,
                    f"a tau for encoder {encoder_name} (run `nvrq calibrate-tau` or pass --tau)",
                    "none",
                )
        encoder = load_encoder(encoder_name, weights=args.weights, device=args.device)
    samples, stab, snr = run_stability(
        pairs,
        metrics=columns,
        encoder=encoder,
        tau=tau,
        n_objects=args.n_objects,
        seed=args.seed,
        min_side=args.min_side,
        batch_size=args.batch_size,
        progress=not args.quiet,
        where=str(args.pairs),
    )
    out.mkdir(parents=True, exist_ok=True)
    write_table(samples, out / "samples.csv")
    write_table(stab, out / "stability.csv")
    write_table(snr, out / "snr.csv")
    plot_stability(stab, snr, out / "stability")
    overall = snr[snr.nuisance == "all"].set_index("metric")["snr"]
    print(
        "signal-to-nuisance ratio (all nuisances): "
        + ", ".join(f"{m} {v:.2f}" for m, v in overall.items()),
        file=sys.stderr,
    )
    return 0
