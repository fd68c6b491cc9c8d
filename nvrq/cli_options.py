"""The options several commands of ``nvrq`` and ``annotate`` add alike, each written once
here: the pairs table ``PAIRS``, the ``--scene`` its image paths are relative to, a
``--seed`` and the ``--method`` of a renderer's output (``--quiet`` is :func:`nvrq.cli_types.add_quiet_option`, beside the
:func:`~nvrq.cli_types.show_progress` that reads it).

Layer: a leaf of ``nvrq`` below its command layer (beside :mod:`nvrq.cli_types`, whose
``int_arg`` it uses), shared with ``annotate``'s commands.

A command whose option means something of its own (``nvrq synth``'s positional ``OUT``, a
``--min-side`` with another default) keeps its own ``add_argument``; these are the spellings,
types and help texts that must read the same wherever they appear.
"""

from __future__ import annotations

from nvrq.cli_types import int_arg

__all__ = ["add_pairs_argument", "add_scene_root_option", "add_seed_option", "add_method_option"]


def add_pairs_argument(parser, *, datasets: bool = False) -> None:
    """Add the positional ``pairs``: the table ``nvrq pairs`` wrote (docs/FORMATS.md §3).

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The parser of a command that reads a pairs table.
    datasets : bool, optional
        Whether a pairs dataset folder (several clips, ``nvrq pairs SCENES --out DIR``) is taken
        too, as by ``nvrq score`` (default: a table only).
    """
    more = ", or a pairs dataset folder (several clips)" if datasets else ""
    parser.add_argument("pairs", help=f"pairs table from `nvrq pairs` (.csv or .parquet){more}")


def add_scene_root_option(parser) -> None:
    """Add ``--scene``: the folder a pairs table's image paths are relative to, overriding its
    ``scene_root`` column.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The parser of a command that reads the crops of a pairs table.
    """
    parser.add_argument("--scene", default=None, metavar="SCENE",
                        help="scene folder the image paths are relative to "
                             "(default: the pairs table's scene_root column)")


def add_seed_option(parser, what: str, *, default: int = 0) -> None:
    """Add ``--seed``: a non-negative integer that makes the command's random choices repeatable.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The command's parser.
    what : str
        What the seed drives, the start of the help, e.g. ``"sampling seed"``; the help ends
        with ``(default N)``.
    default : int, optional
        The seed when none is given (default 0).
    """
    parser.add_argument("--seed", type=int_arg(low=0), default=default, help=f"{what} (default {default})")


def add_method_option(parser, what: str) -> None:
    """Add ``--method NAME``: the reconstruction method whose renders ``nvrq render-plan`` plans
    and ``nvrq import renders`` registers. A method's renders have paths of their own
    (``render_<...>/<method>``, :func:`nvrq.render_plans.default_image_path`), so both
    commands must be given the same name; the help says so in both.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The parser of ``render-plan`` or of ``import renders``.
    what : str
        What the option means to this command, the start of its help.
    """
    parser.add_argument("--method", default=None, metavar="NAME",
                        help=f"{what}; give nvrq render-plan and nvrq import renders the same --method")
