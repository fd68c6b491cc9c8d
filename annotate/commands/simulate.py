"""``annotate simulate STUDY [--raters N] [--seed S]``: add simulated raters (ids ``sim-*``,
new ones when the study was simulated before; refused when its test items need fewer votes
than N: :func:`annotate.simulate.simulate`)."""

from __future__ import annotations

from annotate.simulate import simulate
from annotate.study import load_study
from nvrq.commands.args import int_arg

__all__ = ["register", "run"]


def register(sub) -> None:
    """Add ``simulate`` to the ``annotate`` subcommands ``sub``."""
    m = sub.add_parser("simulate", help="add simulated raters (ids sim-*)")
    m.add_argument("study")
    m.add_argument("--raters", type=int_arg(), default=5)
    m.add_argument("--seed", type=int_arg(low=0), default=0)
    m.set_defaults(func=run)


def run(args) -> int:
    """Simulate the raters' votes and print their parameters and test votes."""
    params = simulate(load_study(args.study), raters=args.raters, seed=args.seed)
    print(params.to_string(index=False))
    return 0
