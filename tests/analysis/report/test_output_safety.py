"""Issue 38 item 38: data in the report's Markdown is shown, never run; CSVs written for people
carry no live spreadsheet formula (OWASP CSV injection), and the machine-read round trip holds."""

import csv
import re
import sys
from pathlib import Path

import pandas as pd
import pytest

from analysis.cli import main
from data_schema.csv_safe import safe_frame, unquote_frame

sys.path.insert(0, str(Path(__file__).parents[1]))
from synth import make_ratings  # noqa: E402

XSS = "<img src=x onerror=alert(1)>"
FORMULA = '=HYPERLINK("http://evil.example","click")'
LINK = "[x](javascript:alert(1))"


def _hostile(tmp_path, *, quoted: bool):
    ratings, metrics = make_ratings()
    clip_value = {"clip0": XSS, "clip1": FORMULA, "clip2": LINK}
    ratings["lighting"] = ratings["clip_id"].map(clip_value).fillna(ratings["lighting"])
    (safe_frame(ratings) if quoted else ratings).to_csv(tmp_path / "ratings.csv", index=False)
    metrics.to_csv(tmp_path / "metrics.csv", index=False)
    out = tmp_path / "o"
    rc = main([str(tmp_path / "ratings.csv"), "--metrics-table", str(tmp_path / "metrics.csv"),
               "--lower-better", "blurriness", "--bootstrap", "0", "--no-screen", "--out", str(out),
               "--quiet"])
    assert rc == 0
    return out


def _cells(path):
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.reader(f))


@pytest.mark.filterwarnings("error")  # issue 38 item 23: analyze prints no warning either
def test_report_md_escapes_html_and_links_and_csvs_quote_formulas(tmp_path):
    out = _hostile(tmp_path, quoted=False)
    md = (out / "report.md").read_text()
    # the value is shown (escaped), never as a raw tag or a live link
    assert "img src=x onerror=alert(1)" in md
    assert not re.search(r"(?<!\\)<img", md), "raw HTML in report.md"
    assert not re.search(r"(?<!\\)\]\(javascript:", md), "a live link in report.md"
    html = (out / "report.html").read_text()
    assert "<img src=x" not in html and "&lt;img src=x onerror=alert(1)&gt;" in html
    rows = _cells(out / "items.csv")
    col = rows[0].index("lighting")
    values = {r[col] for r in rows[1:]}
    assert "'" + FORMULA in values and FORMULA not in values
    assert not any(c[:1] in "=+-@\t\r" and not re.fullmatch(r"[+-]?[\d.]+(e[+-]?\d+)?", c)
                   for r in rows for c in r), "a formula cell in items.csv"
    # numbers stay numbers: the negative offsets are written as they are
    off = rows[0].index("y_offset_m")
    assert {r[off] for r in rows[1:]} == {"-2.0", "-1.0", "0.0", "1.0", "2.0"}
    cats = pd.read_csv(out / "categories.csv")
    assert "'" + FORMULA in set(cats["group"])


def test_quoted_ratings_round_trip_to_the_same_report(tmp_path):
    """analyze reads a ratings.csv quoted by annotate export as the raw one: same items.csv."""
    raw = _hostile(tmp_path / "raw", quoted=False) if (tmp_path / "raw").mkdir() is None else None
    quoted = _hostile(tmp_path / "q", quoted=True) if (tmp_path / "q").mkdir() is None else None
    a, b = pd.read_csv(raw / "items.csv"), pd.read_csv(quoted / "items.csv")
    pd.testing.assert_frame_equal(a, b)
    assert unquote_frame(a)["lighting"].isin([XSS, FORMULA, LINK]).all()


@pytest.mark.parametrize("value, want", [
    ("=1+1", "'=1+1"), ("+cmd", "'+cmd"), ("-2+3", "'-2+3"), ("@SUM(A1)", "'@SUM(A1)"),
    ("\tx", "'\tx"), ("\rx", "'\rx"), ("-3", "-3"), ("+1.5", "+1.5"), ("-2e-3", "-2e-3"),
    ("-", "-"), ("plain", "plain"),
])
def test_safe_frame_cells_hand_listed(value, want):
    # the OWASP list of formula starts (= + - @ tab CR); plain numbers are not formulas
    df = pd.DataFrame({"s": [value], "n": [-3.0]})
    got = safe_frame(df)
    assert got["s"].iloc[0] == want and got["n"].iloc[0] == -3.0
    assert unquote_frame(got)["s"].iloc[0] == value
