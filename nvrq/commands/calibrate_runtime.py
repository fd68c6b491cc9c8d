"""``nvrq calibrate-runtime PAIRS --encoder E --runtime R --precision P``: measure the drift of
a reduced precision against torch fp32 and record it (:mod:`nvrq.encoders.drift`).

Layer: commands (CLI shell).
"""

from __future__ import annotations

from pathlib import Path

from data_schema.text import plural
from nvrq.cli_options import add_pairs_argument, add_scene_root_option, add_seed_option
from nvrq.cli_types import add_link_option, int_arg, number_arg
from nvrq.commands.model_options import add_cache_dir_argument
from nvrq.encoders import get_spec
from nvrq.encoders.runtimes import PRECISIONS

__all__ = ["register", "run"]


def register(sub) -> None:
    """Add ``calibrate-runtime``: the pairs sampled, the runtime and precision checked, and the
    cache folder its record goes to.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        ``nvrq``'s subcommands, given ``calibrate-runtime``.
    """
    p = sub.add_parser("calibrate-runtime", help="drift check of a runtime/precision against torch fp32",
                       description="Embed the GT and render crops of a sample of pairs in torch fp32 and "
                                   "in RUNTIME/PRECISION; report mean/min cosine, NVRQ Spearman and max "
                                   "|dNVRQ|, and record the check (CACHE/runtime_checks.json), which "
                                   "`nvrq score --precision` requires.")
    add_pairs_argument(p)
    p.add_argument("--encoder", default=None, help=f"encoder (default {get_spec().name})")
    p.add_argument("--weights", default=None, help="local weights (HF model folder or .pth)")
    p.add_argument("--runtime", default="openvino", choices=["openvino", "onnxruntime"],
                   help="runtime checked against torch fp32 (default openvino)")
    p.add_argument("--precision", default="int8", choices=PRECISIONS,
                   help="precision checked (default int8; onnxruntime: fp32 or int8). int8 passed "
                        "for dinov2-small and failed for efficientnet-lite0 where measured: the "
                        "command prints the numbers")
    add_scene_root_option(p)
    p.add_argument("--sample", type=int_arg(), default=200, help="pairs checked (default 200)")
    p.add_argument("--calib", type=int_arg(), default=150,
                   help="other pairs whose GT crops calibrate int8 (default 150)")
    add_seed_option(p, "sampling seed")
    p.add_argument("--min-spearman", type=number_arg(low=-1, high=1), default=None,
                   help="pass threshold reported here (default 0.999; `score` applies its own)")
    add_cache_dir_argument(p)
    p.add_argument("--random-weights", action="store_true", help="random weights (seed 0; benchmarks and tests without checkpoints)")
    add_link_option(p)
    p.set_defaults(func=run)


def run(args) -> int:
    """Embed ``args.sample`` pairs in torch fp32 and in ``args.runtime``/``args.precision``,
    print the drift, record it in the cache and say whether ``nvrq score`` will accept it.

    Parameters
    ----------
    args : argparse.Namespace
        ``pairs``, ``encoder``/``weights`` (or ``random_weights``), ``runtime``, ``precision``,
        ``sample``, ``calib``, ``seed``, ``min_spearman`` and ``cache_dir``.

    Returns
    -------
    int
        0 whether the check passes or fails: a failed check is recorded and printed too.
    """
    from data_schema.tables import TableKind, read_table
    from nvrq.encoders import build_random, load_encoder
    from nvrq.encoders.drift import (
        DEFAULT_MIN_SPEARMAN,
        check_runtime,
        measured_text,
        pair_inputs,
        write_record,
    )
    from nvrq.scoring.driver import REQUIRED_COLUMNS

    spec = get_spec(args.encoder)
    name = spec.name
    pairs = read_table(args.pairs, required=REQUIRED_COLUMNS, kind=TableKind.PAIRS)
    base = Path(args.pairs).resolve().parent
    gt, render = pair_inputs(pairs, spec.input_size, n=args.sample + args.calib, seed=args.seed,
                             scene_root=args.scene, base=base, where=str(args.pairs))
    calib = gt[args.sample:] if len(gt) > args.sample else gt  # disjoint from the checked pairs when possible
    gt, render = gt[:args.sample], render[:args.sample]
    enc = (build_random(name, runtime="torch") if args.random_weights
           else load_encoder(name, weights=args.weights, runtime="torch"))
    rec = check_runtime(enc, gt, render, runtime=args.runtime, precision=args.precision,
                        calib=calib, cache_dir=args.cache_dir)
    rec.update(pairs=str(Path(args.pairs).resolve()), n_calibration_crops=int(len(calib)))
    path = write_record(rec, args.cache_dir)
    threshold = DEFAULT_MIN_SPEARMAN if args.min_spearman is None else args.min_spearman
    verdict = "passes" if rec["nvrq_spearman"] >= threshold else "FAILS"
    print(f"{name} {args.runtime}/{args.precision} vs torch fp32 on {plural(rec['n_pairs'], 'pair')}: "
          f"cosine mean {rec['mean_cosine']:.5f} min {rec['min_cosine']:.5f}; NVRQ Spearman "
          f"{rec['nvrq_spearman']:.5f}; max |dNVRQ| {rec['max_dnvrq']:.2e}; {verdict} Spearman >= {threshold}")
    print(f"recorded in {path}")
    measured = measured_text(args.precision, threshold)
    if measured:  # where this precision passed and failed before
        print(measured)
    tag = f"--runtime {args.runtime} --precision {args.precision}"
    if verdict == "passes":
        print(f"nvrq score {tag} --encoder {name} may use it: the record is on file.")
    else:
        print(f"FAILS the check: nvrq score {tag} --encoder {name} will refuse it. The ranking "
              f"drifts too far from fp32 (NVRQ Spearman {rec['nvrq_spearman']:.3f} < {threshold}); "
              "use fp32 on this runtime, or try --precision bf16 (check it the same way). "
              "docs/guides/walkthrough.md ('Reduced precision') has the measurements above.")
    return 0
