"""Text a user reads is written for someone who has never seen this repository's history.

No "issue NN" in the README, docs/ or the packages (help, report text, comments alike); counts
in reports take the singular for one; the horizon sentence stays English when a direction is
not good even at the recorded view; the proxy help names every proxy.
"""

from __future__ import annotations

import re
from pathlib import Path

import pandas as pd

REPO = Path(__file__).resolve().parents[1]
ISSUE = re.compile(r"since issue|issue [0-9]", re.I)


def test_no_issue_numbers_in_what_users_read():
    found = []
    for top in ("README.md", "docs", "nvrq", "annotate", "analysis", "data_schema"):
        path = REPO / top
        files = [path] if path.is_file() else [p for p in path.rglob("*") if p.is_file()
                                               and p.suffix in {".py", ".md", ".j2", ".html", ".css", ".txt", ".toml"}]
        for f in files:
            for i, line in enumerate(f.read_text(encoding="utf-8", errors="replace").splitlines(), 1):
                if ISSUE.search(line):
                    found.append(f"{f.relative_to(REPO)}:{i}: {line.strip()}")
    assert found == []


def _row(cls, direction, horizon=float("nan"), reason="", lo=float("nan"), hi=float("nan"), crossing=float("nan")):
    return dict(method="m", label_class=cls, axis="y", direction=direction, horizon=horizon,
                crossing=crossing, reason=reason, ci_lo=lo, ci_hi=hi)


def test_horizon_sentence_when_the_recorded_view_fails():
    from analysis.report.horizon_report import method_sentence

    fail = "fails at the recorded view"
    table = pd.DataFrame([_row("bus", "left", 2.0, "", 2.1, 2.6, 2.25), _row("bus", "right", reason=fail),
                          _row("car", "left", reason=fail), _row("car", "right", reason=fail)])
    assert method_sentence("m", table) == (
        "m: bus stays good to 2 m left (crossing 2.25 [2.1, 2.6]) (on the right side: not good even at the recorded "
        "view); car is not good even at the recorded view.")


def test_report_counts_take_the_singular_for_one():
    from jinja2 import Environment, FileSystemLoader

    from data_schema.text import plural

    env = Environment(loader=FileSystemLoader(REPO / "analysis" / "report" / "templates"))
    env.filters["plural"] = plural
    src = (REPO / "analysis" / "report" / "templates" / "report.md.j2").read_text()
    line = next(x for x in src.splitlines() if 'counts["clips"]' in x)
    text = env.from_string(line).render(counts={"items": 1, "tracks": 2, "clips": 1},
                                        raters_table="", target_label="")
    assert "1 item, 2 tracks, 1 clip" in text


def test_proxy_help_names_nta_iou():
    from nvrq.cli import build_parser

    text = build_parser().format_help()
    assert "NTA-IoU" in text
