"""``nvrq render-plan SCENE [--offsets ...] [--cameras ...] [--method NAME] [--world scene|source]
--out PLAN.{csv,json,npz} [--format csv|json|npz]``.

Layer: commands (CLI shell).
"""

from __future__ import annotations

from data_schema.text import comma_list, plural
from nvrq.choices import PLAN_FORMATS, WORLDS
from nvrq.cli_options import add_method_option
from nvrq.cli_types import add_link_option
from nvrq.commands.synth import add_view_options, perturb_grid

__all__ = ["register", "run"]


def register(sub) -> None:
    """Add ``render-plan``: which views (offsets or a 6-DoF grid), cameras and method to plan,
    in which world, and the plan file.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        ``nvrq``'s subcommand parsers, one more of which is ``render-plan``.
    """
    p = sub.add_parser(
        "render-plan",
        help="virtual cameras a renderer must draw (paper Eq. 1-2), with their intrinsics",
        description="For every camera, frame and offset: T_sensor'_rig, T_sensor_world, "
        "its inverse (the view matrix), the camera's K, distortion and size, the timestamp and "
        "the path images.csv expects (docs/FORMATS.md §14).",
    )
    p.add_argument("scene", help="scene folder (scene.json + images.csv; images need not exist)")
    add_view_options(
        p, offsets_default=None, offsets_help="offsets in metres (default: those in images.csv)"
    )
    p.add_argument("--cameras", default=None, help="comma list of camera names (default: all)")
    add_method_option(p, "plan this method's renders only, at its paths (default: every method of "
                         "the scene, or none)")
    p.add_argument("--world", choices=WORLDS, default="scene",
                   help="world of the poses: the scene's (default), or the source dataset's own "
                        "(a scene imported from drivestudio: scene.json source_world)")
    p.add_argument("--out", required=True, help="output plan (.csv, .json or .npz)")
    p.add_argument("--format", choices=PLAN_FORMATS, default=None,
                   help="plan format (default: from the --out suffix, which it must match)")
    add_link_option(p)
    p.set_defaults(func=run)


def run(args) -> int:
    """Check the plan's options before the scene is read, plan every render of the scene
    (:func:`nvrq.render_plans.render_plan`) and write the plan file.

    Parameters
    ----------
    args : argparse.Namespace
        ``scene``, the views (``offsets``, ``perturb``), ``cameras``, ``method``, ``world``,
        ``out`` and ``format``.

    Returns
    -------
    int
        0 once the plan is written; the line printed counts its renders.
    """
    from data_schema.methods import check_method_name
    from data_schema.scene import load_scene
    from nvrq.render_plans import plan_format, render_plan, write_render_plan

    plan_format(args.out, args.format)  # the arguments before the scene is read
    offsets = None if args.offsets is None else _parse_offsets(args.offsets, field="--offsets")
    views = perturb_grid(args)
    if args.method is not None:
        check_method_name(args.method, where="method", field=None)
    cameras = None if args.cameras is None else comma_list(args.cameras)
    scene = load_scene(args.scene, check_images=False)
    plan = render_plan(scene, offsets=offsets, perturbations=views, cameras=cameras, method=args.method,
                       world=args.world)
    write_render_plan(plan, args.out, format=args.format)
    world = "" if args.world == "scene" else f" (poses in the {args.world} world)"
    print(f"{plural(len(plan), 'render')} -> {args.out}{world}")
    return 0


def _parse_offsets(text, **kw):
    """:func:`data_schema.tables.parse_offsets` (imported here: pandas is not needed for ``--help``)."""
    from data_schema.tables import parse_offsets

    return parse_offsets(text, **kw)
