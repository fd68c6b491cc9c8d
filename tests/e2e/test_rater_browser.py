"""Real browser (Debian Chromium via Playwright): two raters vote at once with the keyboard.

One rater reloads half-way and must continue at the same item (same images, same counter);
the other undoes a vote with U. The export must then hold every acknowledged vote exactly
once (ack = the page's progress counter moved on), and no page text or image URL may name
the offset, clip, track or item kind.
"""

from __future__ import annotations

import time
from pathlib import Path

import pandas as pd
import pytest

from tests.e2e.browser_support import ARGS, CHROMIUM, serve, settled, stop, toy
from tests.e2e.browser_support import ready as _ready
from tests.e2e.browser_support import wait_moved as _wait_moved

pytestmark = [pytest.mark.browser,
              pytest.mark.skipif(not Path(CHROMIUM).exists(), reason="needs /usr/bin/chromium")]
SECRETS = ("+1.00", "-1.00", "+0.00", "offset", "toy", "trk-", "front", "gold", "repeat", "psnr")


def _state(page) -> tuple[str, tuple]:
    """(progress/done text, image URLs) once the app has finished its rerun."""
    return settled(page, timeout_ms=40000)


def _check_blind(page, seen: list[str]) -> None:
    text = page.inner_text("body")
    urls = " ".join(img.get_attribute("src") or "" for img in page.locator("img").all())
    for secret in SECRETS:
        assert secret not in text and secret not in urls, secret
    seen.append(text)


def test_two_raters_vote_with_keyboard_reload_and_export(tmp_path):
    from playwright.sync_api import sync_playwright

    from annotate.cli import main
    from annotate.study import build_study, load_study

    scene, pairs = toy().make_toy(tmp_path)
    # 1 training + 1 track x 2 frames x 3 offsets + 2 gold + 1 repeat = 10 items per rater
    # (the 2 gold drawn from a pool of 6: issue 38 item 31)
    root = build_study(tmp_path / "study", pairs, scene=str(scene), tracks=1, frames_per_track=2,
                       n_training=1, n_gold=1, n_repeats=1, size=64, progress=False)
    built = load_study(root)
    n_items = len(built.items) - len(built.keys("gold")) + built.gold_per_rater
    assert n_items == 10 and len(built.keys("gold")) == 6
    server, url = serve(root)
    try:
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=CHROMIUM, args=ARGS)
            pages = {r: browser.new_context().new_page() for r in ("alice", "bob")}
            for rater, page in pages.items():
                page.goto(f"{url}?rater={rater}")
            for page in pages.values():
                page.get_by_role("button", name="Start").click()
            state = {r: _state(p) for r, p in pages.items()}
            time.sleep(0.4)  # raters look before they press (presses < 250 ms are dropped)
            acked: dict[str, list[int]] = {"alice": [], "bob": []}
            seen: list[str] = []
            step = 0
            while any(s[0] != "done" for s in state.values()):
                pressed = {}
                for rater, page in pages.items():  # both press before either is awaited
                    if state[rater][0] == "done":
                        continue
                    vote = (step + (rater == "bob")) % 3 != 0
                    _ready(page)
                    page.keyboard.press("g" if vote else "b")
                    pressed[rater] = int(vote)
                for rater, vote in pressed.items():
                    state[rater] = _wait_moved(pages[rater], state[rater])
                    acked[rater].append(vote)
                    _check_blind(pages[rater], seen)
                step += 1
                if step == 3:  # bob takes back his last vote with U, then votes again
                    _ready(pages["bob"])
                    pages["bob"].keyboard.press("u")
                    state["bob"] = _wait_moved(pages["bob"], state["bob"])
                    acked["bob"].pop()
                if step == 5:  # alice reloads half-way: same item, same counter
                    before = state["alice"]
                    pages["alice"].reload()
                    state["alice"] = _state(pages["alice"])
                    time.sleep(0.4)
                    assert state["alice"] == before
            browser.close()
    finally:
        stop(server)
    assert seen and all(len(a) == n_items for a in acked.values())
    out = tmp_path / "ratings.csv"
    assert main(["export", str(root), "--out", str(out)]) == 0
    r = pd.read_csv(out)
    assert not r.duplicated(["rater_id", "item_id", "kind"]).any()
    for rater, votes in acked.items():
        mine = r[r["rater_id"] == rater].sort_values("voted_at", kind="stable")
        assert mine["vote"].tolist() == votes  # every acknowledged vote, once, in order
