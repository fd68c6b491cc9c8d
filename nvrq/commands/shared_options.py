"""The options several commands add alike, importable from here as well: they live in
:mod:`nvrq.cli_options`, below the command layer, so ``annotate``'s commands share them."""

from nvrq.cli_options import (
    add_method_option,
    add_pairs_argument,
    add_scene_root_option,
    add_seed_option,
)

__all__ = ["add_pairs_argument", "add_scene_root_option", "add_seed_option", "add_method_option"]
