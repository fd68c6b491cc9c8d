"""``annotate export STUDY --out RATINGS``: the votes as ratings.csv (docs/FORMATS.md §5; a
pairwise study's votes: §12)."""

from __future__ import annotations

import sys

from annotate.results import votes_table
from annotate.study import load_study, unplaced_votes
from data_schema.outputs import check_output_file
from data_schema.tables import write_table

__all__ = ["register", "run"]


def register(sub) -> None:
    """Add ``export`` to the ``annotate`` subcommands ``sub``."""
    e = sub.add_parser("export", help="write ratings.csv (docs/FORMATS.md §5; a pairwise "
                       "study's votes: §12)")
    e.add_argument("study")
    e.add_argument("--out", required=True)
    e.set_defaults(func=run)


def run(args) -> int:
    """Write the votes table; on stderr, warn about votes that could not be placed and name,
    per rater, the votes undone and the presses dropped as too fast (from the history)."""
    check_output_file(args.out, inputs=[args.study])
    study = load_study(args.study)
    table = votes_table(study)
    lost = unplaced_votes(study)
    write_table(table, args.out)
    print(f"{len(table)} votes -> {args.out}", file=sys.stderr)
    if lost:
        print(f"warning: {sum(lost.values())} votes not exported: "
              + "; ".join(f"{n} {why}" for why, n in lost.items()), file=sys.stderr)
    acts = study.store.action_counts()
    for r in acts[(acts["votes_undone"] > 0) | (acts["too_fast"] > 0)].itertuples():
        print(f"rater {r.rater}: {r.votes_undone} votes undone, {r.too_fast} presses too fast "
              "(not in the table; the store's history keeps them)", file=sys.stderr)
    return 0
