"""One command-line convention (issue 11 item 4, docs/FORMATS.md): names as comma lists, files
as options named for their kind (repeatable where they combine), sizes as WxH, shared defaults
from one constant; old spellings still parse, with one deprecation note on stderr."""

from __future__ import annotations

import pytest

from analysis.cli import build_parser as analyze_parser
from annotate.cli import build_parser as annotate_parser
from data_schema.errors import InputError
from data_schema.tables import MIN_SIDE_PX
from nvrq.cli import build_parser as nvrq_parser
from nvrq.cli_types import parse_wxh


def test_metrics_tables_are_repeatable_and_old_spelling_is_noted(capsys):
    a = analyze_parser().parse_args(["r.csv", "--metrics-table", "a.csv", "--metrics", "b.csv",
                                     "--metrics-table", "c.csv", "--out", "rep"])
    assert a.metrics_tables == ["a.csv", "b.csv", "c.csv"]
    assert capsys.readouterr().err == "note: --metrics FILE is deprecated; use --metrics-table FILE\n"
    b = annotate_parser().parse_args(["build", "st", "--pairs", "p.csv", "--metrics", "m.csv"])
    assert b.metrics_tables == ["m.csv"]
    assert "deprecated" in capsys.readouterr().err


def test_name_lists_are_comma_separated_and_old_space_lists_still_work(capsys):
    a = analyze_parser().parse_args(["r.csv", "--lower-better", "x,y", "--higher-better", "z",
                                     "--exclude-raters", "ann,bob", "--exclude-raters", "cy", "--out", "o"])
    assert (a.lower_better, a.higher_better, a.exclude_raters) == (["x", "y"], ["z"], ["ann", "bob", "cy"])
    assert capsys.readouterr().err == ""
    a = analyze_parser().parse_args(["r.csv", "--lower-better", "x", "y", "--out", "o"])
    assert a.lower_better == ["x", "y"]
    assert capsys.readouterr().err == "note: --lower-better x y is deprecated; use --lower-better x,y\n"


def test_sizes_are_wxh_everywhere(capsys):
    assert nvrq_parser().parse_args(["synth", "s", "--size", "640x360"]).size == "640x360"
    b = annotate_parser().parse_args(["build", "st", "--pairs", "p.csv", "--size", "256x256"])
    assert b.size == "256x256" and capsys.readouterr().err == ""
    old = annotate_parser().parse_args(["build", "st", "--pairs", "p.csv", "--size", "256"])
    assert old.size == "256x256" and "use --size 256x256" in capsys.readouterr().err
    assert parse_wxh("960x540", option="--size") == (960, 540)
    for bad in ("960", "-640x360", "0x10", "axb", "1x2x3"):
        with pytest.raises(InputError, match="--size"):
            parse_wxh(bad, option="--size")


def test_non_square_display_size_is_refused(tmp_path, capsys):
    from annotate.cli import main

    rc = main(["build", str(tmp_path / "st"), "--pairs", str(tmp_path / "p.csv"), "--size", "320x200"])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and "--size" in err and "square" in err
    assert not (tmp_path / "st").exists()


def test_min_side_has_one_default():
    # the two commands read the same constant (30 px, docs/FORMATS.md §3), no longer 30 and 32
    p = nvrq_parser()
    assert p.parse_args(["pairs", "s", "--out", "p.csv"]).min_side == MIN_SIDE_PX == 30
    assert p.parse_args(["stability", "p.csv", "--out", "d"]).min_side == MIN_SIDE_PX


@pytest.mark.parametrize("parser, argv", [
    (nvrq_parser, ["synth", "s", "--size"]),
    (annotate_parser, ["export", "st"]),
    (analyze_parser, ["r.csv", "--bootstrap", "many", "--out", "o"]),
])
def test_usage_errors_are_one_line(parser, argv, capsys):
    with pytest.raises(SystemExit) as exc:
        parser().parse_args(argv)
    err = capsys.readouterr().err
    assert exc.value.code == 2 and err.count("\n") == 1 and err.startswith("error: ")


def _library_modules():
    """Every module of the four packages except the command-line layer (``*/cli.py``, ``nvrq/commands``)
    and the argument conventions it shares (``nvrq/cli_types.py``, ``nvrq/cli_options.py``: flags
    and their help texts)."""
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    for pkg in ("data_schema", "nvrq", "annotate", "analysis"):
        for path in sorted((root / pkg).rglob("*.py")):
            if path.name not in ("cli.py", "cli_types.py", "cli_options.py") \
                    and "commands" not in path.relative_to(root).parts:
                yield path


