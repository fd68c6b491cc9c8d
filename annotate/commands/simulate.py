"""``annotate simulate STUDY [--raters N] [--seed S]``: add simulated raters (ids ``sim-*``,
new ones when the study was simulated before; refused when its test items need fewer votes
than N: :func:`annotate.simulate.simulate`).

Layer: commands (CLI shell) of ``annotate``.
"""

from __future__ import annotations

from nvrq.commands.args import int_arg, show_progress

__all__ = ["register", "run"]


def register(sub) -> None:
    """Add ``simulate`` to the ``annotate`` subcommands ``sub``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The ``annotate`` subcommand parsers.
    """
    m = sub.add_parser("simulate", help="add simulated raters (ids sim-*)")
    m.add_argument("study", metavar="STUDY", help="study folder made by 'annotate build'")
    m.add_argument("--raters", type=int_arg(), default=5,
                   help="simulated raters, the last one careless (default 5)")
    m.add_argument("--seed", type=int_arg(low=0), default=0, help="seed of the simulated votes (default 0)")
    m.add_argument("--quiet", action="store_true", help="no progress bar (none is drawn off a terminal)")
    m.set_defaults(func=run)


def run(args) -> int:
    """Simulate the raters' votes and print their parameters and test votes.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options of ``annotate simulate``.

    Returns
    -------
    int
        The exit status, 0 on success (bad input raises
        :class:`~data_schema.errors.InputError`, status 2 through
        :func:`~nvrq.commands.args.run_cli`).
    """
    from annotate.simulate import simulate
    from annotate.study import load_study

    params = simulate(load_study(args.study), raters=args.raters, seed=args.seed,
                      progress=show_progress(args))
    print(params.to_string(index=False))
    return 0
