"""Issue 38 item 38: ``annotate export`` writes ratings.csv for people: a pair attribute that
starts like a spreadsheet formula gets a leading quote (OWASP CSV injection), numbers do not,
``--raw-csv`` keeps the cells as they came, and ``analyze`` reads either back the same."""

from __future__ import annotations

import csv

import pandas as pd

from analysis.tables.inputs import read_ratings
from annotate.cli import main

FORMULA = '=HYPERLINK("http://evil.example","click")'


def _vote_all(study, rater):
    while (key := study.next_item(rater)) is not None:
        study.store.record_vote(rater, key, 1, response_ms=500)


def test_export_quotes_formula_cells_and_raw_keeps_them(make_study, toy_inputs, tmp_path):
    _scene, pairs = toy_inputs
    p = pd.read_csv(pairs)
    p["lighting"] = FORMULA
    p["road_type"] = "@SUM(1+1)"
    p.to_csv(pairs, index=False)
    s = make_study()
    _vote_all(s, "ann")
    out, raw = tmp_path / "ratings.csv", tmp_path / "raw.csv"
    assert main(["export", str(s.root), "--out", str(out)]) == 0
    assert main(["export", str(s.root), "--out", str(raw), "--raw-csv"]) == 0
    with open(out, newline="", encoding="utf-8") as fh:
        rows = list(csv.reader(fh))
    head = rows[0]
    test = [r for r in rows[1:] if r[head.index("kind")] == "test"]
    assert {r[head.index("lighting")] for r in test} == {"'" + FORMULA}
    assert {r[head.index("road_type")] for r in test} == {"'@SUM(1+1)"}
    # offsets are numbers: -1.0 stays -1.0 (not quoted)
    assert "-1.0" in {r[head.index("y_offset_m")] for r in test}
    with open(raw, newline="", encoding="utf-8") as fh:
        raw_rows = list(csv.reader(fh))
    assert FORMULA in {r[head.index("lighting")] for r in raw_rows[1:]}
    # the machine reader gets the values back either way
    a, b = read_ratings(out), read_ratings(raw)
    pd.testing.assert_frame_equal(a, b)
    assert set(a.loc[a["kind"] == "test", "lighting"]) == {FORMULA}
