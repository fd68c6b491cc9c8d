"""Real browser (Debian Chromium via Playwright): ``annotate rate-yourself DEMO`` end to end.

A demo-like folder (a study of the toy scene with three simulated raters, its pairs table) is
rated in the browser through the command the demo prints: it serves the small study on
127.0.0.1, the rater types a name and votes on every item with the keyboard, the command stops
the server by itself and prints the agreement, which must equal the agreement worked out here
from the two vote stores with pandas.
"""

from __future__ import annotations

import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import pandas as pd
import pytest

from tests.e2e.browser_support import ARGS, CHROMIUM, free_port, settled, toy
from tests.e2e.browser_support import ready as _ready
from tests.e2e.browser_support import wait_moved as _wait_moved

pytestmark = [pytest.mark.browser,
              pytest.mark.skipif(not Path(CHROMIUM).exists(), reason="needs /usr/bin/chromium")]


def test_rate_yourself_serves_the_items_and_prints_the_agreement(tmp_path):
    from playwright.sync_api import sync_playwright

    from annotate.simulate import simulate
    from annotate.study import build_study, load_study

    demo = tmp_path / "demo"
    scene, pairs = toy("annotate_toy_rate_yourself").make_toy(demo)  # demo/scene, demo/pairs.csv
    root = build_study(demo / "study", pairs, scene=str(scene), tracks=4, frames_per_track=6, n_training=1,
                       n_gold=1, n_repeats=1, size=64, items_per_rater=None, progress=False)
    simulate(load_study(root), raters=3, seed=0, progress=False)
    port = free_port()
    proc = subprocess.Popen([sys.executable, "-m", "annotate.cli", "rate-yourself", str(demo), "--items", "8",
                             "--port", str(port)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    url = f"http://127.0.0.1:{port}/"
    try:
        deadline = time.time() + 90
        while True:
            try:
                urllib.request.urlopen(url + "_stcore/health", timeout=1)
                break
            except OSError:
                assert time.time() < deadline and proc.poll() is None, proc.stderr.read()
                time.sleep(0.3)
        own = load_study(demo / "yourself")
        n_items = len(own.items)
        # the whole frames nearest 8 items: 3 frames of the toy's 3 views; no training, gold or repeats
        assert n_items == 9 and set(own.items["kind"]) == {"test"} and own.items["track_id"].nunique() == 3
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=CHROMIUM, args=ARGS)
            page = browser.new_context().new_page()
            page.goto(f"{url}?rater=me")
            page.get_by_role("button", name="Start").click()
            state = settled(page, timeout_ms=40000)
            time.sleep(0.4)
            body = page.inner_text("body")
            for word in ("Prolific", "completion code", "panel"):  # no crowd wording
                assert word.lower() not in body.lower(), word
            pressed = 0
            while state[0] != "done":
                _ready(page)
                page.keyboard.press("g" if pressed % 3 else "b")
                state = _wait_moved(page, state)
                pressed += 1
            browser.close()
        out, err = proc.communicate(timeout=60)  # it stops the server and ends by itself
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 0, err
    assert pressed == n_items
    assert f"Open {url} in your browser" in out
    # the agreement, worked out here from the two stores
    mine = own.store.votes()
    sim = load_study(root).store.votes()
    sim = sim[sim["rater"].str.startswith("sim-") & sim["item"].isin(mine["item"])]
    share = sim.groupby("item")["vote"].mean()
    major = share[share != 0.5].round().astype(int)
    own_votes = mine.set_index("item")["vote"]
    agree = int((own_votes.loc[major.index] == major).sum())
    assert f"You rated {n_items} items that 3 simulated raters rated too." in out, out
    assert f"Your vote agrees with their majority on {agree} of {len(major)} items" in out, out
    each = sum((own_votes.loc[g["item"]].to_numpy() == g["vote"].to_numpy()).mean()
               for _, g in sim.groupby("rater")) / 3
    assert f"You agree with each simulated rater on {100 * each:.0f}% of these items on average." in out, out
    assert pd.notna(share).all()
