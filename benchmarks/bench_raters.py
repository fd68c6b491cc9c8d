"""Load on the rater server: N concurrent raters at the websocket level, vote -> next item,
with K = 1 and K = 2 server processes (``annotate serve --workers K``) side by side.

Builds a study from a small synthetic scene, starts a real ``annotate serve --workers K`` on
127.0.0.1 for each K (one study each, built alike) and drives N rater sessions at once, each
speaking Streamlit's own websocket protocol (the ``BackMsg``/``ForwardMsg`` protobufs of the
installed ``streamlit.proto``, as the browser does): sign in by ``?rater=``, press Start,
then repeatedly think 0.8-1.6 s (``--think``) and press "Good" or "Bad" (a button trigger
sent as a fragment rerun, exactly what a key press sends). Raters arrive spread over the
first ``--arrive`` seconds (default: the longest think time) and rater ``i`` talks to worker
``i mod K``, as a sticky proxy spreads sessions (the proxy's own work is not measured).
The latency of a vote is the time from sending the press to the server's
``script_finished`` of the run that shows the next item. After each round the votes in the
SQLite store are compared with the presses the clients saw acknowledged ("lost" must be 0).
For each N the K rounds run one after the other, both servers up, so they meet the same
machine. Prints one line per (N, K): p50/p95/max latency in ms, votes, votes lost and the
servers' CPU time per vote (all processes of the serve's process group, sign-ins included;
on a shared machine the latencies move with the load, the CPU time much less), then a table
of K = 1 and K = 2 side by side. Targets: 300 concurrent raters with K = 2 at p95 < 1 s,
max < 3 s, 0 votes lost, with ``--think 2 4`` (not judged on a machine where the load client's own
CPU shares the cores: it makes it unmeasurable there); at most 10 ms of server CPU per vote, with the item choice of ``--sampling`` included (``active``: a
pairwise study of three methods, 288 test comparisons, each next one chosen by expected
information gain over the current posterior; ``adaptive``: the binary study, curtailed).

First, measured side by side in the same run: the store's work per vote (next item,
progress, record) with ~300 and with ~3,000 votes already stored, and their ratio (about 1:
the work does not grow with the study; issue 13 measured 11.8 ms at 351 votes and
19.6 ms at 3,120 before the per-item counters).

    python benchmarks/bench_raters.py                       # N = 10, 20, 30; K = 1, 2; 40 s each
    python benchmarks/bench_raters.py --raters 100,200,300 --think 2 4   # issue 30's goal
    python benchmarks/bench_raters.py --raters 2 --seconds 5 --think 0.4 0.6   # smoke run
    python benchmarks/bench_raters.py --raters 150,300 --workers 2 --sampling active  # issue 37
"""

from __future__ import annotations

import argparse
import asyncio
import dataclasses
import os
import signal
import socket
import sqlite3
import subprocess
import sys
import tempfile
import time
import urllib.request
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np
import pandas as pd

from annotate.store import Store
from annotate.study import build_study, load_study
from data_schema.tables import pair_id

__all__ = ["RaterClient", "Screen", "make_scene", "start_server", "stop_server", "free_ports",
           "group_cpu_s", "side_by_side", "run_load", "main"]

WS_PATH = "_stcore/stream"


# ---- a Streamlit websocket client ---------------------------------------------------------
@dataclass
class Screen:
    """What one script run put on the page: buttons by label, texts, image URLs, status."""

    buttons: dict[str, str] = field(default_factory=dict)  # label -> widget id
    fragment: dict[str, str] = field(default_factory=dict)  # widget id -> fragment id
    texts: list[str] = field(default_factory=list)
    images: list[str] = field(default_factory=list)
    status: str = ""

    def vote_id(self) -> str | None:
        """The id of a vote button on screen ("Good", or a pairwise study's "Can't tell")."""
        return self.buttons.get("Good") or self.buttons.get("Can't tell")

    def vote_labels(self) -> list[str]:
        """The labels of the answer buttons on screen (Good/Bad, or left/can't tell/right)."""
        return [b for b in self.buttons if b in ("Good", "Bad", "Can't tell")
                or "is closer" in b]


