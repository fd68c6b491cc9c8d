"""``annotate build STUDY --pairs PAIRS [...]``: a study folder from a pairs table
(:func:`annotate.study.build_study`).

Layer: commands (CLI shell) of ``annotate``.
"""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from annotate.commands.serve import base_url
from annotate.load import (
    DEFAULT_ITEMS_PER_RATER,
    SECONDS_PER_VOTE,
    SESSION_MINUTES,
    load_text,
    rater_load,
)
from data_schema.errors import InputError
from data_schema.outputs import check_output_folder
from data_schema.vocab import Sampling
from nvrq.cli_options import add_scene_root_option, add_seed_option
from nvrq.cli_types import (
    DeprecatedFileOption,
    DeprecatedSize,
    add_link_option,
    add_quiet_option,
    allow_negative_lists,
    int_arg,
    parse_wxh,
    show_progress,
)

if TYPE_CHECKING:
    from annotate.design import StudyOptions

__all__ = ["register", "run", "options_from_args"]


def _items_per_rater(text: str) -> int | None:
    """``--items-per-rater``: a positive integer, or ``all`` (None: no cap)."""
    return None if str(text).strip().lower() == "all" else int_arg()(text)


def register(sub) -> None:
    """Add ``build``: the new study folder, the pairs table and every design option
    (:func:`options_from_args` gathers them).

    Parameters
    ----------
    sub : argparse._SubParsersAction
        ``annotate``'s subcommand parsers; ``build`` is the first of them.
    """
    b = sub.add_parser("build", help="build a study folder from a pairs table")
    b.add_argument("study", metavar="STUDY", help="new study folder (absent or empty)")
    b.add_argument("--pairs", required=True, metavar="PAIRS", help="pairs table (docs/FORMATS.md §3; required)")
    add_scene_root_option(b)
    b.add_argument("--metrics-table", dest="metrics_tables", action="append", default=[], metavar="FILE",
                   help="metrics table (pair_id + metric columns) for the export; repeatable "
                   "(default: none)")
    b.add_argument("--metrics", dest="metrics_tables", action=DeprecatedFileOption, new="--metrics-table",
                   help=argparse.SUPPRESS)
    b.add_argument("--tracks", type=int_arg(), default=12,
                   help="tracks, spread over classes and scene attributes (default 12)")
    b.add_argument("--frames-per-track", type=int_arg(), default=12,
                   help="frames spread evenly along each track (default 12)")
    b.add_argument("--offsets", default="all",
                   help="'all' or a comma list of metres, e.g. -1,0,1 (default all)")
    allow_negative_lists(b)  # --offsets -1,0,1 is a value, not an option
    b.add_argument("--votes-per-item", type=int_arg(), default=5, help="votes collected per item (default 5)")
    add_seed_option(b, "seed of every choice")
    b.add_argument("--training", type=int_arg(low=0), default=5,
                   help="training items, shown first, clearly different ones first (default 5)")
    b.add_argument("--gold", type=int_arg(low=0), default=3, help="hidden gold items of each kind (default 3)")
    b.add_argument("--repeats", type=int_arg(low=0), default=5, help="repeated test items (default 5)")
    b.add_argument("--items-per-rater", type=_items_per_rater, default=DEFAULT_ITEMS_PER_RATER, metavar="N",
                   help="the most items one rater is given, training, gold and repeats included, or "
                   f"'all' (default {DEFAULT_ITEMS_PER_RATER}: about {SESSION_MINUTES} min at "
                   f"{SECONDS_PER_VOTE:g} s per vote)")
    b.add_argument("--size", default="320x320", action=DeprecatedSize, metavar="WxH",
                   help="display size of each crop, a square WxH in pixels (default 320x320)")
    b.add_argument("--image-format", default="jpg", choices=["jpg", "png"],
                   help="format of the display crops (default jpg)")
    b.add_argument("--access", default="open", choices=["open", "token", "crowd"],
                   help="open: raters by name, served on this machine only; token: per-rater "
                   "links (add-rater); crowd: a fresh identity per arrival (docs/FORMATS.md §8; "
                   "default open)")
    b.add_argument("--participant-param", metavar="NAME", help="crowd: the panel's participant id "
                   "parameter, e.g. PROLIFIC_PID (one identity per participant; default: none)")
    b.add_argument("--completion-url", metavar="URL", help="crowd: shown to a rater who has finished "
                   "(default: none)")
    b.add_argument("--public-url", metavar="BASE", help="the address raters will use, for the "
                   "printed admin link (default: no link; 'annotate serve' writes it for its port)")
    b.add_argument("--break-every", type=int_arg(), default=50, metavar="N",
                   help="offer a break every N votes (default 50)")
    b.add_argument("--design", default="binary", choices=["binary", "pairwise"],
                   help="binary: good/bad votes on (GT, render); pairwise: which of two methods' "
                   "renders is closer to the GT (the pairs need a method column; default binary)")
    b.add_argument("--methods", metavar="A,B", help="pairwise: comma list of the methods to compare "
                   "(default: every method of the pairs table)")
    b.add_argument("--sampling", default=None, choices=["uniform", "active", "adaptive"],
                   help="where the votes go: uniform (every test item gets --votes-per-item); "
                   "active (pairwise: the next comparison by expected information gain); adaptive "
                   "(binary: stop asking once an item's majority is settled, the freed votes to "
                   "the most uncertain items; docs/FORMATS.md §8, \"Sampling\"); default: active for "
                   "--design pairwise (benchmarks/bench_sampling.py: the same scale error with half "
                   "the comparisons; uniform keeps the balanced design), uniform for binary")
    b.add_argument("--max-votes-per-item", type=int_arg(), default=None, metavar="N",
                   help="adaptive: the most votes one test item may get (default --votes-per-item: "
                   "curtail only; a higher cap spends the freed votes on the most uncertain items)")
    add_link_option(b)
    add_quiet_option(b)
    b.set_defaults(func=run)


