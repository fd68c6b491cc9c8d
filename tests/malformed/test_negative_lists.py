"""Issue 38 item 7: a list option whose value starts with a minus sign (``--offsets -3,abc``) gets
the command's own message, the one ``3,abc`` gets, in all three CLIs (argparse used to read
``-3,abc`` as an unknown option and say "expected one argument")."""

from __future__ import annotations

import re

import pytest

from tests.malformed.test_corpus import run_main

# (program, argv with {v} for the list value, {tmp}/{world} for folders): one comma-list option
# of each kind in each CLI (numbers, numbers checked against a table, names).
LIST_OPTIONS = [
    ("nvrq", ["synth", "{tmp}/s", "--offsets", "{v}"]),
    ("nvrq", ["render-plan", "{world}/scene", "--out", "{tmp}/plan.csv", "--offsets", "{v}"]),
    ("nvrq", ["demo", "{tmp}/d", "--offsets", "{v}"]),
    ("annotate", ["build", "{tmp}/st", "--pairs", "{world}/toy/pairs.csv", "--scene", "{world}/toy/scene",
                  "--offsets", "{v}"]),
    ("analyze", ["{world}/ratings.csv", "--lower-better", "{v}", "--bootstrap", "0", "--out", "{tmp}/r",
                 "--quiet"]),
    ("analyze", ["--pairs", "{world}/toy/pairs.csv", "--compare-methods", "--methods", "{v}",
                 "--out", "{tmp}/r", "--quiet"]),
]


def _message(prog, argv, value, world, tmp, capfd) -> str:
    capfd.readouterr()
    rc = run_main(prog, [a.format(v=value, tmp=tmp, world=world) for a in argv])
    err = capfd.readouterr().err.strip()
    assert rc == 2 and "\n" not in err, err
    return err


@pytest.mark.parametrize("prog, argv", LIST_OPTIONS, ids=[f"{p} {a[0]} {a[-2] if '{v}' == a[-1] else a[-6]}"
                                                          for p, a in LIST_OPTIONS])
@pytest.mark.parametrize("plain, minus", [("3,abc", "-3,abc"), ("a,b", "-a,b")])
def test_a_list_starting_with_a_minus_gets_the_plain_lists_message(prog, argv, plain, minus, world,
                                                                   tmp_path, capfd):
    want = _message(prog, argv, plain, world, tmp_path, capfd)
    got = _message(prog, argv, minus, world, tmp_path, capfd)
    assert "expected one argument" not in got
    # the same message, but for the value it quotes: `-3,abc` where the other quotes `3,abc`
    # (or the first item alone: `-a` where the other quotes `a`)
    first = plain.split(",")[0]
    assert (_quoted(got, minus) == _quoted(want, plain)
            or _quoted(got, "-" + first) == _quoted(want, first)), (want, got)


def _quoted(message: str, value: str) -> str:
    """``message`` with the first place it quotes ``value`` (as a whole word) replaced by ``VALUE``."""
    return re.sub(rf"(?<![\w.,-]){re.escape(value)}(?![\w.])", "VALUE", message, count=1)