class RaterClient:
    """One browser-like session: ``await c.open(query)``, then ``await c.press(label)``."""

    def __init__(self, base_url: str):
        self.ws_url = base_url.replace("http://", "ws://").rstrip("/") + "/" + WS_PATH
        self.query = ""
        self.ws = None
        self.screen = Screen()

    async def open(self, query: str) -> Screen:
        import websockets

        self.query = query
        self.ws = await websockets.connect(self.ws_url, subprotocols=["streamlit"],
                                           max_size=None, open_timeout=60)
        return await self._run(None)

    async def close(self) -> None:
        if self.ws is not None:
            await self.ws.close()

    async def press(self, label: str) -> Screen:
        """Trigger the button ``label`` of the current screen (a fragment rerun if it is in one)."""
        wid = self.screen.buttons[label]
        return await self._run(wid)

    async def _run(self, trigger: str | None) -> Screen:
        from streamlit.proto.BackMsg_pb2 import BackMsg

        msg = BackMsg()
        cs = msg.rerun_script
        cs.query_string = self.query
        if trigger is not None:
            ws = cs.widget_states.widgets.add()
            ws.id, ws.trigger_value = trigger, True
            frag = self.screen.fragment.get(trigger)
            if frag:
                cs.fragment_id = frag
        await self.ws.send(msg.SerializeToString())
        self.screen = await self._collect()
        return self.screen

    async def _collect(self) -> Screen:
        from streamlit.proto.ForwardMsg_pb2 import ForwardMsg

        screen = Screen()
        while True:
            fm = ForwardMsg()
            fm.ParseFromString(await asyncio.wait_for(self.ws.recv(), timeout=120))
            kind = fm.WhichOneof("type")
            if kind == "delta" and fm.delta.WhichOneof("type") == "new_element":
                _read_element(fm.delta.new_element, fm.delta.fragment_id, screen)
            elif kind == "script_finished":
                screen.status = ForwardMsg.ScriptFinishedStatus.Name(fm.script_finished)
                if screen.status != "FINISHED_EARLY_FOR_RERUN":
                    return screen


def _read_element(el, fragment_id: str, screen: Screen) -> None:
    kind = el.WhichOneof("type")
    if kind == "button":
        screen.buttons[el.button.label] = el.button.id
        screen.fragment[el.button.id] = fragment_id
    elif kind == "imgs":
        screen.images += [img.url for img in el.imgs.imgs]
    elif kind == "progress":
        screen.texts.append(el.progress.text)
    elif kind in ("alert", "markdown", "text", "heading"):
        screen.texts.append(getattr(el, kind).body)


# ---- a study and a server ----------------------------------------------------------------
def make_scene(root: Path, *, n_frames: int = 8, n_tracks: int = 4, seed: int = 0,
               methods: dict[str, float] | None = None) -> Path:
    """A synthetic clip (noise + coloured boxes; renders blurred by |offset|); returns pairs.csv.

    ``methods`` (name -> blur scale): one render per method, a ``method`` column and pair ids
    with the method (docs/FORMATS.md §3), for a pairwise study.
    """

    rng = np.random.default_rng(seed)
    (root / "scene" / "images").mkdir(parents=True, exist_ok=True)
    rows = []
    for f in range(n_frames):
        ts = 100000 * f
        img = rng.integers(0, 60, size=(120, 160, 3), dtype=np.uint8)
        boxes = [(5 + 38 * t, 20 + 5 * (f % 3), 35 + 38 * t, 60 + 5 * (f % 3)) for t in range(n_tracks)]
        for t, (x0, y0, x1, y1) in enumerate(boxes):
            cv2.rectangle(img, (x0, y0), (x1, y1), (40 * t % 255, 200, 255 - 50 * t % 255), -1)
        cv2.imwrite(str(root / "scene" / f"images/gt_{ts}.png"), img)
        for off, (method, scale) in [(o, m) for o in (-1.0, 0.0, 1.0)
                                     for m in (methods or {"": 1.0}).items()]:
            rel = f"images/render_{method}{ts}_{off:+.1f}.png"
            ren = img if off == 0 else cv2.GaussianBlur(img, (0, 0), 2.0 * scale * abs(off))
            cv2.imwrite(str(root / "scene" / rel), ren)
            for t, (x0, y0, x1, y1) in enumerate(boxes):
                rows.append({"pair_id": pair_id("bench", "front", f"t{t}", ts, off, method=method),
                             **({"method": method} if method else {}),
                             "clip_id": "bench", "camera": "front", "track_id": f"t{t}",
                             "label_class": "automobile", "timestamp_us": ts, "y_offset_m": off,
                             "gt_path": f"images/gt_{ts}.png", "render_path": rel,
                             "gt_x0": x0, "gt_y0": y0, "gt_x1": x1, "gt_y1": y1,
                             "r_x0": x0, "r_y0": y0, "r_x1": x1, "r_y1": y1})
    pd.DataFrame(rows).to_csv(root / "pairs.csv", index=False)
    return root / "pairs.csv"


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def start_server(study: Path, port: int, *, workers: int = 1, log=subprocess.DEVNULL,
                 stdout=subprocess.DEVNULL) -> subprocess.Popen:
    """``annotate serve STUDY --workers K`` on 127.0.0.1 from ``port``, in its own process
    group, once every worker answers (``stdout``: where the printed proxy configuration goes)."""
    proc = subprocess.Popen([sys.executable, "-m", "annotate.cli", "serve", str(study),
                             "--port", str(port), "--workers", str(workers)],
                            start_new_session=True, stdout=stdout, stderr=log)
    deadline = time.time() + 120
    for p in range(port, port + workers):
        while True:
            try:
                urllib.request.urlopen(f"http://127.0.0.1:{p}/_stcore/health", timeout=2)
                break
            except OSError:
                if proc.poll() is not None or time.time() > deadline:
                    stop_server(proc)
                    raise RuntimeError("annotate serve did not start") from None
                time.sleep(0.2)
    return proc


