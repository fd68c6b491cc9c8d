"""``annotate serve --workers K``: K servers on one study, consistent through the vote store,
and the printed proxy configuration accepted by the real proxy (that the workers stop with
their supervisor is tests/annotate/test_serve.py's signal test).

The servers are driven at the websocket level by the client of ``benchmarks/bench_raters.py``
(Streamlit's own protobuf messages, as a browser sends them). nginx and Caddy are Debian
packages (``apt-get install -y nginx caddy``); their tests skip where they are absent.
"""

from __future__ import annotations

import asyncio
import importlib.util
import os
import shutil
import socket
import subprocess
import sys
import time
import urllib.error
import urllib.request
from pathlib import Path

import pytest

from annotate.proxy_conf import proxy_conf

_spec = importlib.util.spec_from_file_location(
    "bench_raters_for_worker_tests", Path(__file__).parents[2] / "benchmarks" / "bench_raters.py")
bench = importlib.util.module_from_spec(_spec)
sys.modules[_spec.name] = bench  # dataclasses look their module up there
_spec.loader.exec_module(bench)

_toy_spec = importlib.util.spec_from_file_location("annotate_toy_workers", Path(__file__).with_name("toy.py"))
toy = importlib.util.module_from_spec(_toy_spec)
_toy_spec.loader.exec_module(toy)

QUOTA = 1


def _listening(port: int) -> bool:
    with socket.socket() as s:
        s.settimeout(1)
        return s.connect_ex(("127.0.0.1", port)) == 0


