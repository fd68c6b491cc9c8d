"""Real browser (Debian Chromium via Playwright): a crowd study as a panel's participants see it.

Two participants arrive through the panel's link (``?PROLIFIC_PID=...``); each gets its own
identity in the address, which no longer names the participant. One reloads half-way and
continues at the same item; coming back later through the panel's link (a new browser
context) resumes the same identity too. The first finishes and is shown the completion link.
The store then holds each participant's acknowledged votes under its own rater, and no page
text, address or image URL names an item, offset, clip, track or item kind.
"""

from __future__ import annotations

import time
from pathlib import Path
from urllib.parse import parse_qs, urlsplit

import pytest

from tests.e2e.browser_support import ARGS, CHROMIUM, ready, serve, settled, stop, toy, wait_moved

pytestmark = [pytest.mark.browser,
              pytest.mark.skipif(not Path(CHROMIUM).exists(), reason="needs /usr/bin/chromium")]
SECRETS = ("+1.00", "-1.00", "+0.00", "offset", "toy", "trk-", "front", "gold", "repeat", "psnr",
           "training")
DONE_URL = "https://app.prolific.com/submissions/complete?cc=C0DE1"
PIDS = {"p1": "5f3a0c0ffee0000000000001", "p2": "5f3a0c0ffee0000000000002"}


def _arrive(browser, url: str, who: str):
    """A fresh browser context opening the panel's link of participant ``who``."""
    page = browser.new_context().new_page()
    page.goto(f"{url}?PROLIFIC_PID={PIDS[who]}&STUDY_ID=st1&SESSION_ID=se-{who}")
    page.wait_for_function("() => location.search.includes('token=')", timeout=40000)
    return page


def _token(page) -> str:
    query = parse_qs(urlsplit(page.url).query)
    # the address carries the identity and, since issue 38 (nothing stored before the first
    # vote), the panel's id, so a reload before that vote still records it; nothing else
    assert set(query) == {"token", "PROLIFIC_PID"}, page.url
    return query["token"][0]


def _check_blind(page) -> None:
    text = page.inner_text("body")
    urls = " ".join([page.url] + [img.get_attribute("src") or "" for img in page.locator("img").all()])
    for secret in SECRETS:
        assert secret not in text and secret not in urls, secret


def _vote(page, state: tuple, key: str = "g") -> tuple:
    ready(page)
    page.keyboard.press(key)
    state = wait_moved(page, state)
    _check_blind(page)
    return state


def test_crowd_arrival_reload_two_participants_and_completion(tmp_path):
    from playwright.sync_api import sync_playwright

    from annotate.study import build_study, load_study

    scene, pairs = toy().make_toy(tmp_path)
    # 1 training + 1 track x 2 frames x 3 offsets + 2 gold + 1 repeat = 10 items per rater
    root = build_study(tmp_path / "study", pairs, scene=str(scene), tracks=1, frames_per_track=2,
                       n_training=1, n_gold=1, n_repeats=1, size=64, progress=False,
                       access="crowd", participant_param="PROLIFIC_PID", completion_url=DONE_URL)
    built = load_study(root)  # a rater's share: 2 of the 6 gold of the pool (issue 38 item 31)
    n_items = len(built.items) - len(built.keys("gold")) + built.gold_per_rater
    assert n_items == 10
    server, url = serve(root)
    acked = {"p1": 0, "p2": 0}
    try:
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=CHROMIUM, args=ARGS)
            pages = {who: _arrive(browser, url, who) for who in PIDS}
            tokens = {who: _token(p) for who, p in pages.items()}
            assert tokens["p1"] != tokens["p2"] and all(len(t) * 6 >= 128 for t in tokens.values())
            state = {}
            for who, page in pages.items():
                page.get_by_role("button", name="Start").click()
                state[who] = settled(page, timeout_ms=40000)
                _check_blind(page)
            time.sleep(0.4)  # participants look before they press (presses < 250 ms are dropped)
            for _ in range(3):
                for who in PIDS:
                    state[who] = _vote(pages[who], state[who], "g" if acked[who] % 2 else "b")
                    acked[who] += 1
            # a reload resumes: same item (same images), same counter, same identity
            before = state["p1"]
            pages["p1"].reload()
            assert settled(pages["p1"], timeout_ms=40000) == before and _token(pages["p1"]) == tokens["p1"]
            # p2 comes back later through the panel's link, in a new browser: the same rater
            pages["p2"].context.close()
            pages["p2"] = _arrive(browser, url, "p2")
            assert _token(pages["p2"]) == tokens["p2"]
            assert settled(pages["p2"], timeout_ms=40000) == state["p2"]
            time.sleep(0.4)
            while state["p1"][0] != "done":  # p1 finishes: the completion link is offered
                state["p1"] = _vote(pages["p1"], state["p1"])
                acked["p1"] += 1
            link = pages["p1"].get_by_role("link", name="Finish and return to the panel")
            link.wait_for(state="visible", timeout=30000)
            assert link.get_attribute("href") == DONE_URL
            browser.close()
    finally:
        stop(server)
    study = load_study(root)
    who_is = study.store.participants().set_index("participant")["rater"]
    assert len(who_is) == 2
    for who, pid in PIDS.items():
        assert len(study.store.votes(who_is[pid])) == acked[who]
    assert acked["p1"] == n_items
