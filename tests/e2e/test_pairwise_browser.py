"""Real browser (Debian Chromium via Playwright): the pairwise rater page (docs/FORMATS.md §12).

One rater answers every item with the keys 1, left arrow, 2, right arrow and 0, takes one
answer back with U, reloads half-way (same item, same images, same counter) and finishes.
Then: the stored answers are the keys pressed; each screen's left and right crops are the
item's A and B crops on the sides the export's ``side_a`` says; a repeat shows A on the
other side than its original; and no method name appears anywhere in the page's HTML or its
URLs at any step.
"""

from __future__ import annotations

import time
from pathlib import Path

import cv2
import numpy as np
import pandas as pd
import pytest

from tests.e2e.browser_support import ARGS, CHROMIUM, serve, settled, stop, toy

pytestmark = [pytest.mark.browser,
              pytest.mark.skipif(not Path(CHROMIUM).exists(), reason="needs /usr/bin/chromium")]
T = 40000  # ms: generous waits for a loaded machine
METHODS = {"zebrafish": 0.5, "quokka": 1.5}  # names that occur nowhere else in a page
SECRETS = (*METHODS, "toy:", "trk-", "|gt|")
CODE = {"1": 1, "ArrowLeft": 1, "2": 2, "ArrowRight": 2, "0": 0}
IMAGES = """() => Array.from(document.querySelectorAll('img')).map(i => i.src)"""


def _state(page) -> tuple[str, tuple]:
    return settled(page, timeout_ms=T, images=3)


def _ready(page) -> None:
    """The answer buttons are on screen and enabled and no rerun is pending."""
    button = page.get_by_role("button", name="Can't tell")
    button.wait_for(state="visible", timeout=T)
    page.wait_for_function("(b) => !b.disabled", arg=button.element_handle(), timeout=T)
    page.wait_for_function("() => !document.querySelector('[data-stale=\"true\"]')", timeout=T)
    time.sleep(0.3)  # presses < 250 ms after drawing are dropped (the double-press rule)


def _moved(page, old: tuple) -> tuple:
    deadline = time.time() + 40
    while time.time() < deadline:
        now = _state(page)
        if now[0] != old[0]:
            return now
        time.sleep(0.05)
    raise AssertionError(f"the page did not advance from {old[0]!r}")


def _pixels(page) -> list[np.ndarray]:
    """The three crops on screen (left, reference, right), decoded from their URLs."""
    out = []
    for src in page.evaluate(IMAGES):
        body = page.request.get(src).body()
        out.append(cv2.imdecode(np.frombuffer(body, np.uint8), cv2.IMREAD_COLOR))
    return out


def _check_layout(page) -> None:
    """Three crops of one size side by side, the four visible buttons in one row under them."""
    page.wait_for_function("() => Array.from(document.querySelectorAll('img'))"
                           ".every(i => i.naturalWidth > 0)", timeout=T)
    imgs, buttons = page.evaluate("""() => {
      const box = (e) => { const r = e.getBoundingClientRect(); return [r.x, r.y, r.width, r.height]; };
      return [Array.from(document.querySelectorAll('img')).map(box),
              Array.from(document.querySelectorAll('button')).filter(b => b.offsetParent
                && /closer|tell|Undo/.test(b.innerText)).map(box)];
    }""")
    assert len(imgs) == 3 and len(buttons) == 4, (imgs, buttons)
    assert max(i[2] for i in imgs) - min(i[2] for i in imgs) <= 1 and imgs[0][2] >= 300
    assert max(i[1] for i in imgs) - min(i[1] for i in imgs) <= 1
    assert imgs[0][0] < imgs[1][0] < imgs[2][0]
    assert max(b[1] for b in buttons) - min(b[1] for b in buttons) <= 1
    assert buttons[0][1] >= imgs[0][1] + imgs[0][3] and buttons[0][1] + buttons[0][3] <= 900


def _check_blind(page) -> None:
    html = page.content() + " ".join(page.evaluate(IMAGES)) + page.url
    for secret in SECRETS:
        assert secret not in html, secret


