"""A dead ``annotate serve --workers K`` worker is started again; the others go on serving.

First with stand-in workers (a script that writes its pid and sleeps) under the real
supervisor in a process of its own, then with the real servers: a worker killed with
SIGKILL comes back on its port, the other worker is the same process all along, and every
acknowledged vote is in the store. Servers run in their own process group and are stopped
with it.
"""

from __future__ import annotations

import asyncio
import importlib.util
import os
import signal
import subprocess
import sys
import textwrap
import time
import urllib.request
from pathlib import Path

_spec = importlib.util.spec_from_file_location(
    "bench_raters_for_restart_tests", Path(__file__).parents[2] / "benchmarks" / "bench_raters.py")
bench = importlib.util.module_from_spec(_spec)
sys.modules[_spec.name] = bench
_spec.loader.exec_module(bench)

_toy_spec = importlib.util.spec_from_file_location("annotate_toy_restart", Path(__file__).with_name("toy.py"))
toy = importlib.util.module_from_spec(_toy_spec)
_toy_spec.loader.exec_module(toy)


def _wait(cond, timeout=60.0, what="condition"):
    deadline = time.time() + timeout
    while not cond():
        assert time.time() < deadline, f"timed out waiting for {what}"
        time.sleep(0.1)


def _pid(path: Path) -> int | None:
    try:
        return int(path.read_text())
    except (OSError, ValueError):
        return None


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    try:  # a zombie is dead
        return (Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]) != "Z"
    except OSError:
        return False


def test_a_killed_worker_is_restarted_and_the_restarts_are_bounded(tmp_path):
    worker = ("import os, sys, time; open(sys.argv[1] + '.tmp', 'w').write(str(os.getpid())); "
              "os.replace(sys.argv[1] + '.tmp', sys.argv[1]); time.sleep(600)")
    files = [tmp_path / "a.pid", tmp_path / "b.pid"]
    script = textwrap.dedent(f"""
        import sys
        from annotate.workers import supervise
        argvs = [[sys.executable, "-c", {worker!r}, f] for f in {[str(f) for f in files]!r}]
        sys.exit(supervise(argvs, env=None, poll_s=0.05, grace_s=5, names=["A", "B"],
                           max_restarts=1, min_uptime_s=0.3))
    """)
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).parents[2])}
    sup = subprocess.Popen([sys.executable, "-c", script], env=env, start_new_session=True,
                           stderr=subprocess.PIPE, text=True)
    try:
        _wait(lambda: all(_pid(f) for f in files), what="both workers")
        a, b = _pid(files[0]), _pid(files[1])
        time.sleep(0.5)  # past min_uptime_s
        os.kill(a, signal.SIGKILL)
        _wait(lambda: _pid(files[0]) not in (None, a), what="worker A restarted")
        a2 = _pid(files[0])
        assert _alive(a2) and _alive(b) and _pid(files[1]) == b  # B untouched
        time.sleep(0.5)
        os.kill(a2, signal.SIGKILL)  # the restart is spent: everything stops
        assert sup.wait(timeout=30) == 128 + signal.SIGKILL
        err = sup.stderr.read().strip().splitlines()
        assert err[0].startswith("annotate serve: A was killed by SIGKILL after") and \
            err[0].endswith("restarting it (restart 1 of 1)"), err
        assert err[-1] == ("annotate serve: A was killed by SIGKILL (its restarts are spent: 1); "
                           "stopping every worker (exit status 137)"), err
        _wait(lambda: not _alive(b), timeout=10, what="worker B stopped")
    finally:
        if sup.poll() is None:
            os.killpg(sup.pid, signal.SIGKILL)
            sup.wait()
        sup.stderr.close()


def _health(port: int) -> bool:
    try:
        urllib.request.urlopen(f"http://127.0.0.1:{port}/_stcore/health", timeout=2)
        return True
    except OSError:
        return False


def _worker_pid(pgid: int, port: int) -> int | None:
    """The streamlit process of group ``pgid`` serving ``port`` (Linux /proc)."""
    for d in Path("/proc").iterdir():
        if not d.name.isdigit():
            continue
        try:
            stat = (d / "stat").read_text().rsplit(")", 1)[1].split()
            argv = (d / "cmdline").read_bytes().split(b"\0")
        except OSError:
            continue
        if int(stat[2]) == pgid and stat[0] != "Z" and b"--server.port" in argv and \
                argv[argv.index(b"--server.port") + 1] == str(port).encode():
            return int(d.name)
    return None


def test_killing_a_real_worker_loses_no_vote_and_the_other_serves_on(tmp_path):
    from annotate.study import build_study, load_study
    from annotate.workers import MIN_UPTIME_S

    scene, pairs = toy.make_toy(tmp_path)
    root = build_study(tmp_path / "study", pairs, scene=str(scene), tracks=2, frames_per_track=3,
                       n_training=0, n_gold=1, n_repeats=0, votes_per_item=2, size=64, progress=False)
    port = bench.free_ports(2)
    log = (tmp_path / "serve.err").open("w")
    proc = bench.start_server(root, port, workers=2, log=log)
    acked: dict[str, int] = {}

    async def vote(p: int, rater: str, n: int) -> None:
        c = bench.RaterClient(f"http://127.0.0.1:{p}/")
        screen = await c.open(f"rater={rater}")
        if "Start" in screen.buttons:  # a returning rater goes straight on
            screen = await c.press("Start")
        for _ in range(n):
            shown = screen.vote_id()
            await asyncio.sleep(0.4)  # too-fast presses are dropped
            screen = await c.press("Good")
            assert screen.vote_id() != shown
            acked[rater] = acked.get(rater, 0) + 1
        await c.close()

    try:
        asyncio.run(vote(port, "ann", 2))
        other = _worker_pid(proc.pid, port + 1)
        victim = _worker_pid(proc.pid, port)
        assert other and victim
        time.sleep(MIN_UPTIME_S)  # a worker that dies at its start is not restarted
        os.kill(victim, signal.SIGKILL)
        asyncio.run(vote(port + 1, "bob", 2))  # the other worker serves meanwhile
        _wait(lambda: _health(port) and _worker_pid(proc.pid, port) not in (None, victim),
              timeout=120, what="the killed worker back on its port")
        asyncio.run(vote(port, "ann", 1))  # ann goes on where she was, on the restarted worker
        assert _worker_pid(proc.pid, port + 1) == other and proc.poll() is None
        votes = load_study(root).store.votes()
        assert votes.groupby("rater").size().to_dict() == acked == {"ann": 3, "bob": 2}
    finally:
        bench.stop_server(proc)
        log.close()
    err = (tmp_path / "serve.err").read_text()
    assert f"the worker on port {port} was killed by SIGKILL" in err and "restart 1 of 5" in err, err
