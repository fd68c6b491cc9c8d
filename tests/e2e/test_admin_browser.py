"""Real browser: the admin page refreshes by itself.

Tab A shows the admin page; tab B (another browser context) signs in as a rater and votes.
The vote must appear on tab A (its live caption counts the votes) without tab A being
reloaded or touched.
"""

from __future__ import annotations

import re
import time
from pathlib import Path

import pytest

from tests.e2e.browser_support import ARGS, CHROMIUM, serve, stop, toy

pytestmark = [pytest.mark.browser,
              pytest.mark.skipif(not Path(CHROMIUM).exists(), reason="needs /usr/bin/chromium")]


def _votes_shown(page) -> int:
    page.wait_for_function("() => /\\d+ votes?\\./.test(document.body.innerText)", timeout=30000)  # 1 vote (issue 38)
    return int(re.search(r"(\d+) votes?\.", page.inner_text("body")).group(1))


def test_vote_in_one_tab_appears_on_admin_page_without_reload(tmp_path):
    from playwright.sync_api import sync_playwright

    from annotate.study import build_study, load_study

    scene, pairs = toy().make_toy(tmp_path)
    study = load_study(build_study(tmp_path / "study", pairs, scene=str(scene), tracks=1,
                                   frames_per_track=2, n_training=0, n_gold=1, n_repeats=1,
                                   size=64, progress=False))
    server, url = serve(study.root)
    try:
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=CHROMIUM, args=ARGS)
            admin = browser.new_context().new_page()
            admin.goto(f"{url}?admin={study.admin_token()}")
            assert _votes_shown(admin) == 0
            rater = browser.new_context().new_page()
            rater.goto(f"{url}?rater=ann")
            rater.get_by_role("button", name="Start").click()
            good = rater.get_by_role("button", name="Good")
            good.wait_for(state="visible", timeout=30000)
            time.sleep(0.4)  # the app drops presses within ANNOTATE_MIN_RESPONSE_MS (250) of drawing
            good.click()
            deadline = time.time() + 30
            while len(study.store.votes()) != 1:  # the vote is stored; now the admin tab must show it
                assert time.time() < deadline, "the vote was not recorded"
                time.sleep(0.1)
            deadline = time.time() + 30  # a few refresh periods (annotate.admin.REFRESH_S)
            while _votes_shown(admin) != 1:
                assert time.time() < deadline, "the admin page did not refresh by itself"
                time.sleep(0.25)
            assert "ann" not in admin.url
            browser.close()
    finally:
        stop(server)
    assert len(study.store.votes()) == 1
