"""``nvrq calibrate-tau PAIRS --encoder ENC``: an encoder's NVRQ-CA tau from its noise floor.

Layer: commands (CLI shell).

Rule: tau = median of S over GT crops of unrelated objects (different tracks and classes).
"""

from __future__ import annotations

import datetime as dt

from nvrq.cli_options import add_pairs_argument, add_scene_root_option, add_seed_option
from nvrq.cli_types import add_link_option, add_quiet_option, int_arg, show_progress
from nvrq.commands.model_options import add_encoder_arguments, load_encoder_and_tau

__all__ = ["register", "run"]


def register(sub) -> None:
    """Add ``calibrate-tau``: the encoder options (no ``--tau``: it is what this measures) and
    how many unrelated GT crops and pairs to sample.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The subparsers of ``nvrq``; ``calibrate-tau`` is added to them.
    """
    p = sub.add_parser("calibrate-tau", help="measure an encoder's NVRQ-CA tau (median S of unrelated objects)",
                       description="S (paper Eq. 4) over GT crops of unrelated objects -- different "
                                   "tracks and classes, GT vs GT -- and the tau it recommends: the median.")
    add_pairs_argument(p)
    add_encoder_arguments(p, tau=False)
    add_scene_root_option(p)
    p.add_argument("--max-crops", type=int_arg(), default=400, help="GT crops sampled (default 400)")
    p.add_argument("--max-pairs", type=int_arg(), default=20000, help="unrelated pairs sampled (default 20000)")
    add_seed_option(p, "sampling seed")
    p.add_argument("--allow-same-class", action="store_true",
                   help="also pair objects of the same class (different tracks), e.g. one-class scenes")
    p.add_argument("--write-config", action="store_true", help="store the tau in the --config file")
    add_quiet_option(p)
    add_link_option(p)
    p.set_defaults(func=run)


def run(args) -> int:
    """Measure the encoder's S over unrelated GT crops, print the summary and, with
    ``--write-config``, store the median as its tau in the config file.

    Parameters
    ----------
    args : argparse.Namespace
        ``pairs``, the encoder options, ``max_crops``, ``max_pairs``, ``seed``,
        ``allow_same_class``, ``write_config`` and ``config``.

    Returns
    -------
    int
        0 once the tau is printed (and written, when asked).
    """
    from data_schema.tables import TableKind, read_table
    from nvrq.calibrate import CalibrationOptions, calibrate_tau, config_path, write_tau

    pairs = read_table(args.pairs, kind=TableKind.PAIRS)
    encoder, _ = load_encoder_and_tau(args, needs_tau=False)
    options = CalibrationOptions(max_crops=args.max_crops, max_pairs=args.max_pairs, seed=args.seed,
                                 allow_same_class=args.allow_same_class, batch_size=args.batch_size)
    cal = calibrate_tau(pairs, encoder, options, scene_root=args.scene, progress=show_progress(args),
                        where=str(args.pairs))
    print(cal.summary())
    if args.write_config:
        path = write_tau(config_path(args.config), cal.encoder, cal.tau,
                         rule="median S of unrelated GT crops", n_pairs=int(len(cal.s)),
                         n_crops=int(cal.n_crops), pairs=str(args.pairs),
                         measured_at=dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds"))
        print(f"wrote tau {cal.tau:.3f} for {cal.encoder} to {path}")
    return 0
