"""``nvrq pairs SCENE --out PAIRS.{csv,parquet}`` (docs/FORMATS.md §3); several scenes, or a folder of
scene folders, ``--out DATASET/`` (a Parquet dataset partitioned by clip_id, :mod:`nvrq.fleet`).

Layer: commands (CLI shell).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

from data_schema.defaults import MIN_SIDE_PX, MIN_VISIBLE
from data_schema.errors import InputError
from nvrq.cli_types import add_link_option, add_quiet_option, number_arg, show_progress

__all__ = ["register", "run"]


def register(sub) -> None:
    """Add ``pairs``: one scene or many, the output table or dataset, the clip attributes and
    the box size filters.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        Where ``nvrq`` collects its subcommands.
    """
    p = sub.add_parser("pairs", help="GT/novel-view box pairs of a scene (docs/FORMATS.md §3)",
                       description="Project every 3D box into the GT view and every novel view; "
                                   "keep the boxes valid in both.")
    p.add_argument("scene", nargs="+", help="scene folder (scene.json + images.csv); several, or a "
                   "folder of scene folders, write a dataset")
    p.add_argument("--out", required=True, help="output pairs table (.csv or .parquet), or a folder: "
                   "one Parquet dataset partitioned by clip_id")
    p.add_argument("--clip-attributes", default=None, metavar="FILE",
                   help="table of clip_id + attribute columns (e.g. lighting, road_type) to apply")
    p.add_argument("--keep-going", action="store_true",
                   help="several clips: write the good ones and failed.csv, exit 1 if any failed")
    p.add_argument("--min-side", type=number_arg(low=0), default=MIN_SIDE_PX,
                   help=f"shorter side of the box in pixels (default {MIN_SIDE_PX})")
    p.add_argument("--min-area", type=number_arg(low=0), default=0, help="box area in square pixels (default 0)")
    p.add_argument("--min-visible", type=number_arg(low=0, high=1), default=MIN_VISIBLE, metavar="F",
                   help="smallest visible fraction of the object (not covered by nearer boxes) in the GT view "
                        f"and in the novel view (default {MIN_VISIBLE}); 0 keeps every pair, the paper's protocol")
    p.add_argument("--floor", action="store_true",
                   help="add the viewpoint floor: for each novel view, a pair of two GT views of the object "
                        "whose change of viewpoint matches it (method floor, docs/FORMATS.md §3)")
    add_quiet_option(p)
    add_link_option(p)
    p.set_defaults(func=run)


def run(args) -> int:
    """Project the boxes of one scene into a pairs table, or of several into a dataset
    (:mod:`nvrq.fleet`; ``--out`` without a suffix writes a dataset of one scene too).

    Parameters
    ----------
    args : argparse.Namespace
        ``scene`` (a list), ``out``, ``clip_attributes``, ``keep_going``, ``min_side``,
        ``min_area`` and ``floor`` (one scene only).

    Returns
    -------
    int
        0; 1 when ``--keep-going`` wrote a dataset in which some clips failed (failed.csv).
    """
    from data_schema.tables import write_table
    from nvrq.clip_attributes import read_clip_attributes
    from nvrq.fleet import clip_pairs

    t0 = time.perf_counter()
    attributes = read_clip_attributes(args.clip_attributes) if args.clip_attributes else None
    if _is_fleet(args):
        if args.floor:
            raise InputError(param="--floor", expected="one scene folder and a table --out (.csv or .parquet)",
                             got="a dataset of several clips" if len(args.scene) > 1 else f"--out {args.out}")
        return _run_fleet(args, attributes, t0)
    if args.floor:
        pairs, line = _floor_pairs(args, attributes)
    else:
        _, pairs, stats = clip_pairs(args.scene[0], attributes=attributes, min_side=args.min_side,
                                     min_area=args.min_area, min_visible=args.min_visible,
                                     progress=show_progress(args))
        line = stats.summary()
    write_table(pairs, args.out)
    print(f"{line} -> {args.out} ({time.perf_counter() - t0:.1f} s)")
    return 0


def _floor_pairs(args, attributes):
    """The pairs of one scene with its floor rows (:mod:`nvrq.floor`), and the printed counts."""
    import dataclasses

    from data_schema.scene import load_scene
    from nvrq.floor import add_floor, check_floor_scene
    from nvrq.pairs import make_pairs

    scene = load_scene(args.scene[0])
    if attributes is not None:
        scene = dataclasses.replace(scene, attributes=attributes.for_clip(scene.clip_id, scene.attributes))
    check_floor_scene(scene)
    pairs, stats = make_pairs(scene, min_side=args.min_side, min_area=args.min_area, min_visible=args.min_visible,
                              progress=show_progress(args))
    pairs, fstats = add_floor(scene, pairs, min_side=args.min_side, min_area=args.min_area)
    return pairs, f"{stats.summary()}; {fstats.summary()}"


def _is_fleet(args) -> bool:
    """A dataset is written for several scenes, a folder of scene folders, or a suffix-less --out."""

    first = Path(args.scene[0])
    many = len(args.scene) > 1 or (first.is_dir() and not (first / "scene.json").is_file()
                                   and any(first.glob("*/scene.json")))
    to_file = Path(args.out).suffix != ""  # a dataset folder has no suffix
    if many and to_file:
        raise InputError(param="--out", expected="a folder for several clips (a Parquet dataset partitioned by "
                         "clip_id)", got=args.out)
    return many or not to_file


def _run_fleet(args, attributes, t0) -> int:
    from nvrq.fleet import find_scenes, fleet_pairs

    res = fleet_pairs(find_scenes(args.scene), args.out, min_side=args.min_side, min_area=args.min_area,
                      min_visible=args.min_visible, attributes=attributes, keep_going=args.keep_going, progress=show_progress(args))
    for clip, reason in res.failed:
        print(f"failed: {clip}: {reason}", file=sys.stderr)
    print(f"{res.summary()} -> {args.out} ({time.perf_counter() - t0:.1f} s)")
    return 1 if res.failed else 0
