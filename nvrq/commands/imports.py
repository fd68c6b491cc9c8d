"""``nvrq import {nurec,kitti} ...``: turn external data into a scene folder (docs/FORMATS.md §2)."""

from __future__ import annotations

from pathlib import Path

from nvrq.clip_attributes import read_clip_attributes
from nvrq.commands.import_renders import register_renders
from nvrq.commands.synth import add_view_options, parse_offsets, perturb_grid
from nvrq.sources.kitti import import_kitti
from nvrq.sources.nurec import import_nurec

__all__ = ["register"]


def register(sub) -> None:
    p = sub.add_parser(
        "import",
        help="import a NuRec archive or a KITTI frame as a scene folder",
        description="Convert external data into a scene folder (scene.json + images.csv).",
    )
    kinds = p.add_subparsers(dest="source", metavar="SOURCE", required=True)
    n = kinds.add_parser(
        "nurec",
        help="a NVIDIA NuRec scene archive (.usdz)",
        description="Read rig_trajectories.json and sequence_tracks.json from a NuRec "
        "archive; images.csv lists the GT and render files to produce.",
    )
    n.add_argument("archive", help="NuRec scene archive (.usdz, a zip)")
    n.add_argument("out", help="output scene folder")
    add_view_options(n)
    n.add_argument(
        "--sequence", default=None, help="rig trajectory sequence_id (default: the first)"
    )
    n.add_argument(
        "--clip-attributes",
        default=None,
        metavar="FILE",
        help="table of clip_id + attribute columns (lighting, road_type, ...) for scene.json",
    )
    n.set_defaults(func=_run_nurec)
    k = kinds.add_parser(
        "kitti",
        help="one KITTI object-detection frame (real-data check)",
        description="Import a KITTI frame: image_2, label_2 and calib of FRAME.",
    )
    k.add_argument("kitti_root", help="KITTI object folder (with image_2/, label_2/, calib/)")
    k.add_argument("frame", help="frame id, e.g. 000123")
    k.add_argument("out", help="output scene folder")
    k.set_defaults(func=_run_kitti)
    register_renders(kinds)


def _run_nurec(args) -> int:
    attributes = read_clip_attributes(args.clip_attributes) if args.clip_attributes else None
    out = import_nurec(
        args.archive, args.out, offsets=parse_offsets(args.offsets), sequence=args.sequence,
        perturbations=perturb_grid(args), clip_attributes=attributes,
    )
    print(f"wrote {out}")
    return 0


def _run_kitti(args) -> int:
    out = import_kitti(Path(args.kitti_root), args.frame, Path(args.out))
    print(f"wrote {out}")
    return 0
