"""The ``nvrq`` command: a thin shell over the library.

Each subcommand lives in ``nvrq/commands/<name>.py`` and exposes
``register(subparsers)``, which adds its parser and sets ``func`` (called with the
parsed ``argparse.Namespace``; returns an exit status). Imports sit at module top except
those of heavy optional packages (torch, transformers, ray, openvino, onnxruntime, ...),
which stay inside the functions that need them, so ``nvrq --help`` loads numpy, pandas and
OpenCV but never a deep-learning runtime.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from data_schema.errors import run_subcommand

__all__ = ["main", "build_parser"]

#: Subcommand modules, in the order ``nvrq --help`` lists them.
COMMAND_MODULES = [
    "nvrq.commands.synth",
    "nvrq.commands.imports",
    "nvrq.commands.render_plan",
    "nvrq.commands.pairs",
    "nvrq.commands.score",
    "nvrq.commands.calibrate_tau",
    "nvrq.commands.proxy",
    "nvrq.commands.stability",
    "nvrq.commands.demo",
]


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="nvrq",
        description="Object-level quality of novel-view synthesis in driving scenes (NVRQ).",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name in COMMAND_MODULES:
        importlib.import_module(name).register(sub)  # a missing module is an install error
    return parser


def main(argv=None) -> int:
    """Entry point of the ``nvrq`` console script."""
    return run_subcommand(build_parser, argv)


if __name__ == "__main__":
    sys.exit(main())
