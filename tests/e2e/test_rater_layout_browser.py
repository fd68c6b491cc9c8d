"""Real browser (Debian Chromium via Playwright): the rater page uses the screen.

At 1400x900 and 1024x768 the two crops are drawn side by side at one size, each at least 40%
of the window's width, with the whole item and its buttons on screen; the three buttons sit
in one row under the pair; Good and Bad have different colours; the scale line says the
drawn width over the object's side in camera pixels (items.csv ``crop_side``).
"""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from tests.e2e.browser_support import ARGS, CHROMIUM, serve, settled, stop, toy_study

pytestmark = [pytest.mark.browser,
              pytest.mark.skipif(not Path(CHROMIUM).exists(), reason="needs /usr/bin/chromium")]

SIZES = [(1400, 900), (1024, 768)]
#: the study of every test here: the toy scene's one training item and one test frame, 64 px
ONE_ITEM = {"n_gold": 0, "n_repeats": 0, "size": 64}
BOXES = """() => {
  const box = (e) => { const r = e.getBoundingClientRect(); return [r.x, r.y, r.width, r.height]; };
  const buttons = {};
  for (const b of document.querySelectorAll('button')) {
    const name = b.innerText.split('\\n')[0].trim();
    if (name) buttons[name] = [...box(b), getComputedStyle(b).backgroundColor];
  }
  const scale = document.querySelector('.nvrq-scale b');
  return {imgs: Array.from(document.querySelectorAll('img')).map(box), buttons,
          scale: scale ? scale.innerText : null};
}"""


def test_crops_fill_the_window_at_one_scale_with_one_button_row(tmp_path):
    from playwright.sync_api import sync_playwright

    from annotate.study import load_study

    root = toy_study(tmp_path, "annotate_toy_layout", **ONE_ITEM)
    study = load_study(root)
    first = study.manifest.training_order[0]
    side = float(study.items.at[first, "crop_side"])
    assert side == 41  # the toy boxes are 31x41 px in both views
    server, url = serve(root)
    try:
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=CHROMIUM, args=ARGS)
            for width, height in SIZES:
                page = browser.new_page(viewport={"width": width, "height": height})
                page.goto(f"{url}?rater=layout{width}")
                page.get_by_role("button", name="Start").click()
                settled(page, timeout_ms=40000)
                page.wait_for_function(
                    "() => document.querySelectorAll('img')[0].naturalWidth > 0", timeout=40000)
                time.sleep(0.6)  # the scale script updates every 200 ms
                _check(page.evaluate(BOXES), width, height, side)
            browser.close()
    finally:
        stop(server)


def _check(got: dict, width: int, height: int, side: float) -> None:
    from annotate.layout import scale_text

    (lx, ly, lw, lh), (rx, ry, rw, rh) = got["imgs"]
    assert lw >= 0.4 * width and abs(lw - rw) <= 1 and abs(lh - rh) <= 1, got["imgs"]
    assert abs(ly - ry) <= 1 and lx + lw <= rx, got["imgs"]  # side by side
    row = [got["buttons"][n] for n in ("Good", "Bad", "Undo")]
    assert max(b[1] for b in row) - min(b[1] for b in row) <= 1, row  # one row
    assert row[0][0] < row[1][0] < row[2][0] and row[0][1] >= ly + lh  # under the pair
    assert max(b[1] + b[3] for b in row) <= height  # the whole item fits on screen
    assert row[0][4] != row[1][4]  # Good and Bad are coloured apart
    assert got["scale"] == scale_text(lw, side)


def test_on_a_phone_the_pair_and_the_vote_buttons_fit_without_scrolling(tmp_path):
    """Issue 38, item 20: at 390x844 (a phone) Good and Bad are on screen with the pair,
    without scrolling (Streamlit stacks columns below 640 px, which pushed them off)."""
    from playwright.sync_api import sync_playwright

    root = toy_study(tmp_path, "annotate_toy_phone", **ONE_ITEM)
    server, url = serve(root)
    try:
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=CHROMIUM, args=ARGS)
            page = browser.new_page(viewport={"width": 390, "height": 844}, is_mobile=True,
                                    has_touch=True, device_scale_factor=3)
            page.goto(f"{url}?rater=phone")
            page.get_by_role("button", name="Start").click()
            settled(page, timeout_ms=40000)
            page.wait_for_function(
                "() => document.querySelectorAll('img')[0].naturalWidth > 0", timeout=40000)
            time.sleep(0.6)
            got = page.evaluate(BOXES)
            scroll = page.evaluate("() => [window.scrollY, document.documentElement.scrollWidth]")
            page.screenshot(path=str(tmp_path / "phone.png"))
            browser.close()
    finally:
        stop(server)
    (lx, ly, lw, lh), (rx, ry, rw, rh) = got["imgs"]
    assert abs(ly - ry) <= 1 and lx + lw <= rx, got["imgs"]  # side by side, not stacked
    for name in ("Good", "Bad"):
        x, y, w, h = got["buttons"][name][:4]
        assert 0 <= x and x + w <= 390 and y >= ly + lh and y + h <= 844, (name, got)
    assert scroll == [0, 390], scroll  # nothing scrolled, nothing wider than the screen


def test_enter_in_the_name_field_signs_in_and_training_says_when_it_is_over(tmp_path):
    """Issue 38, item 20: typing a name and pressing Enter signs in (no click needed), and
    the first item after the training says "Training done — the study starts now"."""
    from playwright.sync_api import sync_playwright

    from tests.e2e.browser_support import ready, wait_moved

    root = toy_study(tmp_path, "annotate_toy_enter", **ONE_ITEM)
    server, url = serve(root)
    try:
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=CHROMIUM, args=ARGS)
            page = browser.new_page(viewport={"width": 1400, "height": 900})
            page.goto(url)
            field = page.get_by_label("Your name (letters, digits, '.', '_', '-')")
            field.wait_for(state="visible", timeout=40000)
            field.fill("enid")
            field.press("Enter")
            page.get_by_role("button", name="Start").click(timeout=40000)
            first = settled(page, timeout_ms=40000)
            assert first[0].startswith("Training 0 / 1"), first
            assert "Training done" not in page.inner_text("body")
            ready(page)
            time.sleep(0.4)
            page.keyboard.press("g")
            wait_moved(page, first)
            page.get_by_text("Training done — the study starts now").wait_for(timeout=40000)
            browser.close()
    finally:
        stop(server)
