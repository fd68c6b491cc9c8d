"""``annotate gvf STUDY [--out FILE]``: the good-vote fraction of each test item (binary studies).

Layer: commands (CLI shell) of ``annotate``.
"""

from __future__ import annotations

from pathlib import Path

from annotate.commands import add_study_argument
from data_schema.errors import InputError
from data_schema.outputs import check_output_file
from data_schema.vocab import StudyDesign

__all__ = ["register", "run"]


def register(sub) -> None:
    """Add ``gvf``, which reads a binary (good/bad) study's votes and writes, or prints, the
    good-vote fraction of each test item.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        Where ``annotate`` keeps its subcommands; ``gvf`` is added to it.
    """
    g = sub.add_parser("gvf", help="per-item good-vote fraction of test items")
    add_study_argument(g, need="good/bad design")
    g.add_argument("--out", metavar="FILE", help="table to write (.csv or .parquet; default: print it)")
    g.set_defaults(func=run)


def run(args) -> int:
    """Write the GVF table (:func:`annotate.results.gvf_table`) to ``args.out``, or print it
    when no ``--out`` is given.

    Parameters
    ----------
    args : argparse.Namespace
        ``study`` (a binary study) and ``out`` (a table path, or None to print).

    Returns
    -------
    int
        0; a pairwise study is refused (its votes have no good-vote fraction).
    """
    from annotate.results import gvf_table, ratings_table
    from annotate.study import load_study
    from data_schema.tables import write_table

    if args.out:
        check_output_file(args.out, inputs=[args.study])
    study = load_study(args.study)
    if study.design != StudyDesign.BINARY:
        raise InputError(Path(args.study) / "manifest.json", "design", "a good/bad (binary) study "
                         "for a good-vote fraction; export a pairwise study's votes with "
                         "'annotate export'", study.design)
    table = gvf_table(ratings_table(study))
    if args.out:
        write_table(table, args.out)
    else:
        print(table.to_string(index=False))
    return 0
