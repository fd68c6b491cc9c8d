"""``annotate export STUDY --out RATINGS``: the votes as ratings.csv (docs/FORMATS.md §5; a
pairwise study's votes: §12)."""

from __future__ import annotations

import sys

from data_schema.outputs import check_output_file

__all__ = ["register", "run"]


def register(sub) -> None:
    """Add ``export`` to the ``annotate`` subcommands ``sub``."""
    e = sub.add_parser("export", help="write ratings.csv (docs/FORMATS.md §5; a pairwise "
                       "study's votes: §12)")
    e.add_argument("study", metavar="STUDY", help="study folder made by 'annotate build'")
    e.add_argument("--out", required=True, metavar="RATINGS",
                   help="the votes table to write (.csv or .parquet; required)")
    e.set_defaults(func=run)


def run(args) -> int:
    """Write the votes table; warn on stderr about votes that could not be placed."""
    from annotate.results import votes_table
    from annotate.study import load_study, unplaced_votes
    from data_schema.tables import write_table

    check_output_file(args.out, inputs=[args.study])
    study = load_study(args.study)
    table = votes_table(study)
    lost = unplaced_votes(study)
    write_table(table, args.out)
    print(f"{len(table)} votes -> {args.out}", file=sys.stderr)
    if lost:
        print(f"warning: {sum(lost.values())} votes not exported: "
              + "; ".join(f"{n} {why}" for why, n in lost.items()), file=sys.stderr)
    return 0
