"""The ``annotate`` command: build, serve, add-rater, export, gvf, simulate, rate-yourself (thin shell).

Layer: commands (CLI shell) of ``annotate``.

Each subcommand lives in ``annotate/commands/<name>.py`` and exposes ``register(sub)``, which
adds its parser and sets ``func`` to its ``run(args)`` (returns an exit status), as the
``nvrq`` commands do (:mod:`nvrq.cli`). The argument conventions are
:mod:`nvrq.cli_types`. A command imports the library it runs (pandas, OpenCV, the study)
in ``run``, so ``annotate --help`` answers without them.
"""

from __future__ import annotations

import sqlite3
import sys
from pathlib import Path

from data_schema.errors import InputError
from nvrq.cli_types import ArgumentParser, command_parser, flags_in_errors, run_cli

__all__ = ["main", "build_parser"]

#: Subcommand modules, in the order ``annotate --help`` lists them.
COMMAND_MODULES = [
    "annotate.commands.build",
    "annotate.commands.serve",
    "annotate.commands.add_rater",
    "annotate.commands.export",
    "annotate.commands.gvf",
    "annotate.commands.simulate",
    "annotate.commands.rate_yourself",
]

#: Library parameter names that differ from this CLI's argparse dests.
_ALIASES = {"n_training": "training", "n_gold": "gold", "n_repeats": "repeats",
            "metrics_path": "metrics_tables", "scene_root": "scene"}


def build_parser() -> ArgumentParser:
    """The ``annotate`` parser: every subcommand of :data:`COMMAND_MODULES`
    (:func:`nvrq.cli_types.command_parser`).

    Returns
    -------
    ArgumentParser
    """
    return command_parser("annotate", "Rating studies of render quality.", COMMAND_MODULES)


def _main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)  # --help and --version end here
    from data_schema.tables import no_follow_links  # pandas: after --help has answered

    try:
        with flags_in_errors(parser, args, _ALIASES), no_follow_links(getattr(args, "no_follow_links", False)):
            return args.func(args)
    except sqlite3.Error as exc:  # a damaged vote store: one line naming it
        raise InputError(Path(args.study) / "votes.sqlite", None, "a readable SQLite vote store",
                         f"{type(exc).__name__}: {exc}") from None


def main(argv=None) -> int:
    """Entry point of the ``annotate`` console script: run the subcommand of ``argv`` (default
    ``sys.argv[1:]``) and return its exit status (2 for bad input, :func:`nvrq.cli_types.run_cli`).

    Parameters
    ----------
    argv : list of str, optional
        A subcommand and its options, e.g. ``["export", "STUDY", "--out", "ratings.csv"]``
        (default ``sys.argv[1:]``).

    Returns
    -------
    int
        The subcommand's exit status; 2 after the one-line message of bad input (a damaged
        vote store included).
    """
    return run_cli(_main, argv)


if __name__ == "__main__":
    sys.exit(main())
