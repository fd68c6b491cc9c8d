"""``annotate export STUDY --out RATINGS [--participants FILE]``: the votes as ratings.csv
(docs/FORMATS.md §5; a pairwise study's votes: §12); a crowd study's raters and the panel's
participant ids as a second table (§8).

Layer: commands (CLI shell) of ``annotate``.
"""

from __future__ import annotations

import sys
from pathlib import Path

from annotate.commands import add_study_argument
from data_schema.errors import InputError
from data_schema.outputs import check_output_file
from data_schema.text import plural

__all__ = ["register", "run"]


def register(sub) -> None:
    """Add ``export``: where the votes table goes, the optional participants table, and
    ``--raw-csv`` (text cells not guarded against spreadsheet formulas).

    Parameters
    ----------
    sub : argparse._SubParsersAction
        ``annotate``'s subcommands, to which ``export`` is added.
    """
    e = sub.add_parser("export", help="write ratings.csv (docs/FORMATS.md §5; a pairwise "
                       "study's votes: §12)")
    add_study_argument(e)
    e.add_argument("--out", required=True, metavar="RATINGS",
                   help="the votes table to write (.csv or .parquet; required)")
    e.add_argument("--participants", metavar="FILE", help="also write the crowd raters' panel "
                   "participant ids: rater_id, participant, arrived_at (default: not written)")
    e.add_argument("--raw-csv", action="store_true", help="write text cells as they came (by "
                   "default a CSV cell starting with = + - @ or a tab gets a leading ' so that a "
                   "spreadsheet does not run it as a formula; analyze reads either)")
    e.set_defaults(func=run)


def run(args) -> int:
    """Write the votes table (and the participants table); on stderr, warn about votes that
    could not be placed and name, per rater, the votes undone and the presses dropped as too
    fast (from the history).

    Parameters
    ----------
    args : argparse.Namespace
        ``study``, ``out`` and ``participants`` (paths; both outputs are checked before either
        is written) and ``raw_csv``.

    Returns
    -------
    int
        0, also when some votes could not be placed (they are counted in a warning).
    """
    from annotate.results import votes_table
    from annotate.study import load_study, unplaced_votes
    from data_schema.csv_safe import write_people_table
    from data_schema.tables import TABLE_SUFFIXES

    check_output_file(args.out, inputs=[args.study])
    if args.participants is not None:  # both checked before either is written
        check_output_file(args.participants, inputs=[args.study, args.out], option="participants")
        if Path(args.participants).suffix.lower() not in TABLE_SUFFIXES:
            raise InputError(param="participants", expected="a table file ending in .csv or .parquet",
                             got=args.participants)
    study = load_study(args.study)
    table = votes_table(study)
    lost = unplaced_votes(study)
    raw = getattr(args, "raw_csv", False)
    write_people_table(table, args.out, raw=raw)
    print(f"{plural(len(table), 'vote')} -> {args.out}", file=sys.stderr)
    if args.participants is not None:
        who = study.store.participants().rename(columns={"rater": "rater_id"})
        write_people_table(who, args.participants, raw=raw)
        print(f"{plural(len(who), 'participant')} -> {args.participants}", file=sys.stderr)
    if lost:
        print(f"warning: {plural(sum(lost.values()), 'vote')} not exported: "
              + "; ".join(f"{n} {why}" for why, n in lost.items()), file=sys.stderr)
    acts = study.store.action_counts()
    for r in acts[(acts["votes_undone"] > 0) | (acts["too_fast"] > 0)].itertuples():
        print(f"rater {r.rater}: {plural(r.votes_undone, 'vote')} undone, "
              f"{plural(r.too_fast, 'press', 'presses')} too fast "
              "(not in the table; the store's history keeps them)", file=sys.stderr)
    return 0
