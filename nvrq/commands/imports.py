"""``nvrq import {nurec,kitti,drivestudio} ...``: turn external data into a scene folder
(docs/FORMATS.md §2, §13).

Layer: commands (CLI shell).
"""

from __future__ import annotations

import sys
from pathlib import Path

from data_schema.text import comma_list
from nvrq.commands.args import number_arg
from nvrq.commands.import_renders import register_renders
from nvrq.commands.synth import add_view_options, perturb_grid
from nvrq.sources.drivestudio_meta import DATASETS

__all__ = ["register"]


def register(sub) -> None:
    """Add ``import`` to the ``nvrq`` subcommands ``sub``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The ``nvrq`` subcommand parsers.
    """
    p = sub.add_parser(
        "import",
        help="import a NuRec archive, a drivestudio scene or a KITTI frame as a scene folder",
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
    d = kinds.add_parser(
        "drivestudio",
        help="a drivestudio / OmniRe / EmerNeRF processed scene folder (Waymo, nuScenes, PandaSet, ...)",
        description="Import a drivestudio processed scene (images/, intrinsics/, extrinsics/, ego_pose/, "
        "instances/; docs/FORMATS.md section 13): the GT images are linked (--copy copies them), "
        "images.csv lists the renders to produce.",
    )
    d.add_argument("scene_dir", help="processed scene folder, e.g. data/waymo/processed/training/023")
    d.add_argument("out", help="output scene folder")
    add_view_options(d)
    d.add_argument("--fps", type=number_arg(low=0, high=1000, low_open=True), default=None,
                   help="frame rate in Hz (default: the dataset's, 10; nuScenes 2 or its _NHz folder suffix)")
    d.add_argument("--cameras", default=None,
                   help="comma list of camera indices or names to import (default: all)")
    d.add_argument("--dataset", default=None, choices=DATASETS,
                   help="the source dataset, drivestudio's folder name (default: inferred from the files)")
    d.add_argument("--copy", action="store_true", help="copy the GT images (default: symbolic links)")
    d.set_defaults(func=_run_drivestudio)
    register_renders(kinds)


def _run_nurec(args) -> int:
    from nvrq.clip_attributes import read_clip_attributes
    from nvrq.sources.nurec import import_nurec

    attributes = read_clip_attributes(args.clip_attributes) if args.clip_attributes else None
    out = import_nurec(
        args.archive, args.out, offsets=_parse_offsets(args.offsets), sequence=args.sequence,
        perturbations=perturb_grid(args), clip_attributes=attributes,
    )
    print(f"wrote {out}")
    return 0


def _run_kitti(args) -> int:
    from nvrq.sources.kitti import import_kitti

    out = import_kitti(Path(args.kitti_root), args.frame, Path(args.out))
    print(f"wrote {out}")
    return 0


def _run_drivestudio(args) -> int:
    from nvrq.sources.drivestudio import read_drivestudio, write_drivestudio

    offsets, perturbations = _parse_offsets(args.offsets), perturb_grid(args)
    cameras = None if args.cameras is None else comma_list(args.cameras)
    ds = read_drivestudio(args.scene_dir, dataset=args.dataset, fps=args.fps, cameras=cameras)
    for note in ds.notes:
        print(note.replace("`dataset`", "--dataset"), file=sys.stderr)  # the library names its parameter
    out = write_drivestudio(ds, args.out, offsets=offsets, perturbations=perturbations, copy=args.copy)
    n_frames = ds.image_paths.shape[1]
    print(f"wrote {out} ({ds.dataset}: {n_frames} frames at {ds.fps:g} Hz x {len(ds.cameras)} cameras, "
          f"{len(ds.doc['tracks'])} tracks)")
    return 0


def _parse_offsets(text, **kw):
    """:func:`data_schema.tables.parse_offsets` (imported here: pandas is not needed for ``--help``)."""
    from data_schema.tables import parse_offsets

    return parse_offsets(text, **kw)