def test_library_errors_name_parameters_not_flags():
    # the library names its parameters (`encoder`); only the CLI layer speaks of flags (--encoder),
    # through nvrq.cli_types.flags_in_errors
    import ast

    flagged = []
    for path in _library_modules():
        text = path.read_text(encoding="utf-8")
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, ast.Call) and getattr(node.func, "id", None) == "InputError" and node.args:
                where = node.args[0]
                if isinstance(where, ast.Constant) and str(where.value).startswith("--"):
                    flagged.append(f"{path.name}:{node.lineno} {where.value}")
            if not isinstance(node, ast.FunctionDef):
                continue
            defaults = dict(zip([a.arg for a in node.args.kwonlyargs], node.args.kw_defaults, strict=True))
            for name in ("option", "where"):
                d = defaults.get(name)
                if isinstance(d, ast.Constant) and str(d.value).startswith("--"):
                    flagged.append(f"{path.name}:{node.lineno} {name}={d.value}")
    assert flagged == []


def _strings(tree):
    """``(line, text)`` of every string a module builds, docstrings and argparse calls
    (``add_argument``/``add_parser``: the parser's own text) left out; an f-string is one text."""
    import ast

    skip = set()
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if isinstance(body, list) and body and isinstance(body[0], ast.Expr) \
                and isinstance(body[0].value, ast.Constant):
            skip.add(id(body[0].value))
        if isinstance(node, ast.Call) and getattr(node.func, "attr", None) in ("add_argument", "add_parser"):
            skip.update(id(n) for n in ast.walk(node))
        if isinstance(node, ast.JoinedStr):
            skip.update(id(v) for v in node.values)
            if id(node) not in skip:
                yield node.lineno, "".join(v.value if isinstance(v, ast.Constant) else "{}" for v in node.values)
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in skip:
            yield node.lineno, node.value


def test_library_hints_name_parameters_not_flags():
    # a hint names the parameter between backticks (`weights`, `allow_same_class`); nvrq's entry
    # point turns it into the chosen command's option (nvrq.cli_types.flags_in_errors). Another
    # program's command line between backticks (`ray start --head`) is not ours.
    import ast
    import re

    flag = re.compile(r"(?<![\w-])--[a-z][a-z0-9-]*")
    foreign = re.compile(r"`(?!(?:nvrq|annotate|analyze)\b)[^`]*`")
    flagged = []
    # the analysis report's prose says how `analyze` was run (its options), as does screening's
    # excluded_reason column (raters.csv) and the screening sentence of analysis.common.text (report and
    # terminal): output of that command, not a hint to a caller
    report_prose = {"report.py", "methods_report.py", "pairwise_report.py", "screening.py", "text.py"}
    for path in _library_modules():
        if path.name in report_prose:
            continue
        for line, text in _strings(ast.parse(path.read_text(encoding="utf-8"))):
            if text.startswith("pip install "):  # pip's command line (an install hint), not ours
                continue
            found = flag.findall(foreign.sub("", text))
            if found:
                flagged.append(f"{path.name}:{line} {', '.join(found)}")
    assert flagged == []


def test_a_library_hint_names_the_parameter():
    # the command line gets --allow-same-class (tests/nvrq/test_calibrate.py); the library says
    # the parameter's name
    import pandas as pd

    from nvrq.calibrate import calibrate_tau

    one_class = pd.DataFrame({"pair_id": ["p", "q"], "track_id": ["a", "b"], "label_class": "car",
                              "gt_path": "g.png", "gt_x0": 0, "gt_y0": 0, "gt_x1": 9, "gt_y1": 9})
    with pytest.raises(InputError, match=r"\(or `allow_same_class`\), got 2 tracks, 1 class$"):  # singular: issue 38 item 17
        calibrate_tau(one_class, type("Encoder", (), {"embed": None})())


@pytest.mark.parametrize("argv, name, flag", [
    (["score", "p.csv", "--out", "m.csv"], "encoder", "--encoder"),
    (["score", "p.csv", "--out", "m.csv"], "batch_size", "--batch-size"),
    (["score", "p.csv", "--out", "m.csv"], "scene_root", "--scene"),  # an alias
    (["score", "p.csv", "--out", "m.csv"], "weights", "--weights"),  # alias 'yolo' absent: own name
    (["proxy", "detect", "p.csv", "--out", "d.csv", "--yolo", "y.pt"], "weights", "--yolo"),
    (["score", "p.csv", "--out", "m.csv"], "no_such_parameter", None),
])
def test_parameter_names_map_to_the_chosen_commands_flags(argv, name, flag):
    from nvrq.cli_types import option_for

    parser = nvrq_parser()
    args = parser.parse_args(argv)
    assert option_for(parser, args, name, {"scene_root": "scene", "weights": "yolo"}) == flag


def test_a_library_error_reaches_the_cli_as_its_flag(tmp_path, capsys):
    from nvrq.cli import main
    from nvrq.encoders import get_spec

    with pytest.raises(InputError, match="^encoder: expected one of"):
        get_spec("resnet-9000")
    (tmp_path / "p.csv").write_text("pair_id\n")
    assert main(["score", str(tmp_path / "p.csv"), "--out", str(tmp_path / "m.csv"),
                 "--encoder", "resnet-9000"]) == 2
    assert capsys.readouterr().err.startswith("error: --encoder: expected one of")
