"""Process tests of ``annotate serve``: it owns its server, refuses a busy port, and a server
refuses to record into a study rebuilt under it (``export`` reports votes it cannot place).

The server is driven at the websocket level by the client of ``benchmarks/bench_raters.py``
(Streamlit's own protobuf messages, as a browser sends them).
"""

from __future__ import annotations

import asyncio
import importlib.util
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

_spec = importlib.util.spec_from_file_location(
    "bench_raters_for_tests", Path(__file__).parents[2] / "benchmarks" / "bench_raters.py")
bench = importlib.util.module_from_spec(_spec)
sys.modules[_spec.name] = bench  # dataclasses look their module up there
_spec.loader.exec_module(bench)


def _listening(port: int) -> bool:
    with socket.socket() as s:
        s.settimeout(1)
        return s.connect_ex(("127.0.0.1", port)) == 0


def _group_alive(pgid: int) -> bool:
    try:
        os.killpg(pgid, 0)
        return True
    except ProcessLookupError:
        return False


@pytest.fixture
def small_study(make_study):
    return make_study(n_training=1)


@pytest.mark.parametrize("workers", [1, 2], ids=["one-process", "two-workers"])
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGKILL], ids=["SIGTERM", "SIGKILL"])
def test_signal_to_serve_leaves_nothing_listening(small_study, sig, workers):
    """A signal to the `annotate serve` process alone (SIGKILL included) stops every server:
    with --workers, its supervised workers too (annotate.workers)."""
    port = bench.free_ports(workers)
    proc = bench.start_server(small_study.root, port, workers=workers)
    ports = range(port, port + workers)
    try:
        assert all(_listening(p) for p in ports)
        os.kill(proc.pid, sig)  # only the `annotate serve` process itself, not its group
        proc.wait(timeout=30)
        deadline = time.time() + 30
        while any(_listening(p) for p in ports) or _group_alive(proc.pid):
            assert time.time() < deadline, "a server outlived `annotate serve`"
            time.sleep(0.2)
    finally:
        if _group_alive(proc.pid):
            os.killpg(proc.pid, signal.SIGKILL)


def test_busy_port_is_one_line_and_non_zero(small_study):
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        r = subprocess.run([sys.executable, "-m", "annotate.cli", "serve", str(small_study.root),
                            "--port", str(port)], capture_output=True, text=True, timeout=60)
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2 and len(lines) == 1, r.stderr
    assert "--port" in lines[0] and str(port) in lines[0] and "Traceback" not in r.stderr


def test_server_refuses_a_study_rebuilt_under_it_and_export_reports_foreign_votes(
        small_study, toy_inputs, tmp_path, capsys):
    from annotate.cli import main
    from annotate.store import Store
    from annotate.study import build_study, load_study, unplaced_votes

    root = small_study.root
    port = bench.free_port()
    proc = bench.start_server(root, port)
    try:
        async def session():
            c = bench.RaterClient(f"http://127.0.0.1:{port}/")
            screen = await c.open("rater=kim")
            screen = await c.press("Start")
            first = screen.vote_id()
            await asyncio.sleep(0.3)  # a rater looks first (the app drops presses < 100 ms)
            screen = await c.press("Good")  # recorded in the original study
            assert screen.vote_id() != first
            scene, pairs = toy_inputs
            shutil.rmtree(root)
            build_study(root, pairs, scene=str(scene), tracks=2, frames_per_track=2,
                        n_training=1, size=64, progress=False)
            load_study(root)  # e.g. the organiser looks at it: the new votes.sqlite exists
            await asyncio.sleep(0.3)
            screen = await c.press("Good")
            await c.close()
            return screen

        screen = asyncio.run(session())
    finally:
        bench.stop_server(proc)
    assert any("changed on the server" in t for t in screen.texts), screen.texts
    new = load_study(root)
    assert new.store.votes().empty and unplaced_votes(new) == {}
    # a vote that did land under another study id (an older server) is reported by export
    Store(root / "votes.sqlite", "old-study-0000").record_vote("kim", "x", 1)
    out = tmp_path / "ratings.csv"
    assert main(["export", str(root), "--out", str(out)]) == 0
    err = capsys.readouterr().err
    assert "1 vote not exported" in err and "another study id" in err, err  # singular (issue 38 item 17)
