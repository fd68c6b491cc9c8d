"""``nvrq render-plan SCENE [--offsets ...] [--cameras ...] --out PLAN.{csv,json}``."""

from __future__ import annotations

from data_schema.errors import InputError
from data_schema.scene import load_scene
from data_schema.text import comma_list
from nvrq.commands.args import add_link_option
from nvrq.commands.synth import add_view_options, parse_offsets, perturb_grid
from nvrq.render_plan import render_plan, write_render_plan

__all__ = ["register", "run"]


def register(sub) -> None:
    p = sub.add_parser(
        "render-plan",
        help="virtual camera poses a renderer must draw (paper Eq. 1-2)",
        description="For every camera, frame and offset: T_sensor'_rig, T_sensor_world, "
        "its inverse, the timestamp and the path images.csv expects.",
    )
    p.add_argument("scene", help="scene folder (scene.json + images.csv; images need not exist)")
    add_view_options(
        p, offsets_default=None, offsets_help="offsets in metres (default: those in images.csv)"
    )
    p.add_argument("--cameras", default=None, help="comma list of camera names (default: all)")
    p.add_argument("--out", required=True, help="output plan (.csv or .json)")
    add_link_option(p)
    p.set_defaults(func=run)


def run(args) -> int:
    if not str(args.out).lower().endswith((".csv", ".json")):
        raise InputError(param="--out", expected="a plan file ending in .csv or .json", got=args.out)
    offsets = None if args.offsets is None else parse_offsets(args.offsets, field="--offsets")
    views = perturb_grid(args)  # the arguments before the scene is read
    cameras = None if args.cameras is None else comma_list(args.cameras)
    scene = load_scene(args.scene, check_images=False)
    plan = render_plan(scene, offsets=offsets, perturbations=views, cameras=cameras)
    write_render_plan(plan, args.out, clip_id=scene.clip_id)
    print(f"{len(plan)} renders -> {args.out}")
    return 0
