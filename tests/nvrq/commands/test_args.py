"""The command layer's shared pieces (nvrq.cli_types): how a command ends (docs/FORMATS.md
§7: bad input is one stderr line and exit status 2) and the parser of a CLI made of subcommands."""

from __future__ import annotations

import argparse

import pytest

from data_schema.errors import InputError
from nvrq.cli_types import command_parser, run_cli


def _raising(exc):
    def main(argv):
        raise exc

    return main


def test_run_cli_turns_each_ending_into_its_exit_status(capsys):
    # the statuses of docs/FORMATS.md §7 and the run_cli docstring: 2 for bad input or an
    # unreadable file (one line), argparse's own for --help and usage errors, 130 for Ctrl-C
    assert run_cli(_raising(InputError("p.csv", "pair_id", "unique ids", "a, a"))) == 2
    assert capsys.readouterr().err == "error: p.csv: pair_id: expected unique ids, got a, a\n"
    assert run_cli(_raising(FileNotFoundError(2, "No such file or directory", "x.csv"))) == 2
    assert capsys.readouterr().err == "error: x.csv: No such file or directory\n"
    assert run_cli(_raising(KeyboardInterrupt())) == 130
    assert capsys.readouterr().err == "interrupted\n"
    assert run_cli(_raising(SystemExit(0))) == 0 and run_cli(_raising(SystemExit("bad"))) == 2
    assert run_cli(lambda argv: None) == 0 and run_cli(lambda argv: 1) == 1


def test_command_parser_registers_each_module_in_order(capsys):
    # annotate's subcommands as its module docstring lists them: build, serve, add-rater,
    # export, gvf, simulate, rate-yourself
    from annotate.cli import COMMAND_MODULES

    parser = command_parser("annotate", "Rating studies.", COMMAND_MODULES)
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    assert list(sub.choices) == ["build", "serve", "add-rater", "export", "gvf", "simulate", "rate-yourself"]
    args = parser.parse_args(["gvf", "st"])
    assert args.command == "gvf" and args.func.__module__ == "annotate.commands.gvf"
    with pytest.raises(SystemExit) as exc:
        parser.parse_args(["vote"])
    err = capsys.readouterr().err
    assert exc.value.code == 2 and err.count("\n") == 1
    assert err.startswith("error: annotate: argument COMMAND: invalid choice: 'vote'")
    assert err.endswith("(see annotate --help)\n")


def test_the_argument_types_keep_their_old_import_paths():
    # they moved below the command layer (nvrq.cli_types, nvrq.cli_options); the old modules
    # re-export every public name as the same object
    import nvrq.cli_options
    import nvrq.cli_types
    import nvrq.commands.args
    import nvrq.commands.shared_options

    for new, old in ((nvrq.cli_types, nvrq.commands.args), (nvrq.cli_options, nvrq.commands.shared_options)):
        assert sorted(old.__all__) == sorted(new.__all__)
        assert all(getattr(old, name) is getattr(new, name) for name in new.__all__)
