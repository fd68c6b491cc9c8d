"""InputError's one meaning of ``where`` (issue 26 item 7): the file; a bad parameter or option
is ``param``. The message a user reads is the same line as before, and the CLIs still name
their flag for a parameter (nvrq.cli_types.flags_in_errors)."""

from __future__ import annotations

import ast
import pickle
from pathlib import Path

import pytest

from data_schema.errors import InputError, check_int
from nvrq.cli_types import ArgumentParser, flags_in_errors

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("err, line", [
    # the docs/FORMATS.md §7 format, written out by hand
    (InputError("scene.json", "cameras.front.T_sensor_rig", "a 4x4 matrix", "3x4"),
     "scene.json: cameras.front.T_sensor_rig: expected a 4x4 matrix, got 3x4"),
    (InputError(param="tracks", expected="an integer >= 1", got=0), "tracks: expected an integer >= 1, got 0"),
    (InputError("tracks", None, "an integer >= 1", 0), "tracks: expected an integer >= 1, got 0"),  # former form
    (InputError(param="methods", field="nerf", expected="a method of pairs.csv", got="no such method"),
     "methods: nerf: expected a method of pairs.csv, got no such method"),
    (InputError("pairs.csv", "line 3", "a number", param="offsets"),
     "pairs.csv: offsets: line 3: expected a number"),
])
def test_the_message_is_one_line_in_file_param_field_order(err, line):
    assert str(err) == line
    assert isinstance(err, ValueError)


def test_where_is_the_file_and_param_the_parameter():
    err = InputError(param="tracks", expected="an integer >= 1", got=0)
    assert (err.where, err.param, err.field, err.expected, err.got) == (None, "tracks", None, "an integer >= 1", 0)
    with pytest.raises(InputError) as caught:
        check_int("batch_size", 0)
    assert caught.value.param == "batch_size" and caught.value.where is None


def test_expected_is_required():
    with pytest.raises(TypeError):
        InputError("x.csv", "column 'a'")


def test_an_input_error_pickles_with_its_fields():
    # errors cross process boundaries (Ray tasks): the unpickled error is the same error
    err = InputError("pairs.csv", "line 2", "a number", "x", param="offsets")
    back = pickle.loads(pickle.dumps(err))
    assert type(back) is InputError and str(back) == str(err)
    assert (back.where, back.param, back.field, back.got) == ("pairs.csv", "offsets", "line 2", "x")


def _parser():
    parser = ArgumentParser(prog="tool")
    parser.add_argument("pairs")
    parser.add_argument("--tracks", type=int, default=1)
    parser.add_argument("--exclude-raters", dest="exclude_raters")
    return parser


@pytest.mark.parametrize("raised, line", [
    (InputError(param="tracks", expected="an integer >= 1", got=0), "--tracks: expected an integer >= 1, got 0"),
    # the former positional form (a parameter name as where) still maps
    (InputError("tracks", None, "an integer >= 1", 0), "--tracks: expected an integer >= 1, got 0"),
    # an alias (parameter exclude -> dest exclude_raters), with the field kept
    (InputError(param="exclude", field="bob", expected="a rater id", got="no such rater"),
     "--exclude-raters: bob: expected a rater id, got no such rater"),
    # a positional argument is named by its metavar; the file stays where it was
    (InputError("p.csv", "line 2", "a pair", param="pairs"), "p.csv: PAIRS: line 2: expected a pair"),
    # a file, or a parameter the command has no option for, is left as it is
    (InputError("p.csv", "line 2", "a number", "x"), "p.csv: line 2: expected a number, got x"),
    (InputError(param="seed", expected="an integer", got="x"), "seed: expected an integer, got x"),
])
def test_flags_in_errors_names_the_flag_of_the_parameter(raised, line):
    parser = _parser()
    args = parser.parse_args(["p.csv"])
    with pytest.raises(InputError) as caught, flags_in_errors(parser, args, {"exclude": "exclude_raters"}):
        raise raised
    assert str(caught.value) == line


def test_library_param_names_are_parameters_not_flags():
    # the library names its parameters; only the command layer (cli.py, commands/) speaks of
    # flags, so a library InputError never passes param="--..." (nor where="--...", the
    # former form, tests/nvrq/test_cli_convention.py)
    flagged = []
    for pkg in ("data_schema", "nvrq", "annotate", "analysis"):
        for path in sorted((ROOT / pkg).rglob("*.py")):
            if path.name == "cli.py" or "commands" in path.relative_to(ROOT).parts:
                continue
            for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
                if isinstance(node, ast.Call) and getattr(node.func, "id", None) == "InputError":
                    for kw in node.keywords:
                        if kw.arg == "param" and isinstance(kw.value, ast.Constant) \
                                and str(kw.value.value).startswith("--"):
                            flagged.append(f"{path.name}:{node.lineno}")
    assert flagged == []
