"""Regenerate the README's figures from a finished ``nvrq demo OUT`` folder.

Usage: ``python docs/make_figures.py OUT`` (needs Debian's Chromium at /usr/bin/chromium).
Writes ``docs/rater_ui.png`` (the rater app, signed in, first training item) and copies
``OUT/report/tent.png`` to ``docs/tent.png``.
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

from annotate.cli import serve_command

ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
        "--disable-component-update", "--disable-sync", "--no-first-run"]
DOCS = Path(__file__).resolve().parent


def main(out: Path) -> None:
    from playwright.sync_api import sync_playwright

    shutil.copyfile(out / "report" / "tent.png", DOCS / "tent.png")
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    env = dict(os.environ, ANNOTATE_STUDY=str((out / "study").resolve()))
    server = subprocess.Popen(serve_command(out / "study", port=port), env=env, start_new_session=True,
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
            page = browser.new_page(viewport={"width": 1100, "height": 760})
            page.goto(f"{url}?rater=readme")
            page.get_by_role("button", name="Start").click()
            page.get_by_role("button", name="Good (G)").wait_for(state="visible", timeout=30000)
            page.wait_for_function("document.querySelectorAll('img').length === 2", timeout=30000)
            time.sleep(1.0)
            page.screenshot(path=str(DOCS / "rater_ui.png"))
            browser.close()
    finally:
        os.killpg(server.pid, signal.SIGKILL)
    print(f"wrote {DOCS / 'rater_ui.png'} and {DOCS / 'tent.png'}")


if __name__ == "__main__":
    main(Path(sys.argv[1]))
