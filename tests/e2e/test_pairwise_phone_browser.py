"""Real browser (Debian Chromium via Playwright): the pairwise rater page on a phone
(390 x 844, touch). The reference is on top and the two renders, titled as the left and the
right choice, sit side by side under it, all three at one size; the answer buttons are in a
bar at the bottom of the screen (where a thumb reaches) that covers no crop; nothing is
wider than the screen; and a tap on "Right is closer" stores that answer."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from tests.e2e.browser_support import ARGS, CHROMIUM, serve, settled, stop, toy

pytestmark = [pytest.mark.browser,
              pytest.mark.skipif(not Path(CHROMIUM).exists(), reason="needs /usr/bin/chromium")]
T = 40000
W, H = 390, 844
#: the lowest part of the screen a thumb reaches holding a phone in one hand
THUMB_ZONE = 0.4

BOXES = """() => {
  const box = (e) => { const r = e.getBoundingClientRect(); return [r.x, r.y, r.width, r.height]; };
  const imgs = Array.from(document.querySelectorAll('.st-key-pair img')).map(box);
  const titles = Array.from(document.querySelectorAll('.st-key-pair [data-testid=stImageCaption]'))
    .map(c => [c.innerText.trim(), ...box(c)]);
  const buttons = Array.from(document.querySelectorAll('button')).filter(b => b.offsetParent
    && /closer|tell|Undo/.test(b.innerText)).map(b => [b.innerText.split('\\n')[0].trim(), ...box(b)]);
  return {imgs, titles, buttons, scroll_w: document.documentElement.scrollWidth};
}"""


def test_on_a_phone_the_reference_is_on_top_of_two_labelled_choices_and_buttons_at_the_bottom(tmp_path):
    from playwright.sync_api import sync_playwright

    from annotate.study import build_study, load_study

    scene, pairs = toy("annotate_toy_pairwise_phone").make_toy(tmp_path, methods={"zebrafish": 0.5, "quokka": 1.5})
    root = build_study(tmp_path / "study", pairs, scene=str(scene), tracks=1, frames_per_track=1,
                       offsets="-1,1", n_training=1, n_gold=0, n_repeats=0, size=64, image_format="png",
                       design="pairwise", progress=False)
    server, url = serve(root)
    try:
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=CHROMIUM, args=ARGS)
            page = browser.new_page(viewport={"width": W, "height": H}, is_mobile=True, has_touch=True,
                                    device_scale_factor=2)
            page.goto(f"{url}?rater=thumb")
            page.get_by_role("button", name="Start").click()
            first = settled(page, timeout_ms=T, images=3)
            page.wait_for_function("() => Array.from(document.querySelectorAll('img'))"
                                   ".every(i => i.naturalWidth > 0)", timeout=T)
            time.sleep(0.6)
            got = page.evaluate(BOXES)
            page.screenshot(path=str(tmp_path / "phone.png"))
            button = page.get_by_role("button", name="Right is closer")
            page.wait_for_function("(b) => !b.disabled", arg=button.element_handle(), timeout=T)
            time.sleep(0.4)  # presses < 250 ms after drawing are dropped
            button.tap()
            page.wait_for_function("(old) => { const p = document.querySelector('[data-testid=stProgress]');"
                                   " return (p && p.innerText.trim() !== old) || document.body.innerText.includes('All done'); }",
                                   arg=first[0], timeout=T)
            browser.close()
    finally:
        stop(server)
    (lx, ly, lw, lh), (cx, cy, cw, ch), (rx, ry, rw, rh) = got["imgs"]  # page order: left, reference, right
    assert {round(v) for v in (lw, rw, cw)} == {round(lw)} and lw >= 0.4 * W, got["imgs"]  # one size
    assert cy + ch <= min(ly, ry), got["imgs"]  # the reference on top
    assert abs(ly - ry) <= 1 and lx + lw <= rx, got["imgs"]  # the choices side by side under it
    assert lx < cx + cw / 2 < rx + rw  # the reference centred over the choices
    titles = {t[0]: t[1:] for t in got["titles"]}
    assert set(titles) == {"Left choice", "Reference (real photo)", "Right choice"}, titles
    assert titles["Left choice"][0] < titles["Right choice"][0]
    assert titles["Reference (real photo)"][1] < cy < titles["Left choice"][1] < ly
    bottom = max(i[1] + i[3] for i in got["imgs"])
    for name, x, y, w, h in got["buttons"]:
        assert 0 <= x and x + w <= W and y + h <= H, (name, got["buttons"])
        assert y >= (1 - THUMB_ZONE) * H and y >= bottom, (name, y, bottom)  # in thumb reach, over no crop
        assert h >= 44, (name, h)  # a touch target (Apple's and Google's guidelines: 44-48 px)
    sides = {n.split(" ")[0]: x for n, x, *_ in got["buttons"]}
    assert sides["◀"] < sides["Right"], sides
    assert got["scroll_w"] == W
    votes = load_study(root).store.votes("thumb")
    assert votes["vote"].tolist() == [2]  # right is closer
