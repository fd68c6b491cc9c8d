"""The argument conventions of the three CLIs, importable from here as well: they live in
:mod:`nvrq.cli_types`, below the command layer, so ``annotate`` and ``analyze`` share them."""

from nvrq.cli_types import (
    NEGATIVE_LIST,
    ArgumentParser,
    CommaList,
    DeprecatedFileOption,
    DeprecatedSize,
    LazyHelp,
    add_link_option,
    add_quiet_option,
    add_version,
    allow_negative_lists,
    checked_arg,
    command_parser,
    deprecated,
    flags_in_errors,
    int_arg,
    number_arg,
    option_for,
    parse_wxh,
    run_cli,
    show_progress,
)

__all__ = ["ArgumentParser", "command_parser", "run_cli", "add_version", "show_progress", "add_quiet_option",
           "parse_wxh", "CommaList", "DeprecatedFileOption", "DeprecatedSize", "deprecated",
           "allow_negative_lists", "NEGATIVE_LIST", "option_for", "flags_in_errors", "add_link_option",
           "int_arg", "number_arg", "checked_arg", "LazyHelp"]
