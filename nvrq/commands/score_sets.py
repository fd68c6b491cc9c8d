"""``nvrq score-sets SCENE --out SETS.csv``: Fréchet distance and KID per method and view, of whole
frames and of object crops, against the GT (:mod:`nvrq.sets`, docs/FORMATS.md §3c)."""

from __future__ import annotations

from data_schema.defaults import MIN_VISIBLE
from data_schema.errors import InputError
from nvrq.choices import (
    KID_SUBSET_SIZE,
    KID_SUBSETS,
    MAX_KID_SUBSET_SIZE,
    MAX_KID_SUBSETS,
    SET_KINDS,
)
from nvrq.cli_options import add_seed_option
from nvrq.cli_types import add_link_option, add_quiet_option, int_arg, number_arg, show_progress
from nvrq.commands.model_options import add_model_arguments, add_runtime_arguments

__all__ = ["register", "run"]

SET_METRICS = ("fd", "kid")


def register(sub) -> None:
    """Add ``nvrq score-sets``: which sets and set metrics, the encoder, the KID subsets and
    the optional features file.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        ``nvrq``'s subparsers; ``score-sets`` is added with :func:`run` as its ``func``.
    """
    p = sub.add_parser("score-sets", help="FD and KID per method and view: render frames and object crops "
                       "against the GT (docs/FORMATS.md §3c)",
                       description="Fréchet distance and KID of every set (one method, one view) of a scene "
                       "with renders: frames (neurad-studio's lane-shift FID protocol, any encoder) and objects "
                       "(the render crops of nvrq pairs against their GT crops).")
    p.add_argument("scene", help="scene folder with renders (scene.json + images.csv)")
    p.add_argument("--out", required=True, help="sets table (.csv or .parquet), one row per set")
    p.add_argument("--sets", default=",".join(SET_KINDS), help="frames, objects or both (default both)")
    p.add_argument("--metrics", default=",".join(SET_METRICS),
                   help="fd, kid or both (default both; fd alone makes a set too small for FD an error)")
    p.add_argument("--encoder", default=None, help="encoder of the registry (default efficientnet-lite0, offline; "
                   "dinov2-small etc. with --weights FOLDER)")
    p.add_argument("--weights", default=None, help="local weights: a Hugging Face model folder, or a .pth")
    add_model_arguments(p, batch_help="encoder batch size (default 32)")
    add_runtime_arguments(p, precision=False)
    p.add_argument("--kid-subsets", type=int_arg(high=MAX_KID_SUBSETS), default=KID_SUBSETS,
                   help=f"KID subsets, 1 to {MAX_KID_SUBSETS} (default {KID_SUBSETS})")
    p.add_argument("--kid-subset-size", type=int_arg(low=2, high=MAX_KID_SUBSET_SIZE), default=KID_SUBSET_SIZE,
                   help=f"KID subset size, 2 to {MAX_KID_SUBSET_SIZE}, at most the smaller set "
                   f"(default {KID_SUBSET_SIZE})")
    add_seed_option(p, "KID subset seed", default=2020)
    p.add_argument("--min-side", type=number_arg(low=0), default=30,
                   help="objects: the smallest crop side of a pair (default 30, as nvrq pairs)")
    p.add_argument("--min-visible", type=number_arg(low=0, high=1), default=MIN_VISIBLE, metavar="F",
                   help=f"objects: the visibility rule of the pairs (default {MIN_VISIBLE}, as nvrq pairs; "
                        "0 is the paper's protocol)")
    p.add_argument("--save-features", default=None, metavar="F.npz",
                   help="write the features: features (n, d), set_id and side per row")
    p.add_argument("--pairs", default=None, metavar="PAIRS.csv",
                   help="objects: the scene's pairs table of nvrq pairs (its own --min-side and "
                        "--min-visible) instead of making the pairs again")
    p.add_argument("--crop-features", default=None, metavar="F.npz",
                   help="crop embeddings of nvrq score --save-crop-features with the same encoder: "
                        "the object crops found there are not embedded again")
    add_quiet_option(p)
    add_link_option(p)
    p.set_defaults(func=run)


