"""``nvrq import renders SCENE DIR [--method NAME] [--layout plan|order] [--allow-missing] [--link]
[--existing-method NAME] [--replace]``: register a renderer's output (:mod:`nvrq.sources.renders`)."""

from __future__ import annotations

from nvrq.choices import LAYOUTS
from nvrq.cli_options import add_method_option

__all__ = ["register_renders"]


def register_renders(kinds) -> None:
    """Add the ``renders`` kind to the ``nvrq import`` subparsers ``kinds``.

    Parameters
    ----------
    kinds : argparse._SubParsersAction
        The ``nvrq import`` kind parsers.
    """
    r = kinds.add_parser(
        "renders",
        help="register a renderer's output in a scene (the render rows of images.csv)",
        description="Copy (or link) the renders of the scene's render plan from DIR into the scene "
        "and point images.csv at them (docs/FORMATS.md §14). DIR holds each render at its plan "
        "path (--layout plan) or as 00000.png, 00001.png, ... in plan order (--layout order).",
    )
    r.add_argument("scene", help="scene folder whose images.csv lists the render rows")
    r.add_argument("render_dir", metavar="DIR", help="folder of renders (not the scene folder)")
    add_method_option(r, "reconstruction method of these renders (the images.csv method column)")
    r.add_argument("--existing-method", default=None, metavar="NAME",
                   help="first name the scene's unnamed renders NAME (paths unchanged), so that "
                        "--method adds a second method")
    r.add_argument("--layout", choices=LAYOUTS, default="plan",
                   help="plan: DIR/<plan path>; order: DIR/00000.png (or .jpg, .jpeg), ... in plan "
                        "row order (default plan)")
    r.add_argument("--allow-missing", action="store_true",
                   help="leave views without a render out (their render rows are removed) "
                        "instead of failing")
    r.add_argument("--link", action="store_true",
                   help="symbolic links to the files in DIR instead of copies")
    r.add_argument("--replace", action="store_true",
                   help="allow changing renders of this method already in the scene (the pairs and "
                        "metrics made from them go stale); prints how many files changed")
    r.set_defaults(func=_run, input_args=("scene", "render_dir"))


def _run(args) -> int:
    from nvrq.sources.renders import import_renders

    result = import_renders(args.scene, args.render_dir, method=args.method, layout=args.layout,
                            allow_missing=args.allow_missing, link=args.link,
                            existing_method=args.existing_method, replace=args.replace)
    print(result.summary())
    return 0
