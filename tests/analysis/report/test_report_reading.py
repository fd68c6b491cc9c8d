"""What a reader of the demo's reports is told: inputs by their paths relative to the report
(no machine's temporary folder), one line per headline number of the leaderboard (what the
off-path mean and NTA-IoU pool), and the JOD scale beside Bradley-Terry with its intervals
and the rule for when none is given; jod.csv's numbers are the ones shown."""

from __future__ import annotations

import re

import pandas as pd
import pytest

from analysis.report.report import path_from_report


@pytest.fixture(scope="module")
def pages(demo_report_pages):
    root, built, _ = demo_report_pages
    return root, built["leaderboard"], built["pairwise"]


def test_path_from_report_is_relative_to_the_report_folder(tmp_path):
    assert path_from_report(tmp_path / "a" / "votes.csv", tmp_path / "a" / "report") == "../votes.csv"
    assert path_from_report(tmp_path / "votes.csv", tmp_path / "a" / "b") == "../../votes.csv"


def test_no_absolute_or_temporary_path_is_shown(pages):
    d, board, pairwise = pages
    for page in (board, pairwise):
        for text in (page.read_text(encoding="utf-8"), page.with_name("report.md").read_text(encoding="utf-8")):
            assert str(d) not in text and "nvrq-nta-" not in text and "/tmp/" not in text
    assert "<code>../pairs.csv</code>" in board.read_text(encoding="utf-8")
    assert "<code>../votes.csv</code>" in pairwise.read_text(encoding="utf-8")


def test_the_leaderboard_says_what_each_headline_number_is(pages):
    md = pages[1].with_name("report.md").read_text(encoding="utf-8")
    lines = [line[2:] for line in md.split("## Leaderboard", 1)[1].split("###", 1)[0].splitlines()
             if line.startswith("- ")]
    assert lines[0].startswith("nvrq_ca:dinov2-small (off-path) in the leaderboard: per method, the mean")
    assert "every view but the recorded one pooled" in lines[0]
    nta = next(line for line in lines if line.startswith("nta_iou:"))
    assert "pools every box at every non-zero offset" in nta
    assert all(line.endswith(".") for line in lines)


def test_the_jod_table_shows_jod_csv(pages):
    page = pages[2]
    jod = pd.read_csv(page.with_name("jod.csv"))
    md = page.with_name("report.md").read_text(encoding="utf-8")
    section = md.split("## The same votes in JOD (Thurstone scale)", 1)[1].split("###", 1)[0]
    rows = [[c.strip() for c in line.strip("|").split("|")] for line in section.splitlines() if line.startswith("| ")]
    assert rows[0] == ["method", "votes", "JOD", "next method", "P(above next)", "P(prefer to next)", "reason"]
    overall = jod[jod["axis"] == "all"].set_index("method")
    for method, votes, value, *_ in rows[1:]:
        r = overall.loc[method]
        assert value == f"{r.jod:.2f} [{r.jod_ci_lo:.2f}, {r.jod_ci_hi:.2f}]" and float(votes) == r.n_votes
    assert len(rows) - 1 == len(overall) == 2
    assert re.search(r"No interval is given from fewer than 3 raters, without a bootstrap", section)
    assert "<h2>The same votes in JOD (Thurstone scale)</h2>" in page.read_text(encoding="utf-8")
