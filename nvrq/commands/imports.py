"""``nvrq import {nurec,kitti,drivestudio,renders} ...``: turn external data into a scene folder
(docs/FORMATS.md §2, §13).

Each scene importer is one module (an object following :class:`nvrq.sources.base.Importer`,
named ``IMPORTER`` there) and one :class:`ImporterCommand` in :data:`IMPORTERS`: its name, the
module, the arguments that name its inputs, a function adding its arguments and one turning
them into the importer's options. The command reads the source with the importer
(``IMPORTER.read(path, **options)``, ``path`` the first input), writes it through the one writer
(:func:`nvrq.sources.base.write_imported`) and prints ``wrote OUT (...)``; ``nvrq`` learns the
inputs from the registration (``input_args``) and refuses an ``OUT`` over one of them before any
work. The module is imported only when the command runs: ``nvrq import --help`` stays light.
"""

from __future__ import annotations

import importlib
import re
import sys
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial

from nvrq.cli_types import number_arg
from nvrq.commands.import_renders import register_renders
from nvrq.commands.synth import add_view_options
from nvrq.sources.drivestudio_meta import DATASETS

__all__ = ["register", "ImporterCommand", "IMPORTERS", "register_importer"]


@dataclass(frozen=True)
class ImporterCommand:
    """One ``nvrq import NAME`` subcommand: ``module`` holds ``IMPORTER`` (an
    :class:`nvrq.sources.base.Importer`), ``inputs`` the argument names (dests) that are input
    files or folders, ``arguments(parser)`` adds the arguments before ``OUT``.

    Attributes
    ----------
    name : str
        Subcommand name (``nvrq import NAME``).
    module : str
        Dotted name of the module that holds ``IMPORTER``.
    inputs : tuple of str
        Argument names (dests) that are input files or folders.
    arguments : callable
        ``arguments(parser)`` adds the positional arguments before ``OUT``.
    help : str
        One-line help shown in ``nvrq import --help``.
    description : str
        The subcommand's description.
    options : callable or None
        ``options(parser)`` adds the importer's options; None for none.
    read_options : callable or None
        ``read_options(args)``: the keywords of ``IMPORTER.read`` besides the source (the first
        of ``inputs``), parsed from the arguments; None for none.
    """

    name: str
    module: str
    inputs: tuple[str, ...]
    arguments: Callable
    help: str
    description: str
    options: Callable | None = None
    read_options: Callable | None = None


def _nurec_inputs(p) -> None:
    p.add_argument("archive", help="NuRec scene archive (.usdz, a zip)")


def _nurec_options(p) -> None:
    add_view_options(p)
    p.add_argument("--sequence", default=None, help="rig trajectory sequence_id (default: the first)")
    p.add_argument("--clip-attributes", default=None, metavar="FILE",
                   help="table of clip_id + attribute columns (lighting, road_type, ...) for scene.json")


def _views(args) -> dict:
    """``offsets`` and ``perturbations`` of ``--offsets``/``--perturb`` (the options are read
    before any file)."""
    from data_schema.perturbation import perturb_option
    from data_schema.tables import parse_offsets

    perturbations = perturb_option(args.perturb, offsets=args.offsets,
                                   offsets_given=getattr(args, "offsets_given", False))
    return {"offsets": parse_offsets(args.offsets), "perturbations": perturbations}


def _nurec_read_options(args) -> dict:
    from nvrq.clip_attributes import read_clip_attributes

    views = _views(args)
    attributes = read_clip_attributes(args.clip_attributes) if args.clip_attributes else None
    return {**views, "sequence": args.sequence, "clip_attributes": attributes}


def _kitti_inputs(p) -> None:
    p.add_argument("kitti_root", help="KITTI object folder (with image_2/, label_2/, calib/)")
    p.add_argument("frame", help="frame id, e.g. 000123")


def _drivestudio_inputs(p) -> None:
    p.add_argument("scene_dir", help="processed scene folder, e.g. data/waymo/processed/training/023")


def _drivestudio_options(d) -> None:
    add_view_options(d)
    d.add_argument("--fps", type=number_arg(low=0, high=1000, low_open=True), default=None,
                   help="frame rate in Hz (default: the dataset's, 10; nuScenes 2 or its _NHz folder suffix)")
    d.add_argument("--cameras", default=None,
                   help="comma list of camera indices or names to import (default: all)")
    d.add_argument("--dataset", default=None, choices=DATASETS,
                   help="the source dataset, drivestudio's folder name (default: inferred from the files)")
    d.add_argument("--copy", action="store_true", help="copy the GT images (default: symbolic links)")


def _drivestudio_read_options(args) -> dict:
    from data_schema.text import comma_list

    views = _views(args)
    cameras = None if args.cameras is None else comma_list(args.cameras)
    return {**views, "dataset": args.dataset, "fps": args.fps, "cameras": cameras, "copy": args.copy}


def _stereo_inputs(p) -> None:
    p.add_argument("left", help="rectified left image (the GT image)")
    p.add_argument("right", help="rectified right image (the render, method real)")


