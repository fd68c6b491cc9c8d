"""``nvrq synth OUT [--seed N] [--seconds S] [--fps F] [--offsets ...] [--cameras ...] [--size WxH]
[--methods NAME:SCALE,...]``.

Layer: commands (CLI shell).
"""

from __future__ import annotations

import argparse

from data_schema.text import comma_list
from nvrq.cli_options import add_seed_option
from nvrq.cli_types import (
    add_quiet_option,
    allow_negative_lists,
    number_arg,
    parse_wxh,
    show_progress,
)

__all__ = ["register", "run", "parse_size", "add_perturb_option", "add_view_options",
           "perturb_grid"]


def add_perturb_option(parser) -> None:
    """``--perturb AXIS=START:STOP:STEP,...`` (6-DoF grid; replaces ``--offsets`` when given).

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The command's parser.
    """
    parser.add_argument(
        "--perturb", default=None, metavar="GRID",
        help="6-DoF views as a comma list of AXIS=START:STOP:STEP (or AXIS=VALUE), AXIS in "
        "{x,y,z,roll,pitch,yaw}, metres/degrees in the rig frame, e.g. y=-3:3:1,z=0:2:0.5,yaw=-10:10:5; "
        "replaces --offsets",
    )


def add_view_options(
    parser,
    *,
    offsets_default: str | None = "-3,-2,-1,0,1,2,3",
    offsets_help: str = "render offsets in metres (left > 0)",
) -> None:
    """The views to render: ``--offsets`` (lateral, metres) and ``--perturb`` (6-DoF grid).

    Also lets the parser take negative comma lists such as ``-3,-2,-1`` as values.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The command's parser.
    offsets_default : str or None, optional
        Default of ``--offsets`` (a comma list of metres).
    offsets_help : str, optional
        The help of ``--offsets``.
    """
    parser.add_argument("--offsets", default=offsets_default, help=offsets_help + "; not with --perturb",
                        action=_GivenOffsets)
    add_perturb_option(parser)
    allow_negative_lists(parser)


class _GivenOffsets(argparse.Action):
    """Stores ``--offsets`` and notes that it was given (``--perturb`` refuses it then)."""

    def __call__(self, parser, namespace, values, option_string=None):
        setattr(namespace, self.dest, values)
        namespace.offsets_given = True


def perturb_grid(args):
    """The ``(K, 6)`` views of ``--perturb``, or None when it was not given.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options (``perturb``).

    Returns
    -------
    (K, 6) float64 or None
        ``(dx, dy, dz, roll, pitch, yaw)``: metres, degrees, rig frame.
    """
    from data_schema.perturbation import perturb_option

    return perturb_option(args.perturb, offsets=args.offsets, offsets_given=getattr(args, "offsets_given", False))


def parse_size(text: str) -> tuple[int, int]:
    """``"1280x720"`` -> ``(1280, 720)`` (the WxH rule of :func:`nvrq.cli_types.parse_wxh`).

    Parameters
    ----------
    text : str
        ``WxH``, pixels.

    Returns
    -------
    (int, int)
        ``(W, H)``.

    >>> parse_size("640x360")
    (640, 360)
    """
    return parse_wxh(text, option="--size")


def register(sub) -> None:
    """Add ``synth``: the clip's seed, length and frame rate, its views and cameras, the image
    size and the reconstruction methods rendered.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        ``nvrq``'s subparsers, to which ``synth`` is added.
    """
    p = sub.add_parser(
        "synth",
        help="write a synthetic driving clip with known degradation",
        description="Procedural driving clip (scene folder per docs/FORMATS.md §2) with GT "
        "images, renders at lateral offsets and degradation.csv.",
    )
    p.add_argument("out", help="output scene folder")
    add_seed_option(p, "random seed")
    p.add_argument("--seconds", type=number_arg(low=0, low_open=True), default=10.0, help="clip length (default 10)")
    p.add_argument("--fps", type=number_arg(low=0, high=1000, low_open=True), default=10.0, help="frame rate (default 10)")
    add_view_options(p)
    p.add_argument(
        "--cameras", default="pinhole", help="comma list from {pinhole, ftheta} (default pinhole)"
    )
    p.add_argument("--size", default="1280x720", help="image size WxH (default 1280x720)")
    p.add_argument("--methods", default=None, metavar="NAME:SCALE,...",
                   help="render the clip once per reconstruction method, its artefact severity times "
                        "SCALE (>= 0; smaller = better), e.g. 3dgs:0.5,nerf:1.5 (default: one unnamed method)")
    add_quiet_option(p)
    p.set_defaults(func=run)


def run(args) -> int:
    """Generate the synthetic scene folder ``args.out`` (:func:`nvrq.synth.generate_scene`)
    and print where it is.

    Parameters
    ----------
    args : argparse.Namespace
        ``out``, ``seed``, ``seconds``, ``fps``, the views (``offsets``, ``perturb``),
        ``cameras``, ``size`` and ``methods``.

    Returns
    -------
    int
        0 once the scene is written.
    """
    from data_schema.methods import parse_methods
    from data_schema.tables import parse_offsets
    from nvrq.synth import SynthOptions, generate_scene

    methods = None if args.methods is None else parse_methods(args.methods)
    cameras = tuple(comma_list(args.cameras))
    options = SynthOptions(seed=args.seed, seconds=args.seconds, fps=args.fps,
                           offsets=parse_offsets(args.offsets), perturbations=perturb_grid(args),
                           cameras=cameras, size=parse_size(args.size), methods=methods)
    out = generate_scene(args.out, options, progress=show_progress(args))
    print(f"wrote {out}")
    return 0
