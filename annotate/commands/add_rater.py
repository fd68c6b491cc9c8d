"""``annotate add-rater STUDY NAME [--host H] [--port P] [--public-url BASE]``: register a rater,
print the sign-in link (a token link on a token or crowd study).

Layer: commands (CLI shell) of ``annotate``.
"""

from __future__ import annotations

import secrets

from annotate.access import check_serving
from annotate.commands.serve import add_address_options, base_url
from data_schema.raters import check_rater_name

__all__ = ["register", "run"]


def register(sub) -> None:
    """Add ``add-rater`` to the ``annotate`` subcommands ``sub``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The ``annotate`` subcommand parsers.
    """
    a = sub.add_parser("add-rater", help="register a rater and print the sign-in link")
    a.add_argument("study", metavar="STUDY", help="study folder made by 'annotate build'")
    a.add_argument("name", metavar="NAME", help="the rater's name (1-40 letters, digits, '.', '_' or '-')")
    add_address_options(a)
    a.set_defaults(func=run)


def run(args) -> int:
    """Register ``args.name`` (with a secret token on a token or crowd study) and print its link.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options of ``annotate add-rater``.

    Returns
    -------
    int
        The exit status, 0 on success (bad input raises
        :class:`~data_schema.errors.InputError`, status 2 through
        :func:`~nvrq.commands.args.run_cli`).
    """
    from annotate.study import load_study

    study = load_study(args.study)
    name = check_rater_name(args.name)
    base = base_url(args.host, args.port, public_url=args.public_url)
    check_serving(study.manifest["access"], host=args.host, public_url=args.public_url)
    if study.manifest["access"] in ("token", "crowd"):
        token = secrets.token_urlsafe(18)
        study.store.add_rater(name, plan=study.new_plan(name), token=token)
        print(f"{base}?token={token}")
    else:
        study.plan_for(name)
        print(f"{base}?rater={name}")
    return 0
