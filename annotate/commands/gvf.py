"""``annotate gvf STUDY [--out FILE]``: the good-vote fraction of each test item (binary studies).

Layer: commands (CLI shell) of ``annotate``.
"""

from __future__ import annotations

from pathlib import Path

from data_schema.errors import InputError
from data_schema.outputs import check_output_file

__all__ = ["register", "run"]


def register(sub) -> None:
    """Add ``gvf`` to the ``annotate`` subcommands ``sub``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The ``annotate`` subcommand parsers.
    """
    g = sub.add_parser("gvf", help="per-item good-vote fraction of test items")
    g.add_argument("study", metavar="STUDY", help="study folder made by 'annotate build' (good/bad design)")
    g.add_argument("--out", metavar="FILE", help="table to write (.csv or .parquet; default: print it)")
    g.set_defaults(func=run)


def run(args) -> int:
    """Write the GVF table to ``args.out``, or print it when no ``--out`` is given.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options of ``annotate gvf``.

    Returns
    -------
    int
        The exit status, 0 on success (bad input raises
        :class:`~data_schema.errors.InputError`, status 2 through
        :func:`~nvrq.commands.args.run_cli`).
    """
    from annotate.results import gvf_table, ratings_table
    from annotate.study import load_study
    from data_schema.tables import write_table

    if args.out:
        check_output_file(args.out, inputs=[args.study])
    study = load_study(args.study)
    if study.design != "binary":
        raise InputError(Path(args.study) / "manifest.json", "design", "a good/bad (binary) study "
                         "for a good-vote fraction; export a pairwise study's votes with "
                         "'annotate export'", study.design)
    table = gvf_table(ratings_table(study))
    if args.out:
        write_table(table, args.out)
    else:
        print(table.to_string(index=False))
    return 0
