"""Real browser (Debian Chromium via Playwright): an active pairwise study (issue 37) with two
raters at once.

Two raters (two browser contexts) have an item on screen at the same time and answer in
turn with the keys 1, 2 and 0 until both are done. Then: no answer is lost (the store holds
every press, as pressed); the two never held the same comparison at once; and each test item
a rater got was chosen from the posterior of that moment: the posterior is rebuilt
independently from the export's A/B choices of the votes cast before the item was drawn
(:func:`annotate.sampling.posterior_from_votes`), it moved between the rater's consecutive
items, and the item has the largest expected information gain
(:func:`annotate.sampling.pair_gain`) among the rater's open comparisons that the other rater
did not hold.
"""

from __future__ import annotations

import time
from datetime import datetime
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from tests.e2e.browser_support import ARGS, CHROMIUM, serve, stop, toy

pytestmark = [pytest.mark.browser,
              pytest.mark.skipif(not Path(CHROMIUM).exists(), reason="needs /usr/bin/chromium")]
T = 40000  # ms: generous waits for a loaded machine
METHODS = {"alpha": 0.5, "beta": 1.0, "gamma": 1.5}
CODE = {"1": 1, "2": 2, "0": 0}
RATERS = ("ann", "bob")


def _ready(page) -> None:
    """The answer buttons are on screen and enabled and no rerun is pending."""
    button = page.get_by_role("button", name="Can't tell")
    button.wait_for(state="visible", timeout=T)
    page.wait_for_function("(b) => !b.disabled", arg=button.element_handle(), timeout=T)
    page.wait_for_function("() => !document.querySelector('[data-stale=\"true\"]')", timeout=T)
    time.sleep(0.3)  # presses < 250 ms after drawing are dropped (the double-press rule)


WAITING = "No item is free right now"


# one read of the page once no rerun is pending: ['waiting'], ['done'], [progress, image URLs]
# (an item on screen), or null (still drawing); the state and what it shows come from the same
# moment, so a panel that redraws between two reads cannot leave a wait for a state now gone
STATE = """(w) => {
  if (document.querySelector('[data-stale="true"]')) return null;
  const text = document.body.innerText;
  if (text.includes(w)) return ['waiting'];
  if (text.includes('All done')) return ['done'];
  const p = document.querySelector('[data-testid=stProgress]');
  const imgs = Array.from(document.querySelectorAll('img'));
  if (p && imgs.length === 3) return [p.innerText, imgs.map(i => i.getAttribute('src'))];
  return null;
}"""


def _state(page) -> tuple:
    """(progress text or 'done', image URLs), or ``('waiting', ())`` while the other rater
    holds the last comparison of the budget (the page offers Retry)."""
    from playwright.sync_api import TimeoutError as PlaywrightTimeout

    try:
        got = page.wait_for_function(STATE, arg=WAITING, timeout=T).json_value()
    except PlaywrightTimeout:
        stale = page.evaluate("() => document.querySelectorAll('[data-stale=\"true\"]').length")
        imgs = page.evaluate("() => document.querySelectorAll('img').length")
        raise AssertionError(f"page not settled: {stale} stale, {imgs} images, text: "
                             f"{page.inner_text('body')[:600]!r}") from None
    if got[0] in ("waiting", "done"):
        return got[0], ()
    return got[0].strip(), tuple(got[1])


def _moved(page, old: tuple) -> tuple:
    deadline = time.time() + 60
    while time.time() < deadline:
        now = _state(page)
        if now[0] != old[0]:
            return now
        time.sleep(0.05)
    raise AssertionError(f"the page did not advance from {old[0]!r}")


def _epoch(iso: str) -> float:
    return datetime.fromisoformat(iso.replace("Z", "+00:00")).timestamp()


def _gains(study, votes: pd.DataFrame):
    """(posterior, gain per test key) of the test votes ``votes`` (export rows, in order)."""
    from annotate.sampling import pair_gain, posterior_from_votes

    tests = study.items[study.items["kind"] == "test"]
    views = list(dict.fromkeys(tests["pair_id"]))
    methods = study.manifest.methods
    post = posterior_from_votes(len(views), len(methods), [
        (views.index(tests.loc[k, "pair_id"]), methods.index(a), methods.index(b),
         {"a": 1.0, "b": 0.0, "tie": 0.5}[c])
        for k, a, b, c in votes[["item_id", "method_a", "method_b", "choice"]].itertuples(index=False)])
    g = pair_gain(post)
    i, j = np.triu_indices(len(methods), 1)
    pair = {(int(a), int(b)): p for p, (a, b) in enumerate(zip(i, j, strict=True))}
    return post, {k: g[views.index(r["pair_id"]), pair[(methods.index(r["method_a"]),
                                                        methods.index(r["method_b"]))]]
                  for k, r in tests.iterrows()}


