"""``annotate simulate STUDY [--raters N] [--seed S]``: add simulated raters (ids ``sim-*``,
new ones when the study was simulated before; refused when its test items need fewer votes
than N: :func:`annotate.simulate.simulate`).

Layer: commands (CLI shell) of ``annotate``.
"""

from __future__ import annotations

from annotate.commands import add_study_argument
from nvrq.cli_options import add_seed_option
from nvrq.cli_types import add_quiet_option, int_arg, show_progress

__all__ = ["register", "run"]


def register(sub) -> None:
    """Add ``simulate``: how many raters to simulate (the last one careless) and the seed
    of their parameters and votes.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The subcommands of ``annotate``, given ``simulate``.
    """
    m = sub.add_parser("simulate", help="add simulated raters (ids sim-*)")
    add_study_argument(m)
    m.add_argument("--raters", type=int_arg(), default=5,
                   help="simulated raters, the last one careless (default 5)")
    add_seed_option(m, "seed of the simulated votes")
    add_quiet_option(m)
    m.set_defaults(func=run)


def run(args) -> int:
    """Let ``args.raters`` new simulated raters vote in the study
    (:func:`annotate.simulate.simulate`); print their parameters and test votes.

    Parameters
    ----------
    args : argparse.Namespace
        ``study``, ``raters`` (how many) and ``seed``; ``quiet`` hides the progress bar.

    Returns
    -------
    int
        0 once the simulated votes are stored in the study.
    """
    from annotate.simulate import simulate
    from annotate.study import load_study

    params = simulate(load_study(args.study), raters=args.raters, seed=args.seed,
                      progress=show_progress(args))
    print(params.to_string(index=False))
    return 0
