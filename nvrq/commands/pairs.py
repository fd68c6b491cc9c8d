"""``nvrq pairs SCENE --out PAIRS.{csv,parquet}`` (SPEC section 3)."""

from __future__ import annotations

import time

from data_schema.scene import load_scene
from data_schema.tables import MIN_SIDE_PX, write_table
from nvrq.pairs import make_pairs

__all__ = ["register", "run"]


def register(sub) -> None:
    p = sub.add_parser("pairs", help="GT/novel-view box pairs of a scene (SPEC section 3)",
                       description="Project every 3D box into the GT view and every novel view; "
                                   "keep the boxes valid in both.")
    p.add_argument("scene", help="scene folder (scene.json + images.csv)")
    p.add_argument("--out", required=True, help="output pairs table (.csv or .parquet)")
    p.add_argument("--min-side", type=float, default=MIN_SIDE_PX,
                   help=f"shorter side of the box in pixels (default {MIN_SIDE_PX})")
    p.add_argument("--min-area", type=float, default=0, help="box area in square pixels (default 0)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def run(args) -> int:
    t0 = time.perf_counter()
    scene = load_scene(args.scene)
    pairs, stats = make_pairs(scene, min_side=args.min_side, min_area=args.min_area, progress=not args.quiet)
    write_table(pairs, args.out)
    print(f"{stats.summary()} -> {args.out} ({time.perf_counter() - t0:.1f} s)")
    return 0