def test_active_study_two_raters_at_once(tmp_path):
    from playwright.sync_api import sync_playwright

    from annotate.cli import main
    from annotate.study import build_study, load_study

    scene, pairs = toy("annotate_toy_active_e2e").make_toy(tmp_path, methods=METHODS)
    # 1 track x 2 frames x 2 offsets = 4 object views x 3 pairs of methods = 12 comparisons,
    # one vote each: 12 test votes to share; + 1 training, 2 gold, 1 repeat per rater
    root = build_study(tmp_path / "study", pairs, scene=str(scene), tracks=1, frames_per_track=2,
                       offsets="-1,1", n_training=1, n_gold=1, n_repeats=1, votes_per_item=1,
                       size=64, image_format="png", design="pairwise", sampling="active",
                       progress=False)
    study = load_study(root)
    rng = np.random.default_rng(0)
    pressed: dict[str, list[int]] = {r: [] for r in RATERS}
    server, url = serve(root, log=tmp_path / "server.log")
    try:
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=CHROMIUM, args=ARGS)
            pages, state = {}, {}
            for r in RATERS:  # both have an item on screen before anyone answers
                pages[r] = browser.new_context(viewport={"width": 1400, "height": 900}).new_page()
                pages[r].goto(f"{url}?rater={r}")
                pages[r].get_by_role("button", name="Start").click()
                state[r] = _state(pages[r])
            while any(s[0] != "done" for s in state.values()):
                for r in RATERS:
                    if state[r][0] == "done":
                        continue
                    if state[r][0] == "waiting":  # retry once the other rater has answered
                        pages[r].get_by_role("button", name="Retry").click()
                        time.sleep(0.5)
                        state[r] = _state(pages[r])
                        continue
                    _ready(pages[r])
                    key = str(rng.choice(list(CODE)))
                    pages[r].keyboard.press(key)
                    state[r] = _moved(pages[r], state[r])
                    pressed[r].append(CODE[key])
            browser.close()
    finally:
        stop(server)
    for r in RATERS:  # no answer lost, each as pressed
        assert study.store.votes(r)["vote"].tolist() == pressed[r], r
    out = tmp_path / "votes.csv"
    assert main(["export", str(root), "--out", str(out)]) == 0
    votes = pd.read_csv(out)
    hist = study.store.history()
    hist = hist[hist["action"] == "vote"].assign(t=lambda h: h["at"].map(_epoch))
    when = {(r, k): t for r, k, t in hist[["rater", "item", "t"]].itertuples(index=False)}
    tests = votes[votes["kind"] == "test"].copy()
    tests["t"] = [when[(r, k)] for r, k in tests[["rater_id", "item_id"]].itertuples(index=False)]
    tests = tests.sort_values("t")
    assert len(tests) == 12  # the uniform design's budget: 12 comparisons x 1 vote
    assigned = study.store.assignments()
    assigned = assigned[assigned["item"].isin(study.keys("test"))]
    claims = {r: [(k, t, when.get((r, k), np.inf)) for k, t in
                  assigned.loc[assigned["rater"] == r, ["item", "assigned_at"]].itertuples(index=False)]
              for r in RATERS}
    for r in RATERS:
        other = claims[RATERS[1 - RATERS.index(r)]]
        before = None
        for n, (key, t, _done) in enumerate(claims[r]):
            post, gain = _gains(study, tests[tests["t"] <= t])
            if before is not None:  # the posterior moved between the rater's items
                assert not (np.allclose(post.mu, before.mu) and np.allclose(post.var, before.var))
            before = post
            had = {k for k, _, _ in claims[r][:n]}
            held = {k for k, t0, t1 in other if t0 < t < t1}  # on the other rater's screen
            assert key not in held, (r, key)
            free = [k for k in study.keys("test") if k not in had and k not in held]
            assert gain[key] == pytest.approx(max(gain[k] for k in free), rel=1e-9), (r, n)