def options_from_args(args) -> StudyOptions:
    """The study's options from ``annotate build``'s parsed arguments (the one place they are
    gathered).

    Parameters
    ----------
    args : argparse.Namespace
        ``annotate build``'s arguments.

    Returns
    -------
    annotate.design.StudyOptions
        The options :func:`annotate.study.build_study` checks and uses.

    Raises
    ------
    InputError
        ``--size`` is not a square WxH.
    """
    from annotate.design import StudyOptions  # pandas: not for --help

    width, height = parse_wxh(args.size, option="--size")
    if width != height:
        raise InputError("--size", None, "a square WxH (display crops are square), e.g. 320x320", args.size)
    return StudyOptions(
        tracks=args.tracks, frames_per_track=args.frames_per_track, offsets=args.offsets,
        votes_per_item=args.votes_per_item, seed=args.seed, n_training=args.training,
        n_gold=args.gold, n_repeats=args.repeats, size=width, image_format=args.image_format,
        access=args.access, break_every=args.break_every, design=args.design, methods=args.methods,
        scene=args.scene, metrics_paths=tuple(args.metrics_tables),
        participant_param=args.participant_param, completion_url=args.completion_url,
        items_per_rater=args.items_per_rater, sampling=args.sampling,
        max_votes_per_item=args.max_votes_per_item)


def run(args) -> int:
    """Build the study; print its item counts and the admin page's link (the only time the
    admin token is printed).

    Parameters
    ----------
    args : argparse.Namespace
        ``study`` (absent or empty), ``pairs``, ``metrics_tables``, ``scene``, ``public_url``,
        ``quiet`` and the design options of :func:`options_from_args`.

    Returns
    -------
    int
        0 once the study folder is complete (it is written whole or not at all).
    """
    from annotate.study import build_study, load_study

    check_output_folder(args.study, kind="study", option="STUDY",
                        inputs=[args.pairs, *args.metrics_tables, args.scene])
    admin_base = base_url(public_url=args.public_url)
    out = build_study(args.study, args.pairs, options_from_args(args), progress=show_progress(args))
    study = load_study(out)
    counts = ", ".join(f"{v} {k}" for k, v in study.manifest.counts.items())
    share = study.rater_counts()["gold"]
    pool = f" (each rater sees {share} of the {study.manifest.counts['gold']} gold)" \
        if share < study.manifest.counts["gold"] else ""
    print(f"study {out}: {counts} items{pool}")
    if args.sampling is None and study.manifest.sampling != Sampling.UNIFORM:  # a default's change
        print(f"sampling: {study.manifest.sampling} (the default for {study.design} studies; "
              "--sampling uniform gives every comparison the same number of votes)")
    load = rater_load(study.rater_counts(), items_per_rater=args.items_per_rater,
                      votes_per_item=args.votes_per_item)
    print(load_text(load, votes_per_item=args.votes_per_item))
    if args.public_url is not None:
        print(f"admin page: {admin_base}?admin={study.admin_token()} "
              f"(the admin token is printed only now; it is kept in {out / 'secrets.json'})")
    else:  # the port is serve's: its own link is in STUDY/admin-link.txt once it runs
        print(f"admin token: {study.admin_token()} (printed only now; kept in {out / 'secrets.json'}); "
              f"the admin page is ?admin=TOKEN on the address 'annotate serve' prints, which "
              f"writes the full link to {out / 'admin-link.txt'}")
    return 0