def _stereo_options(p) -> None:
    from nvrq.sources.stereo_meta import MARGIN_PX, ROW_TOLERANCE_PX, UNKNOWN_CLASS

    p.add_argument("--calibration", required=True, metavar="FILE",
                   help="intrinsics: JSON {focal_length, principal_point}, Argoverse's "
                   "vehicle_calibration_stereo_info.json or a KITTI calib .txt (P2)")
    p.add_argument("--baseline", required=True, type=number_arg(low=0, low_open=True), metavar="B",
                   help="metres from the left to the right camera (> 0); the render is at y_offset_m = -B")
    p.add_argument("--disparity", default=None, metavar="PNG",
                   help="objects-only disparity of the left image (uint16 PNG, value/256 px, 0 = none): "
                   "objects are its clusters")
    p.add_argument("--labels", default=None, metavar="FILE",
                   help="instead of --disparity: KITTI label_2 boxes (--calibration then is the KITTI calib)")
    p.add_argument("--label-class", default=UNKNOWN_CLASS, metavar="NAME",
                   help=f"class of the objects found in the disparity (default {UNKNOWN_CLASS})")
    p.add_argument("--margin", type=number_arg(low=0), default=MARGIN_PX, metavar="PX",
                   help=f"pixels added around each cluster's points (default {MARGIN_PX})")
    p.add_argument("--row-tolerance", type=number_arg(low=0), default=ROW_TOLERANCE_PX, metavar="PX",
                   help="largest median row difference of matching points of a rectified pair "
                   f"(default {ROW_TOLERANCE_PX:g})")


def _stereo_read_options(args) -> dict:
    from pathlib import Path

    return {"right": args.right, "calibration": args.calibration, "baseline": args.baseline,
            "disparity": args.disparity, "labels": args.labels, "label_class": args.label_class,
            "margin": args.margin, "row_tolerance": args.row_tolerance,
            "clip_id": Path(args.out).resolve().name.replace(":", "-") or "stereo"}


#: The scene importers, in the order ``nvrq import --help`` lists them.
IMPORTERS: list[ImporterCommand] = [
    ImporterCommand("nurec", "nvrq.sources.nurec", ("archive", "clip_attributes"), _nurec_inputs,
                    "a NVIDIA NuRec scene archive (.usdz)",
                    "Read rig_trajectories.json and sequence_tracks.json from a NuRec archive; images.csv "
                    "lists the GT and render files to produce.", _nurec_options, _nurec_read_options),
    ImporterCommand("kitti", "nvrq.sources.kitti", ("kitti_root",), _kitti_inputs,
                    "one KITTI object-detection frame (real-data check)",
                    "Import a KITTI frame: image_2, label_2 and calib of FRAME.", None,
                    lambda args: {"frame": args.frame}),
    ImporterCommand("drivestudio", "nvrq.sources.drivestudio", ("scene_dir",), _drivestudio_inputs,
                    "a drivestudio / OmniRe / EmerNeRF processed scene folder (Waymo, nuScenes, PandaSet, ...)",
                    "Import a drivestudio processed scene (images/, intrinsics/, extrinsics/, ego_pose/, "
                    "instances/; docs/FORMATS.md section 13): the GT images are linked (--copy copies them), "
                    "images.csv lists the renders to produce.", _drivestudio_options,
                    _drivestudio_read_options),
    ImporterCommand("stereo", "nvrq.sources.stereo", ("left", "right", "calibration", "disparity", "labels"),
                    _stereo_inputs, "a rectified stereo pair: the right image as a real render (method real)",
                    "Import a rectified stereo pair: the left image is the GT, the right one the render at "
                    "y_offset_m = -B with method real; objects from the objects-only disparity (--disparity) "
                    "or KITTI labels (docs/FORMATS.md section 16).", _stereo_options,
                    _stereo_read_options),
]


def register_importer(kinds, command: ImporterCommand) -> None:
    """Add ``command`` to the ``nvrq import`` subparsers ``kinds``.

    Parameters
    ----------
    kinds : argparse._SubParsersAction
        The subparsers of ``nvrq import``.
    command : ImporterCommand
        The registration.

    Returns
    -------
    None
        The parser runs :func:`run_importer` and carries ``input_args = command.inputs``.
    """
    p = kinds.add_parser(command.name, help=command.help, description=command.description)
    command.arguments(p)
    p.add_argument("out", help="output scene folder")
    if command.options is not None:
        command.options(p)
    p.set_defaults(func=partial(run_importer, command), input_args=command.inputs)


def register(sub) -> None:
    """Add ``nvrq import`` (every :data:`IMPORTERS` entry, then ``renders``) to ``sub``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The subparsers of ``nvrq``.

    Returns
    -------
    None
    """
    p = sub.add_parser(
        "import",
        help="import a NuRec archive, a drivestudio scene or a KITTI frame as a scene folder",
        description="Convert external data into a scene folder (scene.json + images.csv).",
    )
    kinds = p.add_subparsers(dest="source", metavar="SOURCE", required=True)
    for command in IMPORTERS:
        register_importer(kinds, command)
    register_renders(kinds)


def run_importer(command: ImporterCommand, args) -> int:
    """Run ``nvrq import NAME``: read with the importer, write through the one writer.

    Parameters
    ----------
    command : ImporterCommand
        The registration.
    args : argparse.Namespace
        The parsed arguments (``out`` among them).

    Returns
    -------
    int
        0 (errors are :class:`~data_schema.errors.InputError`).
    """
    from nvrq.sources.base import describe, write_imported

    importer = importlib.import_module(command.module).IMPORTER
    options = command.read_options(args) if command.read_options is not None else {}
    imported = importer.read(getattr(args, command.inputs[0]), **options)
    for note in imported.notes:  # the library names its parameters (`dataset`); the user typed flags
        print(re.sub(r"`([a-z][a-z_]*)`", lambda m: "--" + m.group(1).replace("_", "-"), note), file=sys.stderr)
    out = write_imported(imported, args.out)
    print(f"wrote {out} ({describe(imported)})")
    return 0
