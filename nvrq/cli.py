"""The ``nvrq`` command: a thin shell over the library.

Each subcommand lives in ``nvrq/commands/<name>.py`` and exposes
``register(subparsers)``, which adds its parser and sets ``func`` (called with the
parsed ``argparse.Namespace``; returns an exit status); the options several commands share
are modules of their own (:mod:`nvrq.cli_types`, the conventions of all three CLIs, below the
command layer; :mod:`nvrq.commands.engine_options`). Imports sit at module top except
the library a command runs, which its ``run`` imports: a command module imports at its top
only what its parser needs (the conventions, option defaults and choices), so ``nvrq --help``
and ``nvrq COMMAND --help`` load neither a deep-learning runtime nor SciPy, matplotlib, pandas
or OpenCV (tests/test_import_layers.py) and answer fast (benchmarks/bench_cli_help.py).
Choices and defaults the parsers need from heavy modules live in light ones
(:mod:`nvrq.choices`, :mod:`data_schema.defaults`).
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

from data_schema.outputs import check_output_file, check_output_folder
from nvrq.cli_types import ArgumentParser, command_parser, flags_in_errors, run_cli
from nvrq.commands.model_options import check_model_options

__all__ = ["main", "build_parser"]

#: Subcommand modules, in the order ``nvrq --help`` lists them.
COMMAND_MODULES = [
    "nvrq.commands.synth",
    "nvrq.commands.imports",
    "nvrq.commands.render_plan",
    "nvrq.commands.pairs",
    "nvrq.commands.score",
    "nvrq.commands.score_sets",
    "nvrq.commands.calibrate_tau",
    "nvrq.commands.calibrate_runtime",
    "nvrq.commands.proxy",
    "nvrq.commands.stability",
    "nvrq.commands.demo",
]


def build_parser() -> ArgumentParser:
    """The ``nvrq`` parser: every subcommand of :data:`COMMAND_MODULES`
    (:func:`nvrq.cli_types.command_parser`).

    Returns
    -------
    ArgumentParser
        The top-level parser with one subparser per command.
    """
    return command_parser("nvrq", "Object-level quality of novel-view synthesis in driving scenes (NVRQ).",
                          COMMAND_MODULES)


#: What each subcommand writes: the kind of its ``--out``/``OUT`` (see data_schema.outputs).
OUTPUT_KINDS = {"synth": "scene", "import": "scene", "render-plan": "file", "pairs": "file",
                "score": "file", "score-sets": "file", "proxy": "file", "stability": "report"}
#: Commands (or ``nvrq proxy`` kinds) that write ``OUT.timing.csv`` beside ``--out``.
WRITES_TIMING = ("score", "imagenet", "clip")
#: Parsed arguments that name a command's input files or folders. A subcommand may add its own
#: with ``set_defaults(input_args=(...))`` (every ``nvrq import`` importer does, from its
#: registration: :class:`nvrq.commands.imports.ImporterCommand`).
INPUT_ARGS = ("pairs", "scene", "detections", "class_map", "yolo", "weights", "config", "clip")


def check_outputs(args) -> None:
    """Refuse an output that is an input or lies in a scene/study folder (before any work)."""
    from data_schema.datasets import MANIFEST
    from data_schema.tables import timing_path

    kind = OUTPUT_KINDS.get(args.command)
    if kind is None or getattr(args, "out", None) is None:
        return
    names = (*INPUT_ARGS, *getattr(args, "input_args", ()))
    inputs = [getattr(args, a) for a in names if getattr(args, a, None) is not None]
    option = "OUT" if kind == "scene" else "--out"  # the scene writers take a positional OUT
    if kind == "file" and Path(args.out).suffix == "":
        # a Parquet dataset folder (several clips, --engine ray; data_schema.datasets): its
        # manifest path gets the file rule; the command checks what the folder already holds
        check_output_file(Path(args.out) / MANIFEST, inputs=inputs, option=option)
    elif kind == "file":
        check_output_file(args.out, inputs=inputs, option=option)
        if args.command in WRITES_TIMING or getattr(args, "proxy", None) in WRITES_TIMING:
            check_output_file(timing_path(args.out), inputs=inputs, option="--out (its .timing.csv)")
    else:
        command = args.command if kind == "report" else None  # a report replaces only its own command's
        check_output_folder(args.out, kind=kind, inputs=inputs, option=option, command=command)


def _main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)  # --help and --version end here
    from data_schema.tables import no_follow_links  # pandas: after --help has answered

    aliases = {"scene_root": "scene", "perturbations": "perturb", "weights": "yolo"}
    with flags_in_errors(parser, args, aliases), no_follow_links(getattr(args, "no_follow_links", False)):
        check_outputs(args)
        check_model_options(args)
        return args.func(args)


def main(argv=None) -> int:
    """Entry point of the ``nvrq`` console script. Sets the Hugging Face hub offline for the
    process (the library reads model folders with ``local_files_only`` and never downloads;
    this also keeps transformers from asking the hub about them).

    Parameters
    ----------
    argv : list of str, optional
        Command-line arguments (default: ``sys.argv[1:]``).

    Returns
    -------
    int
        The process exit status.
    """
    os.environ["HF_HUB_OFFLINE"] = "1"
    os.environ["TRANSFORMERS_OFFLINE"] = "1"
    return run_cli(_main, argv)


if __name__ == "__main__":
    sys.exit(main())
