"""``nvrq score PAIRS --out METRICS.{csv,parquet}`` (SPEC section 4)."""

from __future__ import annotations

import sys
from pathlib import Path

import cv2

from data_schema.cliargs import comma_list
from data_schema.errors import InputError
from data_schema.tables import read_table, timing_path, write_table
from nvrq.commands._encoder import (
    add_encoder_arguments,
    encoder_for_metrics,
    load_encoder_and_tau,
)
from nvrq.score_core import encoder_columns
from nvrq.scoring import REQUIRED_COLUMNS, resolve_metrics, score_pairs

__all__ = ["register", "run", "timing_path"]


def register(sub) -> None:
    p = sub.add_parser("score", help="NVRQ, NVRQ-CA and pixel metrics per pair (SPEC section 4)",
                       description="Score every GT/render crop pair of a pairs table. Writes "
                                   "METRICS and METRICS.timing.csv (metric, seconds, pairs).")
    p.add_argument("pairs", help="pairs table from `nvrq pairs` (.csv or .parquet)")
    p.add_argument("--out", required=True, help="output metrics table (.csv or .parquet)")
    p.add_argument("--metrics", default="psnr,ssim,nvrq,nvrq_ca",
                   help="comma-separated metrics (default psnr,ssim,nvrq,nvrq_ca; also ms_ssim, "
                        "gmsd, mse, mae)")
    add_encoder_arguments(p)
    p.add_argument("--scene", default=None, help="scene folder the image paths are relative to "
                                                 "(default: the pairs table's scene_root column)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def run(args) -> int:


    raw = comma_list(args.metrics)
    encoder_name = encoder_for_metrics(raw, args.encoder)
    columns = resolve_metrics(raw, encoder_name)
    pairs = read_table(args.pairs, required=REQUIRED_COLUMNS, what="pairs table")
    if not str(args.out).lower().endswith((".csv", ".parquet")):
        raise InputError(args.out, None, "an output file ending in .csv or .parquet", args.out)
    enc_cols = encoder_columns(columns)
    encoder = tau = None
    if enc_cols:
        needs_tau = any(c.startswith("nvrq_ca:") for c in enc_cols)
        encoder, tau = load_encoder_and_tau(args, needs_tau=needs_tau, name=encoder_name)
    cv2.setNumThreads(1)  # crops are small; leave the cores to the encoder and the decode thread
    res = score_pairs(pairs, metrics=columns, encoder=encoder, tau=tau, scene_root=args.scene,
                      base=Path(args.pairs).resolve().parent, batch_size=args.batch_size,
                      progress=not args.quiet, where=str(args.pairs))
    write_table(res.table, args.out)
    tpath = write_table(res.timing, timing_path(args.out))
    _report(res, uses_encoder=bool(enc_cols), file=sys.stderr)
    print(f"-> {args.out}, {tpath}")
    return 0


def _report(res, *, uses_encoder: bool, file) -> None:
    """One summary line: pairs/s, images decoded, encoder images per pair."""
    wall = res.timing.attrs.get("wall_seconds", float("nan"))
    msg = f"scored {res.n_pairs} pairs in {wall:.1f} s ({res.n_pairs / max(wall, 1e-9):.1f} pairs/s); " \
          f"decoded {res.n_images_decoded} images"
    if uses_encoder:
        per = res.n_encoder_images / max(res.n_pairs, 1)
        msg += (f"; encoder images: {res.n_encoder_images} ({per:.2f} per pair, "
                f"{2 * res.n_pairs} without GT reuse)")
    print(msg, file=file)