def _group_members(pgid: int) -> list[int]:
    """Live processes of process group ``pgid`` (Linux /proc)."""
    out = []
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                stat = (d / "stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(stat[2]) == pgid and stat[0] != "Z":
                out.append(int(d.name))
    return out


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    """A binary study (no training, quota 1) served by two workers: (root, ports, proc, stdout)."""
    from annotate.study import build_study

    tmp = tmp_path_factory.mktemp("workers")
    scene, pairs = toy.make_toy(tmp)
    root = build_study(tmp / "study", pairs, scene=str(scene), tracks=2, frames_per_track=3,
                       n_training=0, n_gold=1, n_repeats=0, votes_per_item=QUOTA, size=64,
                       progress=False)
    first = bench.free_ports(2)
    with (tmp / "stdout.txt").open("w") as out:
        proc = bench.start_server(root, first, workers=2, stdout=out)
    try:
        yield root, [first, first + 1], proc, (tmp / "stdout.txt").read_text()
    finally:
        bench.stop_server(proc)


def _url(port: int) -> str:
    return f"http://127.0.0.1:{port}/"


def test_two_workers_on_consecutive_ports_in_the_callers_group(served):
    root, ports, proc, stdout = served
    assert all(_listening(p) for p in ports)
    members = _group_members(proc.pid)
    # the supervisor and one streamlit process per port, all in the group of `annotate serve`
    assert proc.pid in members and len(members) >= 3
    # the printed configuration names exactly these ports; the study is open-access, which is
    # for this machine only, so its proxy listens on loopback alone (review of issue 30)
    assert stdout.startswith(proxy_conf("nginx", ports, loopback=True)), stdout
    assert "listen 127.0.0.1:80;" in stdout


def test_a_vote_through_one_worker_is_seen_by_the_other(served):
    from annotate.results import ratings_table
    from annotate.study import load_study

    root, (a, b), _proc, _ = served
    admin = load_study(root).admin_token()

    async def session():
        ca = bench.RaterClient(_url(a))
        screen = await ca.open("rater=kim")
        screen = await ca.press("Start")
        first = screen.vote_id()
        await asyncio.sleep(0.4)  # a rater looks first (too-fast presses are dropped)
        screen = await ca.press("Good")
        assert screen.vote_id() != first
        await ca.close()
        cb = bench.RaterClient(_url(b))  # the same rater, now on the other worker
        seen = await cb.open("rater=kim")
        await cb.close()
        cadm = bench.RaterClient(_url(b))
        adm = await cadm.open(f"admin={admin}")
        await cadm.close()
        return seen, adm

    seen, adm = asyncio.run(session())
    n = len(ratings_table(load_study(root)))  # read from the file by this process
    assert n >= 1
    assert any(t.startswith("1 / ") for t in seen.texts), seen.texts  # progress: 1 done
    assert any(f"{n} vote{'s' if n != 1 else ''}." in t for t in adm.texts), adm.texts  # issue 38: plurals


@pytest.mark.skipif(shutil.which("nginx") is None, reason="nginx not installed (apt-get install -y nginx)")
def test_nginx_in_front_of_the_workers_is_sticky(served, tmp_path):
    """The printed configuration under a real nginx on loopback: one cookie, one worker.

    A header naming the upstream is added so the test sees which worker answered: the page,
    the websocket and the session's images all come from one worker (the images exist only
    in the worker that drew them), while other cookies reach both workers.
    """
    root, ports, _proc, stdout = served
    listen = bench.free_port()
    conf = stdout.split("\n\n", 1)[0].replace("listen 127.0.0.1:80;", f"listen 127.0.0.1:{listen};")
    conf = conf.replace("proxy_pass http://nvrq_raters;", "proxy_pass http://nvrq_raters;\n"
                        "        add_header X-Nvrq-Upstream $upstream_addr always;")
    _nginx_files(tmp_path, conf)
    base = f"http://127.0.0.1:{listen}"
    nginx = subprocess.Popen(["nginx", "-p", str(tmp_path), "-c", "nginx.conf", "-e", "error.log"],
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)

    def get(path, cookie=None):
        req = urllib.request.Request(base + path, headers={"Cookie": cookie} if cookie else {})
        try:
            r = urllib.request.urlopen(req, timeout=10)
        except urllib.error.HTTPError as err:
            r = err
        with r:  # the response (or the error, which holds it) closes its socket
            return r.status, r.headers

    try:
        deadline = time.time() + 30
        while True:
            try:
                status, headers = get("/")
                break
            except OSError:
                assert nginx.poll() is None and time.time() < deadline, (tmp_path / "error.log").read_text()
                time.sleep(0.2)
        cookie = headers["Set-Cookie"].split(";")[0]
        assert status == 200 and cookie.startswith("nvrq_worker=")
        upstream = headers["X-Nvrq-Upstream"]
        assert upstream in {f"127.0.0.1:{p}" for p in ports}
        ws_upstream, images = asyncio.run(_images_through(base + "/", cookie))
        assert ws_upstream == upstream and images
        for url in images * 3:
            status, headers = get(url, cookie)
            assert (status, headers["X-Nvrq-Upstream"]) == (200, upstream)
        assert get("/_stcore/metrics", cookie)[0] == 404  # refused by the proxy (README)
        others = {get("/", f"nvrq_worker=other{i}")[1]["X-Nvrq-Upstream"] for i in range(16)}
        assert others == {f"127.0.0.1:{p}" for p in ports}  # 2**-15 chance of one worker only
    finally:
        nginx.terminate()
        nginx.wait(timeout=30)


async def _images_through(base: str, cookie: str) -> tuple[str, list[str]]:
    """(upstream of the websocket, image URLs of the first item) of a session through the proxy."""
    import websockets

    c = bench.RaterClient(base)
    c.query = "rater=proxied"
    c.ws = await websockets.connect(c.ws_url, subprotocols=["streamlit"], open_timeout=60,
                                    additional_headers={"Cookie": cookie})
    await c._run(None)
    screen = await c.press("Start")
    for _ in range(6):  # a busy machine: the first screen may say "no item is free right now"
        if screen.images or "Retry" not in screen.buttons:
            break
        await asyncio.sleep(5)
        screen = await c.press("Retry")
    await c.close()
    assert screen.images, screen.texts  # what the page said instead of an item
    return c.ws.response.headers["X-Nvrq-Upstream"], screen.images


def _nginx_files(folder: Path, conf: str) -> None:
    """A self-contained nginx main configuration in ``folder`` including ``conf`` as conf.d would."""
    (folder / "nvrq.conf").write_text(conf)
    temps = " ".join(f"{k}_temp_path {k}_temp;" for k in ("client_body", "proxy", "fastcgi", "uwsgi", "scgi"))
    (folder / "nginx.conf").write_text(
        "pid nginx.pid;\nerror_log error.log;\ndaemon off;\nevents {}\n"
        f"http {{\n  access_log off;\n  {temps}\n  include nvrq.conf;\n}}\n")


@pytest.mark.skipif(shutil.which("nginx") is None, reason="nginx not installed (apt-get install -y nginx)")
@pytest.mark.parametrize("host,loopback", [("127.0.0.1", False), ("0.0.0.0", False), ("::1", False),
                                           ("127.0.0.1", True)])
def test_nginx_accepts_the_configuration(tmp_path, host, loopback):
    _nginx_files(tmp_path, proxy_conf("nginx", [8501, 8502, 8503], host=host, listen=8080, loopback=loopback))
    r = subprocess.run(["nginx", "-t", "-p", str(tmp_path), "-c", "nginx.conf", "-e", "error.log"],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 0 and "test is successful" in r.stderr, r.stderr


@pytest.mark.skipif(shutil.which("caddy") is None, reason="caddy not installed (apt-get install -y caddy)")
@pytest.mark.parametrize("loopback", [False, True])
def test_caddy_accepts_the_configuration(tmp_path, loopback):
    (tmp_path / "Caddyfile").write_text(proxy_conf("caddy", [8501, 8502], listen=8080, loopback=loopback))
    r = subprocess.run(["caddy", "validate", "--config", str(tmp_path / "Caddyfile"), "--adapter",
                        "caddyfile"], capture_output=True, text=True, timeout=60,
                       env=dict(os.environ, HOME=str(tmp_path), XDG_DATA_HOME=str(tmp_path),
                                XDG_CONFIG_HOME=str(tmp_path)))
    assert r.returncode == 0, r.stderr + r.stdout


def test_workers_past_the_last_port_are_refused(make_study):
    r = subprocess.run([sys.executable, "-m", "annotate.cli", "serve", str(make_study().root),
                        "--port", "65535", "--workers", "2"], capture_output=True, text=True, timeout=60)
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2 and len(lines) == 1 and "--workers" in lines[0], r.stderr


def test_one_worker_ending_stops_the_others_and_gives_its_status():
    """supervise returns the first worker's exit status once it has stopped the rest."""
    from annotate.workers import supervise

    sleeper = [sys.executable, "-c", "import time; time.sleep(120)"]
    failing = [sys.executable, "-c", "import sys, time; time.sleep(0.5); sys.exit(3)"]
    t0 = time.time()
    assert supervise([sleeper, failing], env=dict(os.environ), poll_s=0.05) == 3
    assert time.time() - t0 < 60  # the sleeper was stopped, not waited for


def test_claims_hold_across_workers(served):
    """Raters arriving at once on both workers never share a test item beyond the quota, and
    none goes without a test item while one is free.

    More raters arrive than there are test items, so the last ones get a gold item of their
    plan or nothing: every test item is held for 120 s after this test, so it runs last of
    the tests on ``served`` (the earlier ones need a free item).
    """
    from annotate.study import load_study

    root, ports, _proc, _ = served
    study = load_study(root)
    tests = set(study.keys("test"))
    names = [f"claim{i}" for i in range(len(tests) + 2)]  # more raters than test items

    async def first_items():
        clients = [bench.RaterClient(_url(ports[i % 2])) for i in range(len(names))]
        await asyncio.gather(*[c.open(f"rater={n}") for c, n in zip(clients, names, strict=True)])
        await asyncio.gather(*[c.press("Start") for c in clients])
        await asyncio.gather(*[c.close() for c in clients])

    asyncio.run(first_items())
    everyone = study.store.assignments()
    asg = everyone[everyone["rater"].isin(names)]
    others = everyone[~everyone["rater"].isin(names) & everyone["item"].isin(tests)]
    assert asg.groupby("rater").size().max() == 1  # one Start, one item at most
    claimed = asg[asg["item"].isin(tests)].groupby("item").size()
    assert (claimed <= QUOTA).all(), claimed  # no test item shared between the new raters
    # an earlier test's vote fills its item's quota (a claim of an earlier test may have ended)
    assert not set(claimed.index) & set(others.loc[others["voted"], "item"]), claimed
    # more raters than test items: the last ones got a gold item or nothing, so no test was left
    assert set(claimed.index) | set(others["item"]) == tests
