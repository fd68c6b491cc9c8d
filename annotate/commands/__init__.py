"""Subcommands of the ``annotate`` CLI, one module each with ``register(sub)`` and ``run(args)``
(see :mod:`annotate.cli`), and the positional ``STUDY`` they share (:func:`add_study_argument`).

Layer: commands (CLI shell) of ``annotate``.

A ``run`` returns the exit status; bad input raises :class:`~data_schema.errors.InputError`,
which :func:`nvrq.cli_types.run_cli` prints as one line with exit status 2.
"""

from __future__ import annotations

__all__ = ["add_study_argument"]


def add_study_argument(parser, *, need: str = "") -> None:
    """Add the positional ``study`` (metavar ``STUDY``): a folder ``annotate build`` made.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The parser of a command that works on an existing study.
    need : str, optional
        What else the command needs of the study, appended to the help in parentheses, e.g.
        ``"good/bad design"`` (default: nothing).
    """
    more = f" ({need})" if need else ""
    parser.add_argument("study", metavar="STUDY", help=f"study folder made by 'annotate build'{more}")
