"""One command-line convention (issue 11 item 4, docs/FORMATS.md): names as comma lists, files
as options named for their kind (repeatable where they combine), sizes as WxH, shared defaults
from one constant; old spellings still parse, with one deprecation note on stderr."""

from __future__ import annotations

import pytest

from analysis.cli import build_parser as analyze_parser
from annotate.cli import build_parser as annotate_parser
from data_schema.cliargs import parse_wxh
from data_schema.errors import InputError
from data_schema.tables import MIN_SIDE_PX
from nvrq.cli import build_parser as nvrq_parser


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