def free_ports(n: int) -> int:
    """The first of ``n`` consecutive free ports on 127.0.0.1."""
    while True:
        first, socks = free_port(), []
        try:
            for p in range(first, first + n):
                socks.append(socket.socket())
                socks[-1].bind(("127.0.0.1", p))
            return first
        except OSError:
            continue
        finally:
            for sock in socks:
                sock.close()


def stop_server(proc: subprocess.Popen) -> None:
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass
    proc.wait(timeout=30)


# ---- the load --------------------------------------------------------------------------
async def _rater(url: str, name: str, *, until: float, think: tuple[float, float],
                 rng: np.random.Generator, lat: list[float], arrive: float = 0.0) -> int:
    """One rater's session, opened after ``U(0, arrive)`` s; returns the acknowledged votes."""
    await asyncio.sleep(float(rng.uniform(0, arrive)))
    c = RaterClient(url)
    screen = await c.open(f"rater={name}")
    if "Start" in screen.buttons:
        screen = await c.press("Start")
    acked = 0
    try:
        while time.time() < until and screen.vote_id():
            await asyncio.sleep(float(rng.uniform(*think)))
            old = screen.vote_id()
            t0 = time.perf_counter()
            labels = screen.vote_labels()
            screen = await c.press(labels[0] if rng.random() < 0.6 else labels[-1])
            if screen.vote_id() != old:  # the next item (or "All done") is on screen: acked
                lat.append(time.perf_counter() - t0)
                acked += 1
    finally:
        await c.close()
    return acked


async def _warm_up(url: str) -> None:
    """One session, so the app's first run (its imports) is not timed."""
    c = RaterClient(url)
    await c.open("rater=warmup")
    await c.close()


async def _round(urls: list[str], names: list[str], *, seconds: float, think, seed: int,
                 arrive: float = 0.0):
    """Rater ``i`` on ``urls[i % len(urls)]``; (latencies, acknowledged votes per rater)."""
    lat: list[float] = []
    until = time.time() + seconds
    acked = await asyncio.gather(*[
        _rater(urls[i % len(urls)], n, until=until, think=think,
               rng=np.random.default_rng([seed, i]), lat=lat, arrive=arrive)
        for i, n in enumerate(names)])
    return lat, dict(zip(names, acked, strict=True))


