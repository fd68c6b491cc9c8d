"""``nvrq score PAIRS --out METRICS.{csv,parquet}`` (SPEC section 4)."""

from __future__ import annotations

import sys
from pathlib import Path

import cv2

from data_schema.errors import InputError
from data_schema.tables import read_table, timing_path, write_table
from nvrq.calibrate import resolve_tau
from nvrq.encoders import DEFAULT_ENCODER, get_spec, load_encoder
from nvrq.metrics import REGISTRY, split_column
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
    p.add_argument("--encoder", default=None, help="encoder for nvrq/nvrq_ca (default efficientnet-lite0)")
    p.add_argument("--weights", default=None,
                   help="local weights: a Hugging Face model folder, or a .pth for efficientnet-lite0")
    p.add_argument("--tau", type=float, default=None, help="NVRQ-CA tau (default: user config, then registry)")
    p.add_argument("--config", default=None, help="tau config file (default $NVRQ_CONFIG or ~/.config/nvrq/tau.json)")
    p.add_argument("--scene", default=None, help="scene folder the image paths are relative to "
                                                 "(default: the pairs table's scene_root column)")
    p.add_argument("--batch-size", type=int, default=32, help="encoder batch size (default 32)")
    p.add_argument("--device", default="cpu", help="torch device, e.g. cpu or cuda (default cpu)")
    p.add_argument("--threads", type=int, default=None, help="torch CPU threads (default: all cores)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def run(args) -> int:
    encoder_name = args.encoder or DEFAULT_ENCODER
    get_spec(encoder_name)
    columns = resolve_metrics(args.metrics.split(","), encoder_name)
    if args.batch_size < 1:
        raise InputError("--batch-size", None, "a positive integer", args.batch_size)
    pairs = read_table(args.pairs, required=REQUIRED_COLUMNS, what="pairs table")
    if not str(args.out).lower().endswith((".csv", ".parquet")):
        raise InputError(args.out, None, "an output file ending in .csv or .parquet", args.out)

    needs_encoder = any(REGISTRY[split_column(c)[0]].needs_encoder for c in columns)
    tau = None
    encoder = None
    if needs_encoder:
        if any(split_column(c)[0] == "nvrq_ca" for c in columns):
            tau, tau_from = resolve_tau(encoder_name, tau=args.tau, config=args.config)
            if tau is None:
                raise InputError("--tau", None, f"a tau for encoder {encoder_name}: run `nvrq calibrate-tau "
                                 f"PAIRS --encoder {encoder_name} --write-config` or pass --tau",
                                 "none in the registry or the user config")
            if not 0 < tau < 1:
                raise InputError("--tau", None, "a number strictly between 0 and 1", tau)
            print(f"tau = {tau:.3f} for {encoder_name} (from {tau_from})", file=sys.stderr)
        import torch


        if args.threads is not None:
            torch.set_num_threads(max(1, args.threads))
        if args.device.startswith("cuda") and not torch.cuda.is_available():
            raise InputError("--device", None, "an available device (cpu, or cuda with a GPU)", args.device)
        encoder = load_encoder(encoder_name, weights=args.weights, device=args.device)


    cv2.setNumThreads(1)  # crops are small; leave the cores to the encoder and the decode thread
    res = score_pairs(pairs, metrics=columns, encoder=encoder, tau=tau, scene_root=args.scene,
                      base=Path(args.pairs).resolve().parent, batch_size=args.batch_size, progress=not args.quiet, where=str(args.pairs))
    write_table(res.table, args.out)
    tpath = write_table(res.timing, timing_path(args.out))
    wall = res.timing.attrs.get("wall_seconds", float("nan"))
    msg = f"scored {res.n_pairs} pairs in {wall:.1f} s ({res.n_pairs / max(wall, 1e-9):.1f} pairs/s); " \
          f"decoded {res.n_images_decoded} images"
    if needs_encoder:
        per = res.n_encoder_images / max(res.n_pairs, 1)
        msg += (f"; encoder images: {res.n_encoder_images} ({per:.2f} per pair, "
                f"{2 * res.n_pairs} without GT reuse)")
    print(msg, file=sys.stderr)
    print(f"-> {args.out}, {tpath}")
    return 0