def test_pairwise_page_keys_undo_reload_swapped_repeat_and_no_method_name(tmp_path):
    from playwright.sync_api import sync_playwright

    from annotate.cli import main
    from annotate.study import build_study, load_study

    scene, pairs = toy("annotate_toy_pairwise_e2e").make_toy(tmp_path, methods=METHODS)
    # offsets +-1 (at 0 both methods' renders are the GT image): 1 training + 1 track x
    # 1 frame x 2 offsets x 1 pair of methods + 2 gold + 1 repeat = 6 items
    root = build_study(tmp_path / "study", pairs, scene=str(scene), tracks=1, frames_per_track=1,
                       offsets="-1,1", n_training=1, n_gold=1, n_repeats=1, size=64,
                       image_format="png", design="pairwise", progress=False)
    study = load_study(root)
    assert len(study.items) == 6
    keys = ["1", "ArrowLeft", "2", "ArrowRight", "0"]
    screens: list[list[np.ndarray]] = []  # per answer that stands: what was on screen
    pressed: list[int] = []
    server, url = serve(root)
    try:
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=CHROMIUM, args=ARGS)
            page = browser.new_page(viewport={"width": 1400, "height": 900})
            page.goto(f"{url}?rater=pia")
            _check_blind(page)
            page.get_by_role("button", name="Start").click()
            state = _state(page)
            _check_layout(page)
            step = 0
            while state[0] != "done":
                _ready(page)
                _check_blind(page)
                shown = _pixels(page)
                key = keys[step % len(keys)]
                page.keyboard.press(key)
                state = _moved(page, state)
                screens.append(shown)
                pressed.append(CODE[key])
                step += 1
                if step == 2:  # take the last answer back: the same item comes back
                    _ready(page)
                    page.keyboard.press("u")
                    state = _moved(page, state)
                    screens.pop()
                    pressed.pop()
                    _ready(page)  # the counter moves before the rerun has redrawn the images
                    again = _pixels(page)
                    assert all(np.array_equal(a, b) for a, b in zip(again, shown, strict=True))
                if step == 4:  # reload: same item, same images, same counter
                    _ready(page)  # as at step 2: the counter moves before the images are redrawn
                    before = _state(page)
                    page.reload()
                    state = _state(page)
                    assert state == before
            browser.close()
    finally:
        stop(server)
    assert len(screens) == len(study.items)
    votes = tmp_path / "votes.csv"
    assert main(["export", str(root), "--out", str(votes)]) == 0
    v = pd.read_csv(votes).sort_values("voted_at", kind="stable").reset_index(drop=True)
    standing = study.store.votes("pia")  # in the order voted
    order = standing["item"].tolist()
    assert standing["vote"].tolist() == pressed  # every answer is the key pressed
    crops = {}
    for k, shown in zip(order, screens, strict=True):
        item = study.items.loc[k]
        a, b, ref = (cv2.imread(str(root / "crops" / item[c])) for c in ("a_file", "b_file", "ref_file"))
        side = v.loc[(v["item_id"] == item["item_id"]) & (v["kind"] == item["kind"]), "side_a"].item()
        left, right = (a, b) if side == "left" else (b, a)
        assert np.array_equal(shown[0], left) and np.array_equal(shown[2], right)
        assert np.array_equal(shown[1], ref)
        crops[k] = shown
    rep = study.keys("repeat")[0]
    orig = rep.split(":", 1)[1]
    # the repeat's own crops (cut with its boxes moved, annotate.crops.draw_shift) were shown
    # above on its A side; A sits on the other side than for its original
    sides = v.set_index("kind").loc[["repeat", "test"]].reset_index()
    sides = sides[sides["item_id"] == study.items.loc[orig, "item_id"]].set_index("kind")["side_a"]
    assert sides["repeat"] != sides["test"]
    assert not np.array_equal(crops[orig][0], crops[orig][2])  # 0.5 vs 1.5 x the blur: visible