def run_load(n_list: list[int], *, seconds: float, think: tuple[float, float], seed: int = 0,
             frames: int = 8, workers: tuple[int, ...] = (1, 2),
             arrive: float | None = None, build: dict | None = None) -> pd.DataFrame:
    """Build a study per K, serve each with K workers, and drive each N on each; one row per (N, K).

    ``build``: more options of the studies (:class:`annotate.design.StudyOptions` fields,
    e.g. ``{'sampling': 'active', 'design': 'pairwise'}``); a pairwise study compares three
    methods (the raters press left 60%, else right or can't tell).
    """

    arrive = think[1] if arrive is None else arrive
    with tempfile.TemporaryDirectory(prefix="bench_raters_") as tmp:
        tmp = Path(tmp)
        build = dict(build or {})
        pairwise = build.get("design") == "pairwise"
        pairs = make_scene(tmp, n_frames=frames,
                           methods={"m1": 0.5, "m2": 1.0, "m3": 1.5} if pairwise else None)
        opts = dict(scene=str(tmp / "scene"), tracks=4, frames_per_track=frames,
                    votes_per_item=max(n_list), n_training=2, n_gold=2, n_repeats=3, size=96,
                    progress=False, **build)
        work = db_work(load_study(build_study(tmp / "work", pairs, **opts)), sizes=(300, 3000))
        for w in work:
            print(f"store work per vote at {w['stored_votes']:5d} stored votes: "
                  f"{w['ms_per_vote']:.2f} ms", flush=True)
        print(f"store work ratio (largest / smallest study): "
              f"{work[-1]['ms_per_vote'] / work[0]['ms_per_vote']:.2f}", flush=True)
        servers, rows = {}, []
        try:
            for k in workers:
                root = build_study(tmp / f"study-k{k}", pairs, **opts)
                first = free_ports(k)
                servers[k] = (load_study(root).store, start_server(root, first, workers=k),
                              [f"http://127.0.0.1:{p}/" for p in range(first, first + k)])
                for url in servers[k][2]:
                    asyncio.run(_warm_up(url))
            for j, n in enumerate(n_list):
                for k in workers:
                    store, server, urls = servers[k]
                    names = [f"load{j}-k{k}-{i}" for i in range(n)]
                    cpu0 = group_cpu_s(server.pid)
                    lat, acked = asyncio.run(_round(urls, names, seconds=seconds, think=think,
                                                    seed=seed + j, arrive=arrive))
                    cpu = group_cpu_s(server.pid) - cpu0
                    rows.append(_row(n, k, lat, acked, store, cpu))
                    print(_line(rows[-1]), flush=True)
        finally:
            for _store, server, _urls in servers.values():
                stop_server(server)
    return pd.DataFrame(rows)


def _row(n: int, k: int, lat: list[float], acked: dict[str, int], store, cpu_s: float) -> dict:
    """One (N, K) result: latency percentiles, votes, votes lost against the store, CPU per vote."""
    stored = store.votes()
    stored = stored[stored["rater"].isin(list(acked))].groupby("rater").size()
    lost = sum(max(0, a - int(stored.get(r, 0))) for r, a in acked.items())
    ms = np.asarray(lat) * 1000
    votes = int(sum(acked.values()))
    return {"raters": n, "workers": k, "votes": votes,
            "p50_ms": float(np.percentile(ms, 50)) if len(ms) else float("nan"),
            "p95_ms": float(np.percentile(ms, 95)) if len(ms) else float("nan"),
            "max_ms": float(ms.max()) if len(ms) else float("nan"),
            "votes_lost": int(lost), "server_cpu_ms_per_vote": cpu_s * 1000 / max(1, votes)}


def group_cpu_s(pgid: int) -> float:
    """User + system CPU seconds of the live processes of process group ``pgid`` (Linux ``/proc``)."""
    total = 0.0
    for d in Path("/proc").iterdir():
        if not d.name.isdigit():
            continue
        try:
            fields = (d / "stat").read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[2]) == pgid:
            total += server_cpu_s(int(d.name))
    return total if Path("/proc").is_dir() else float("nan")


