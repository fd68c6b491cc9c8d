"""What the real-browser tests share: Chromium and its flags, the toy study, a served app.

A server runs in its own process group on 127.0.0.1 and is stopped with that group.
"""

from __future__ import annotations

import importlib.util
import os
import signal
import socket
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

__all__ = ["ARGS", "CHROMIUM", "SNAPSHOT", "toy_study", "free_port", "ready", "serve", "settled",
           "stop", "toy", "wait_moved"]

CHROMIUM = "/usr/bin/chromium"
ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
        "--disable-component-update", "--disable-sync", "--no-first-run"]

# (progress text, or 'done' once the rater is done; image URLs) read in one go
SNAPSHOT = """() => {
  const p = document.querySelector('[data-testid=stProgress]');
  const text = document.body.innerText.includes('All done') ? 'done' : (p ? p.innerText : '');
  return [text, Array.from(document.querySelectorAll('img')).map(i => i.getAttribute('src'))];
}"""


def toy(module_name: str = "annotate_toy_e2e"):
    """The toy scene + pairs maker of ``tests/annotate/toy.py``."""
    path = Path(__file__).parents[1] / "annotate" / "toy.py"
    spec = importlib.util.spec_from_file_location(module_name, path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def toy_study(tmp: Path, module_name: str, **options) -> Path:
    """``tmp/study`` built from the toy scene made in ``tmp``: one track, one frame and one
    training item unless ``options`` (more :func:`annotate.study.build_study` keywords) say
    otherwise; its root folder."""
    from annotate.study import build_study

    scene, pairs = toy(module_name).make_toy(tmp)
    options = {"tracks": 1, "frames_per_track": 1, "n_training": 1, "progress": False, **options}
    return build_study(tmp / "study", pairs, scene=str(scene), **options)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def serve(root: Path, *, log: Path | None = None, start_s: float = 60, probe_s: float = 1,
          stop_s: float = 10) -> tuple[subprocess.Popen, str]:
    """``annotate serve ROOT`` on a free local port; (process, base URL) once it answers.

    The server's stderr goes to ``log`` (or nowhere); a server that does not come up within
    ``start_s`` seconds is stopped and the test fails.
    """
    port = free_port()
    stderr = subprocess.DEVNULL if log is None else open(log, "wb")  # noqa: SIM115 (closed below)
    try:
        proc = subprocess.Popen([sys.executable, "-m", "annotate.cli", "serve", str(root), "--port",
                                 str(port)], start_new_session=True, stdout=subprocess.DEVNULL,
                                stderr=stderr)
    finally:
        if log is not None:
            stderr.close()  # the child has its own copy of the descriptor
    url = f"http://127.0.0.1:{port}/"
    deadline = time.time() + start_s
    try:
        while True:
            try:
                urllib.request.urlopen(url + "_stcore/health", timeout=probe_s)
                return proc, url
            except OSError:
                assert time.time() < deadline and proc.poll() is None, "server did not start"
                time.sleep(0.2)
    except BaseException:
        stop(proc, wait_s=stop_s)
        raise


def stop(proc: subprocess.Popen, *, wait_s: float = 10) -> None:
    """Kill the server's whole process group and reap it."""
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait(timeout=wait_s)


def settled(page, *, timeout_ms: int, images: int = 2) -> tuple[str, tuple]:
    """(progress text or 'done', image URLs) once the app has finished its rerun.

    ``images``: the crops an item shows (2; a pairwise study: 3).
    """
    page.wait_for_function(
        "(n) => !document.querySelector('[data-stale=\"true\"]') &&"
        " ((document.querySelector('[data-testid=stProgress]') &&"
        "   document.querySelectorAll('img').length === n) ||"
        "  document.body.innerText.includes('All done'))", arg=images, timeout=timeout_ms)
    text, srcs = page.evaluate(SNAPSHOT)  # one read: the panel may redraw in between
    return text.strip(), tuple(srcs)


def wait_moved(page, old: tuple, *, timeout_s: float = 40) -> tuple:
    """The page's :func:`settled` state once its progress text differs from ``old``'s."""
    deadline = time.time() + timeout_s
    while time.time() < deadline:
        now = settled(page, timeout_ms=40000)
        if now[0] != old[0]:
            time.sleep(0.4)  # let the rerun finish rendering (the app drops presses < 250 ms)
            return settled(page, timeout_ms=40000)
        time.sleep(0.05)
    raise AssertionError(f"the page did not advance from {old[0]!r}")


def ready(page, names=("Good", "Bad")) -> None:
    """Wait until the vote buttons ``names`` of the current item are rendered and enabled.

    A shortcut key pressed while Streamlit is still re-rendering can be lost on a loaded
    machine, so a test never presses before the buttons can take it.
    """
    for name in names:
        button = page.get_by_role("button", name=name)
        button.wait_for(state="visible", timeout=30000)
        page.wait_for_function("(b) => !b.disabled", arg=button.element_handle(), timeout=30000)