def _choices(text: str, allowed, option: str) -> tuple[str, ...]:
    items = tuple(dict.fromkeys(s.strip() for s in str(text).split(",") if s.strip()))
    bad = [s for s in items if s not in allowed]
    if bad or not items:
        raise InputError(option, None, "a comma-separated list of " + ", ".join(allowed), text)
    return items


def run(args) -> int:
    """``nvrq score-sets``: FD and KID of every set of a scene with renders
    (:func:`nvrq.sets.score_sets`); writes the sets table and, optionally, the features.

    Parameters
    ----------
    args : argparse.Namespace
        ``scene``, ``out``, ``sets``, ``metrics``, the encoder and runtime options, the KID
        options (``kid_subsets``, ``kid_subset_size``, ``seed``), ``min_side``, ``min_visible``,
        ``save_features``, ``pairs`` and ``crop_features``.

    Returns
    -------
    int
        0 once the sets table (and the features file, when asked) is written.
    """
    from pathlib import Path

    import numpy as np

    from data_schema.outputs import check_output_file
    from data_schema.scene import load_scene
    from data_schema.tables import TableKind, read_table, write_table
    from data_schema.text import plural
    from nvrq.commands.model_options import prepare_device
    from nvrq.encoders.registry import encoder_config
    from nvrq.sets import SetOptions, crop_features, score_sets

    kinds = _choices(args.sets, SET_KINDS, "--sets")
    metrics = _choices(args.metrics, SET_METRICS, "--metrics")
    if not str(args.out).lower().endswith((".csv", ".parquet")):
        raise InputError(args.out, None, "an output file ending in .csv or .parquet", args.out)
    if args.save_features is not None:
        if not str(args.save_features).endswith(".npz"):
            raise InputError("--save-features", None, "a file ending in .npz", args.save_features)
        check_output_file(args.save_features, inputs=[args.scene, args.out], option="--save-features")
    cfg = encoder_config(args.encoder, weights=args.weights, device=args.device, runtime=args.runtime,
                         threads=None, cache_dir=args.cache_dir)
    options = SetOptions(kinds=kinds, metrics=metrics, kid_subsets=args.kid_subsets,
                         kid_subset_size=args.kid_subset_size, seed=args.seed, min_side=args.min_side,
                         min_visible=args.min_visible)
    pairs = None
    if getattr(args, "pairs", None) is not None:
        if args.min_side != 30 or args.min_visible != MIN_VISIBLE:
            raise InputError("--pairs", None, "the pairs' own rules: --min-side and --min-visible left out "
                             "(they make the pairs when --pairs is not given)", args.pairs)
        pairs = read_table(args.pairs, kind=TableKind.PAIRS)
    scene = load_scene(args.scene)
    prepare_device(args)
    known = None
    if getattr(args, "crop_features", None) is not None:
        known = crop_features(args.crop_features, cfg)
    table, groups, features, name = score_sets(scene, options, encoder=cfg, batch_size=args.batch_size,
                                               progress=show_progress(args), known=known, pairs=pairs)
    write_table(table, args.out)
    if args.save_features is not None:
        with open(Path(args.save_features), "wb") as f:
            np.savez(f, features=features.astype(np.float64), set_id=groups["set_id"].to_numpy(str),
                     side=groups["side"].to_numpy(str), path=groups["path"].astype(str).to_numpy(str),
                     encoder=np.array(name))
    empty = int((table["reason"] != "").sum())
    note = f" ({plural(empty, 'set')} without a value for some metric: see its reason)" if empty else ""
    print(f"{plural(len(table), 'set')} ({name}){note} -> {args.out}"
          + (f", {args.save_features}" if args.save_features else ""))
    return 0