def server_cpu_s(pid: int) -> float:
    """User + system CPU seconds of process ``pid`` so far (Linux ``/proc``; NaN elsewhere)."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return float("nan")
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _prefill(store, items: list[str], raters: list[str]) -> None:
    """Every rater in ``raters`` assigned and voted on every item (one transaction)."""

    now = time.time()
    with sqlite3.connect(store.path) as con:
        con.executemany("INSERT INTO assignments (study, rater, item, assigned_at) VALUES (?, ?, ?, ?)",
                        [(store.study, r, k, now) for r in raters for k in items])
        con.executemany("INSERT INTO votes (study, rater, item, vote, voted_at) VALUES (?, ?, ?, 1, 'x')",
                        [(store.study, r, k) for r in raters for k in items])


def db_work(study, *, sizes: tuple[int, int], n_votes: int = 40) -> list[dict]:
    """Per-vote store work (next item + progress + record) at two numbers of stored votes.

    Each size adds simulated raters who voted on every test item, then a fresh rater votes
    ``n_votes`` times; the store runs with ``synchronous=NORMAL`` here so that the disk sync
    (the same at any size) does not hide the database work being compared.
    """

    study = dataclasses.replace(study, store=Store(study.store.path, study.store.study,
                                                   synchronous="NORMAL"))
    tests = study.keys("test")
    rows, have = [], len(study.store.votes())
    for k, size in enumerate(sizes):
        extra = max(0, (size - have) // len(tests))
        _prefill(study.store, tests, [f"fill{k}-{i}" for i in range(extra)])
        have = len(study.store.votes())
        rater, t0 = f"probe{k}", time.perf_counter()
        for _ in range(n_votes):
            key = study.next_item(rater)
            study.progress(rater)
            study.store.record_shown_vote(rater, key, 1)
        rows.append({"stored_votes": have, "ms_per_vote": (time.perf_counter() - t0) / n_votes * 1000})
    return rows


def _line(r: dict) -> str:
    return (f"N={r['raters']:3d} raters, K={r['workers']} workers: vote->next item p50 "
            f"{r['p50_ms']:.0f} ms, p95 {r['p95_ms']:.0f} ms, max {r['max_ms']:.0f} ms; "
            f"{r['votes']} votes, {r['votes_lost']} votes lost; "
            f"server CPU {r['server_cpu_ms_per_vote']:.1f} ms per vote")


def side_by_side(table: pd.DataFrame) -> pd.DataFrame:
    """One row per N, the figures of every K in columns (``p95_ms K=1``, ``p95_ms K=2``, ...)."""
    wide = table.pivot(index="raters", columns="workers",
                       values=["p50_ms", "p95_ms", "max_ms", "server_cpu_ms_per_vote", "votes",
                               "votes_lost"])
    wide.columns = [f"{what} K={k}" for what, k in wide.columns]
    return wide.round(1)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--raters", default="10,20,30", help="comma list of concurrent raters N")
    ap.add_argument("--workers", default="1,2", help="comma list of server processes K (serve --workers)")
    ap.add_argument("--seconds", type=float, default=40.0, help="duration of each round")
    ap.add_argument("--think", type=float, nargs=2, default=(0.8, 1.6), metavar=("MIN", "MAX"))
    ap.add_argument("--arrive", type=float, default=None,
                    help="raters arrive spread over this many seconds (default: think MAX)")
    ap.add_argument("--frames", type=int, default=8, help="frames of the synthetic clip")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--sampling", default="uniform", choices=["uniform", "active", "adaptive"],
                    help="annotate build --sampling of the studies (active: a pairwise study; "
                    "default uniform)")
    ap.add_argument("--design", default=None, choices=["binary", "pairwise"],
                    help="the studies' design (default: pairwise with --sampling active, else binary)")
    args = ap.parse_args(argv)
    n_list = [int(v) for v in args.raters.split(",")]
    k_list = tuple(int(v) for v in args.workers.split(","))
    table = run_load(n_list, seconds=args.seconds, think=tuple(args.think), seed=args.seed,
                     frames=args.frames, workers=k_list, arrive=args.arrive,
                     build={"sampling": args.sampling, "design": args.design or (
                         "pairwise" if args.sampling == "active" else "binary")})
    with pd.option_context("display.width", 250, "display.max_columns", 40):
        print(side_by_side(table).to_string())
    print(f"votes lost in all rounds: {int(table['votes_lost'].sum())}")
    cpu = table["server_cpu_ms_per_vote"]
    at = table[(table["raters"] == 150) & (table["workers"] == 2)]["server_cpu_ms_per_vote"]
    verdict = ("not run" if at.empty else "met" if (at <= 10).all() else "not met")
    print(f"server CPU per vote: {cpu.min():.1f}-{cpu.max():.1f} ms; target <= 10 ms at 150 "
          f"raters, K = 2 (sampling {args.sampling}): {verdict}")
    goal = table[(table["raters"] >= 300) & (table["workers"] == 2)]
    met = len(goal) and ((goal["p95_ms"] < 1000) & (goal["max_ms"] < 3000)
                         & (goal["votes_lost"] == 0)).all()
    print("target (300 raters, K = 2: p95 < 1000 ms, max < 3000 ms, 0 lost): "
          f"{'met' if met else 'not met' if len(goal) else 'not run'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
