"""The demo's reports in a real browser (Debian Chromium via Playwright) at 1280 x 800 and at
390 x 844: every table's last column can be reached by scrolling inside the table's own box,
no table row is taller than three lines of text, every figure is drawn at its own aspect ratio
inside the page, and the pairwise page has its JOD table. The figures' legends are checked
as drawn in tests/analysis/report/test_figure_legends.py; ``--screenshots DIR`` (NVRQ_SHOTS) keeps
the pages as PNG."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from tests.e2e.browser_support import ARGS, CHROMIUM

pytestmark = [pytest.mark.browser,
              pytest.mark.skipif(not Path(CHROMIUM).exists(), reason="needs /usr/bin/chromium")]

SIZES = [(1280, 800), (390, 844)]

# per table: [scroll box width, scrollWidth, last header cell reachable after scrolling to the end,
#             tallest row in lines, table heading]
TABLES = """() => Array.from(document.querySelectorAll('table')).map(t => {
  const box = t.closest('.scroll');
  const head = t.querySelector('thead tr');
  const last = head.lastElementChild;
  box.scrollLeft = box.scrollWidth;
  const b = box.getBoundingClientRect(), c = last.getBoundingClientRect();
  const reach = c.right <= b.right + 1 && c.right > b.left;  // its end in view (a long cell is wider than a phone)
  box.scrollLeft = 0;
  let lines = 0;
  for (const row of t.querySelectorAll('tr')) {
    for (const cell of row.children) {
      const s = getComputedStyle(cell);
      const inner = cell.clientHeight - parseFloat(s.paddingTop) - parseFloat(s.paddingBottom);
      lines = Math.max(lines, inner / parseFloat(s.lineHeight));
    }
  }
  return [box ? box.clientWidth : -1, box ? box.scrollWidth : -1, reach, lines,
          (box.previousElementSibling || {}).textContent || ''];
})"""

# per figure: [natural w, natural h, drawn w, drawn h (inside its border), right edge, page width, title]
FIGURES = """() => Array.from(document.querySelectorAll('img')).map(i => {
  const r = i.getBoundingClientRect();
  return [i.naturalWidth, i.naturalHeight, i.clientWidth, i.clientHeight, r.right, document.documentElement.clientWidth,
          i.alt];
})"""


def test_demo_reports_read_at_desktop_and_phone_sizes(demo_report_pages):
    from playwright.sync_api import sync_playwright

    pages = demo_report_pages[1]
    shots = os.environ.get("NVRQ_SHOTS")
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=CHROMIUM, args=ARGS)
        try:
            for width, height in SIZES:
                page = browser.new_page(viewport={"width": width, "height": height})
                for name, path in pages.items():
                    page.goto(path.as_uri())
                    where = f"{name} at {width} x {height}"
                    assert page.evaluate("document.documentElement.scrollWidth") <= width, where
                    tables = page.evaluate(TABLES)
                    assert tables, where
                    for box_w, _scroll_w, reach, lines, title in tables:
                        assert box_w > 0, f"{where}: a table outside a scroll box ({title})"
                        assert reach, f"{where}: the last column of a table after {title!r} cannot be reached"
                        assert lines <= 3.05, f"{where}: a row {lines:.1f} lines tall after {title!r}"
                    figures = page.evaluate(FIGURES)
                    assert figures, where
                    for nw, nh, w, h, right, page_w, alt in figures:
                        assert nw > 0 and w > 0, f"{where}: {alt} not drawn"
                        assert abs(w / h - nw / nh) < 0.02 * nw / nh, f"{where}: {alt} squeezed ({w}x{h} of {nw}x{nh})"
                        assert w <= nw + 0.5 and right <= page_w + 0.5, f"{where}: {alt} beyond the page"
                    if name == "pairwise":
                        heads = page.locator("h2").all_inner_texts()
                        assert any("JOD" in h for h in heads), heads
                        jod = page.locator("h2:has-text('JOD') + .scroll table")
                        assert jod.locator("th").all_inner_texts()[:4] == ["method", "votes", "JOD", "next method"]
                        assert jod.locator("tbody tr").count() == 2
                    if name == "report":  # its wide tables are wider than either window
                        assert max(t[1] for t in tables) > width
                    if shots:
                        page.screenshot(path=str(Path(shots) / f"{name}-{width}.png"), full_page=False)
                page.close()
        finally:
            browser.close()
