"""Issue 38 item 18 in a real browser (Debian Chromium via Playwright): the analysis report with
a 25-column breakdown table and the pairwise report fit a 1400 px and a 1024 px window; wide
tables scroll inside their own box. Counts print as integers, and a rater excluded by the
screening rule has the flags text once."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from analysis.cli import main
from tests.analysis.methods_data import make_method_tables, make_pairwise_votes
from tests.analysis.synth import make_ratings
from tests.e2e.browser_support import ARGS, CHROMIUM

pytestmark = [pytest.mark.browser,
              pytest.mark.skipif(not Path(CHROMIUM).exists(), reason="needs /usr/bin/chromium")]

WIDTHS = """() => [document.documentElement.scrollWidth, window.innerWidth,
  Math.max(...Array.from(document.querySelectorAll('.scroll')).map(d => d.scrollWidth)),
  Array.from(document.querySelectorAll('table')).filter(t => !t.closest('.scroll')).length]"""


def _wide_report(d: Path) -> Path:
    """The synthetic ratings with 11 metric columns (breakdown tables of 3 + 2 x 11 columns,
    as wide as the demo's) and a fast straight-lining rater excluded by screening."""
    ratings, metrics = make_ratings()
    rng = np.random.default_rng(1)
    extra = [f"very_long_metric_name_number_{i}" for i in range(8)]
    for c in extra:
        metrics[c] = metrics["nvrq:dinov2-small"] + rng.normal(0, 0.1, len(metrics))
    ratings = ratings.drop(columns="blurriness")
    liar = ratings[(ratings["rater_id"] == "sim-0")].assign(rater_id="zz-liar", vote=1,
                                                           response_ms=50)
    pd.concat([ratings, liar]).to_csv(d / "ratings.csv", index=False)
    metrics.to_csv(d / "metrics.csv", index=False)
    out = d / "report"
    assert main([str(d / "ratings.csv"), "--metrics-table", str(d / "metrics.csv"), "--higher-better",
                 ",".join(extra), "--bootstrap", "0", "--out", str(out), "--quiet"]) == 0
    return out / "report.html"


def _pairwise_report(d: Path) -> Path:
    pairs, metrics = make_method_tables()
    make_pairwise_votes(pairs, n_raters=5).to_csv(d / "votes.csv", index=False)
    metrics.to_csv(d / "metrics.csv", index=False)
    assert main([str(d / "votes.csv"), "--metrics-table", str(d / "metrics.csv"), "--bootstrap", "0",
                 "--out", str(d / "pw"), "--quiet"]) == 0
    return d / "pw" / "report.html"


def test_reports_fit_1400_and_1024_px_windows(tmp_path):
    from playwright.sync_api import sync_playwright

    (tmp_path / "pw").parent.mkdir(exist_ok=True)
    pages = {"report": _wide_report(tmp_path), "pairwise": _pairwise_report(tmp_path)}
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=CHROMIUM, args=ARGS)
        try:
            for width in (1400, 1024):
                page = browser.new_page(viewport={"width": width, "height": 900})
                for name, path in pages.items():
                    page.goto(path.as_uri())
                    page_w, inner, widest, loose = page.evaluate(WIDTHS)
                    assert page_w <= inner == width, f"{name} at {width} px: page {page_w} px"
                    assert loose == 0, f"{name}: a table outside a scroll box"
                    if name == "report":  # the breakdown tables are wider than the window
                        assert widest > width, widest
                        page.screenshot(path=str(tmp_path / f"report-{width}.png"), full_page=True)
                page.close()
        finally:
            browser.close()
    md = (pages["report"].parent / "report.md").read_text().split("## Raters")[-1]
    rows = [[c.strip() for c in line.strip("|").split(" | ")] for line in md.splitlines()
            if line.startswith("| ")]
    head, body = rows[0], rows[1:]
    liar = next(r for r in body if r[0] == "zz-liar")
    raters = pd.read_csv(pages["report"].parent / "raters.csv").set_index("rater_id")
    flags = raters.loc["zz-liar", "flags"]
    assert raters.loc["zz-liar", "excluded"] and isinstance(flags, str) and flags
    # the flags text once in the rater's row (in excluded_reason), not in two columns
    assert sum(flags in c for c in liar) == 1, liar
    # counts and milliseconds print as whole numbers (they were 919.000)
    for col in ("n_test", "gold_failures", "median_response_ms"):
        assert all(r[head.index(col)].isdigit() for r in body), col
