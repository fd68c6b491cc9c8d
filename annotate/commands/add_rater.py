"""``annotate add-rater STUDY NAME [--host H] [--port P] [--public-url BASE] [--rotate]``:
register a rater, print the sign-in link (a token link on a token or crowd study)."""

from __future__ import annotations

import secrets
import sys

from annotate.access import check_serving
from annotate.commands import add_study_argument
from annotate.commands.serve import (
    DEFAULT_HOST,
    DEFAULT_PORT,
    add_address_options,
    base_url,
    served_base,
)
from data_schema.errors import InputError
from data_schema.raters import check_rater_name
from data_schema.vocab import Access

__all__ = ["register", "run"]


def register(sub) -> None:
    """Add ``add-rater``: the study, the rater's name, the address the printed link names
    (:func:`annotate.commands.serve.add_address_options`, no defaults) and ``--rotate``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The parsers of ``annotate``'s subcommands; ``add-rater`` joins them.
    """
    a = sub.add_parser("add-rater", help="register a rater and print the sign-in link")
    add_study_argument(a)
    a.add_argument("name", metavar="NAME", help="the rater's name (1-40 letters, digits, '.', '_' or '-')")
    add_address_options(a, defaults=False)
    a.add_argument("--rotate", action="store_true", help="give a registered rater a new link "
                   "(token and crowd studies; the old link stops working)")
    a.set_defaults(func=run)


def run(args) -> int:
    """Register ``args.name`` (with a secret token on a token or crowd study) and print its link.

    A name registered already is refused on a token or crowd study (a new token would
    revoke the link the rater has) unless ``--rotate`` asks for exactly that; the old link
    then stops working, and the command says so. The link's base is ``--public-url``, else
    ``--host``/``--port``, else the address ``annotate serve`` last served the study at,
    else ``http://127.0.0.1:8501/``.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed options: ``study``, ``name``, ``host``, ``port``, ``public_url``, ``rotate``.

    Returns
    -------
    int
        The exit status, 0.
    """
    from annotate.study import load_study

    study = load_study(args.study)
    name = check_rater_name(args.name)
    explicit = args.host is not None or args.port is not None or args.public_url is not None
    host = DEFAULT_HOST if args.host is None else args.host
    base = (base_url(host, DEFAULT_PORT if args.port is None else args.port, public_url=args.public_url)
            if explicit else served_base(study.root) or base_url())
    check_serving(study.manifest.access, host=host, public_url=args.public_url)
    if study.manifest.access in (Access.TOKEN, Access.CROWD):
        known = study.store.plan(name) is not None
        if known and not args.rotate:
            raise InputError("NAME", None, f"a rater not registered yet, or --rotate to give {name} "
                             "a new link (the old one then stops working)",
                             f"{name} (registered already)")
        token = secrets.token_urlsafe(18)
        study.store.add_rater(name, plan=study.new_plan(name), token=token)
        print(f"{base}?token={token}")
        if known:
            print(f"note: {name}'s previous link stops working now (--rotate)", file=sys.stderr)
    else:
        study.plan_for(name)
        print(f"{base}?rater={name}")
    return 0
