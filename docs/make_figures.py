"""Regenerate the README's figures from a finished ``nvrq demo OUT`` folder.

Usage: ``python docs/make_figures.py OUT`` (needs Debian's Chromium at /usr/bin/chromium).
Writes ``docs/rater_ui.png`` (the rater app at 1400x900, signed in, first training item),
copies ``OUT/report/tent.png`` to ``docs/tent.png`` and writes ``docs/img/report-1280x800.png``
and ``docs/img/report-390x844.png`` (``OUT/report/report.html`` in a desktop and a phone
window, at its "Metrics against GVF" table; on the phone scrolled sideways). ``python docs/make_figures.py STUDY`` (a study
folder, e.g. ``OUT/study``) writes ``docs/rater_ui.png`` only.
"""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

from annotate.commands.serve import serve_command

ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
        "--disable-component-update", "--disable-sync", "--no-first-run"]
DOCS = Path(__file__).resolve().parent


def main(out: Path) -> None:
    if (out / "manifest.json").is_file():  # a study folder: the rater UI only
        rater_ui(out)
        return
    shutil.copyfile(out / "report" / "tent.png", DOCS / "tent.png")
    rater_ui(out / "study")
    report_shots(out / "report" / "report.html")
    print(f"wrote {DOCS / 'tent.png'}")


#: the windows the report is shown in: a desktop and a phone (CSS pixels)
REPORT_SIZES = [(1280, 800), (390, 844)]


def report_shots(report: Path) -> list[Path]:
    """``docs/img/report-WxH.png`` of ``report`` (a report.html) for each of :data:`REPORT_SIZES`,
    scrolled to its "Metrics against GVF" table (PNG, 8-bit palette: a small file)."""
    from PIL import Image
    from playwright.sync_api import sync_playwright

    (DOCS / "img").mkdir(exist_ok=True)
    written = []
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path="/usr/bin/chromium", args=ARGS)
        for width, height in REPORT_SIZES:
            page = browser.new_page(viewport={"width": width, "height": height})
            page.goto(report.resolve().as_uri())
            heading = page.locator("h2", has_text="Metrics against").first
            if width >= 600:
                heading.evaluate("h => h.scrollIntoView()")
            else:  # a phone: the table itself, scrolled sideways (its first column stays)
                heading.evaluate("h => { let e = h.nextElementSibling; while (!e.matches('.scroll'))"
                                 " e = e.nextElementSibling; e.scrollIntoView(); e.scrollLeft = 240; }")
            path = DOCS / "img" / f"report-{width}x{height}.png"
            page.screenshot(path=str(path))
            Image.open(path).convert("RGB").quantize(colors=128).save(path, optimize=True)
            written.append(path)
            page.close()
        browser.close()
    for path in written:
        print(f"wrote {path}")
    return written


def rater_ui(study: Path) -> None:
    """``docs/rater_ui.png``: the first training item of ``study`` at 1400x900."""
    from playwright.sync_api import sync_playwright

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    env = dict(os.environ, ANNOTATE_STUDY=str(study.resolve()))
    server = subprocess.Popen(serve_command(study, port=port), env=env, start_new_session=True,
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    url = f"http://127.0.0.1:{port}/"
    try:
        for _ in range(300):
            try:
                urllib.request.urlopen(url + "_stcore/health", timeout=1)
                break
            except OSError:
                time.sleep(0.2)
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path="/usr/bin/chromium", args=ARGS)
            page = browser.new_page(viewport={"width": 1400, "height": 900})
            page.goto(f"{url}?rater=readme")
            page.get_by_role("button", name="Start").click()
            page.get_by_role("button", name="Good").wait_for(state="visible", timeout=30000)
            page.wait_for_function("document.querySelectorAll('img').length === 2", timeout=30000)
            page.mouse.move(0, 0)  # no hover effects in the figure
            time.sleep(1.0)  # the scale line follows the drawn size within 200 ms
            page.screenshot(path=str(DOCS / "rater_ui.png"))
            browser.close()
    finally:
        os.killpg(server.pid, signal.SIGKILL)
    print(f"wrote {DOCS / 'rater_ui.png'}")


if __name__ == "__main__":
    main(Path(sys.argv[1]))
