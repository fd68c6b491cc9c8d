"""The vote store under concurrency and crashes; balanced assignment; crop path safety.

Expected values are counted independently in the test (the writers' own logs), never read
back from the store's own summaries.
"""

from __future__ import annotations

import signal
import subprocess
import sys
import threading
from collections import Counter

import numpy as np
import pytest

from annotate.assign import make_plan
from annotate.chooser import choose_next
from annotate.store import Store
from annotate.study import crop_path
from data_schema.errors import InputError


def test_eight_threads_200_votes_nothing_lost_or_duplicated(tmp_path):
    # NORMAL sync: this test is about concurrency (the SIGKILL test below runs the default FULL)
    store = Store(tmp_path / "v.sqlite", "s", synchronous="NORMAL")
    n_threads, n_votes, n_items = 8, 200, 40
    sent: list[list[tuple[str, str, int]]] = [[] for _ in range(n_threads)]
    errors = []

    def writer(t: int) -> None:
        rng = np.random.default_rng(t)
        rater = f"r{t % 4}"  # two threads per rater: same (rater, item) keys collide
        try:
            for _ in range(n_votes):  # 200 votes on 40 items: repeats and changed votes
                item, vote = f"i{int(rng.integers(n_items))}", int(rng.integers(2))
                store.record_vote(rater, item, vote, response_ms=int(rng.integers(100, 900)))
                sent[t].append((rater, item, vote))
        except Exception as exc:  # pragma: no cover - reported below
            errors.append(exc)

    threads = [threading.Thread(target=writer, args=(t,)) for t in range(n_threads)]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    assert not errors
    hist = store.history()
    # history complete: every vote that returned is logged exactly once (multiset equality)
    logged = Counter(zip(hist["rater"], hist["item"], hist["vote"], strict=True))
    assert logged == Counter(v for s in sent for v in s)
    assert len(hist) == n_threads * n_votes
    votes = store.votes()
    # nothing duplicated: one row per (rater, item) ever voted
    keys = {(r, i) for s in sent for r, i, _ in s}
    assert len(votes) == len(keys) and not votes.duplicated(["rater", "item"]).any()
    # a changed vote replaces the old one: the standing vote is the last one logged
    last = hist.groupby(["rater", "item"])["vote"].last()
    assert votes.set_index(["rater", "item"])["vote"].sort_index().equals(last.sort_index())


_WRITER = """
import sys
from annotate.store import Store
s = Store(sys.argv[1], "s")
i = 0
while True:
    s.record_vote("r", f"item-{i}", i % 2, response_ms=i)
    print(f"ack {i}", flush=True)
    i += 1
"""


def test_sigkill_keeps_every_acknowledged_vote(tmp_path):
    db = tmp_path / "v.sqlite"
    Store(db, "s")
    proc = subprocess.Popen([sys.executable, "-c", _WRITER, str(db)], stdout=subprocess.PIPE,
                            text=True)
    acked = []
    try:
        for line in proc.stdout:
            acked.append(int(line.split()[1]))
            if len(acked) >= 60:
                break
        proc.send_signal(signal.SIGKILL)  # mid-study: the writer is still voting
        proc.wait(timeout=10)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(timeout=10)
        proc.stdout.close()
    assert proc.returncode == -signal.SIGKILL
    votes = Store(db, "s").votes().set_index("item")
    for i in acked:
        assert votes.loc[f"item-{i}", "vote"] == i % 2


def test_vote_must_be_0_or_1(tmp_path):
    with pytest.raises(InputError, match="1 \\(good\\) or 0 \\(bad\\)"):
        Store(tmp_path / "v.sqlite", "s").record_vote("r", "i", 2)


def test_undo_removes_latest_standing_vote(tmp_path):
    s = Store(tmp_path / "v.sqlite", "s")
    for item, vote in (("a", 1), ("b", 0)):
        s.next_item("r", lambda *_, item=item: item)
        s.record_shown_vote("r", item, vote, session="tab")
    assert s.undo_last("r", session="tab") == "b"
    assert s.undo_last("r", session="tab") == "a"
    assert s.undo_last("r", session="tab") is None
    assert s.votes().empty and s.history()["action"].tolist() == ["vote", "vote", "undo", "undo"]


def test_balanced_assignment_every_item_reaches_quota_first(tmp_path):
    store = Store(tmp_path / "v.sqlite", "s")
    tests = [f"t{i}" for i in range(10)]
    quota, raters = 2, [f"r{i}" for i in range(5)]  # 5 raters, quota 2 -> 20 votes in all
    plans = {r: make_plan(training=[], tests=tests, golds=[], repeats={}, seed=i)
             for i, r in enumerate(raters)}
    active = list(raters)
    while active:
        for r in list(active):
            key = store.next_item(r, lambda a, v, loads, r=r: choose_next(plans[r], a, v, loads,
                                                                          quota=quota))
            if key is None:
                active.remove(r)
                continue
            counts = Counter(store.votes()["item"])
            # balanced: no item gets a vote while another still has fewer (hand rule)
            assert counts.get(key, 0) == min(counts.get(t, 0) for t in tests)
            store.record_vote(r, key, 1)
    counts = Counter(store.votes()["item"])
    assert counts == {t: quota for t in tests}


def test_crop_path_refuses_traversal(tmp_path):
    (tmp_path / "crops").mkdir()
    (tmp_path / "crops" / "abc.jpg").write_bytes(b"x")
    (tmp_path / "secrets.json").write_text("{}")
    assert crop_path(tmp_path, "abc.jpg") == (tmp_path / "crops" / "abc.jpg").resolve()
    for bad in ("../secrets.json", "/etc/passwd", "sub/../../secrets.json", "..", "",
                "abc.jpg/../../secrets.json", "missing.jpg"):
        with pytest.raises(InputError):
            crop_path(tmp_path, bad)
    (tmp_path / "crops" / "link.jpg").symlink_to(tmp_path / "secrets.json")
    with pytest.raises(InputError):
        crop_path(tmp_path, "link.jpg")


def test_item_counters_match_a_full_recount_after_random_operations(tmp_path):
    """The trigger-kept per-item counters equal a recount from the raw tables (the old query)."""
    import sqlite3

    store = Store(tmp_path / "v.sqlite", "s")
    tests = [f"t{i}" for i in range(8)]
    plans = {f"r{i}": make_plan(training=[], tests=tests, golds=[], repeats={}, seed=i)
             for i in range(4)}
    rng = np.random.default_rng(3)
    for _ in range(60):
        r = f"r{int(rng.integers(4))}"
        op = rng.random()
        if op < 0.6:
            key = store.next_item(r, lambda a, v, loads, r=r: choose_next(plans[r], a, v, loads,
                                                                          quota=3))
            if key is not None and rng.random() < 0.8:
                store.record_shown_vote(r, key, int(rng.integers(2)), session=r)
        elif op < 0.8:
            store.undo_last(r, session=r)
    con = sqlite3.connect(tmp_path / "v.sqlite")
    counters = {i: (v, c) for i, v, c in con.execute(
        "SELECT item, voted, claimed FROM item_loads WHERE study = 's'") if v or c}
    recount = {}
    for item in tests:
        voted = con.execute("SELECT COUNT(*) FROM votes WHERE item = ?", (item,)).fetchone()[0]
        claimed = con.execute(
            "SELECT COUNT(*) FROM assignments a WHERE a.item = ? AND NOT EXISTS (SELECT 1 FROM "
            "votes v WHERE v.rater = a.rater AND v.item = a.item)", (item,)).fetchone()[0]
        if voted or claimed:
            recount[item] = (voted, claimed)
    assert counters == recount and sum(v for v, _ in recount.values()) > 5


def test_counters_backfilled_for_a_database_made_before_them(tmp_path):
    import sqlite3

    s = Store(tmp_path / "v.sqlite", "s")
    s.next_item("r", lambda a, v, loads: "x")
    s.record_vote("r", "x", 1)
    s.next_item("q", lambda a, v, loads: "x")
    con = sqlite3.connect(tmp_path / "v.sqlite")
    con.executescript("DROP TABLE item_loads; DROP TRIGGER IF EXISTS item_loads_assign;"
                      "DROP TRIGGER IF EXISTS item_loads_vote; DROP TRIGGER IF EXISTS item_loads_unvote;")
    con.close()
    s2 = Store(tmp_path / "v.sqlite", "s")
    seen = {}
    s2.next_item("z", lambda a, v, loads: seen.update(loads))
    assert seen == {"x": 2}  # one vote (r) + one open claim (q), as recounted by hand


def test_shown_vote_is_recorded_once_and_only_for_an_assigned_item(tmp_path):
    s = Store(tmp_path / "v.sqlite", "s")
    assert s.record_shown_vote("r", "a", 1) == "unassigned"
    s.next_item("r", lambda a, v, loads: "a")
    assert s.record_shown_vote("r", "a", 1, response_ms=5) == "recorded"
    assert s.record_shown_vote("r", "a", 0) == "already"  # e.g. a second tab: first vote stands
    assert s.votes()[["item", "vote"]].values.tolist() == [["a", 1]]
    assert s.history()["action"].tolist() == ["vote"]


def test_a_deleted_database_is_not_silently_recreated(tmp_path):
    import sqlite3

    s = Store(tmp_path / "v.sqlite", "s")
    s._keeper.close()
    for suffix in ("", "-wal", "-shm"):
        (tmp_path / f"v.sqlite{suffix}").unlink(missing_ok=True)
    with pytest.raises(sqlite3.OperationalError):
        s.record_vote("r", "a", 1)
    assert not (tmp_path / "v.sqlite").exists()


def test_skipped_item_leaves_the_queue(tmp_path):
    s = Store(tmp_path / "v.sqlite", "s")
    order = iter(["a", "b"])
    assert s.next_item("r", lambda a, v, loads: next(order)) == "a"
    s.skip("r", "a", reason="crop cannot be shown")
    assert s.next_item("r", lambda a, v, loads: next(order, None)) == "b"


def test_a_replaced_database_is_written_through_a_new_connection(tmp_path):
    """The connection pool never writes to the file a pooled connection opened once that path
    holds another file (a study rebuilt under a running server)."""
    import os

    s = Store(tmp_path / "v.sqlite", "s")
    s.record_vote("ann", "a", 1)  # leaves a pooled connection to the first file
    Store(tmp_path / "new.sqlite", "s")._keeper.close()
    s._keeper.close()
    old_ino = os.stat(tmp_path / "v.sqlite").st_ino
    for suffix in ("-wal", "-shm"):
        (tmp_path / f"v.sqlite{suffix}").unlink(missing_ok=True)
    os.replace(tmp_path / "new.sqlite", tmp_path / "v.sqlite")
    assert os.stat(tmp_path / "v.sqlite").st_ino != old_ino
    s.record_vote("bob", "b", 0)
    assert s.votes()[["rater", "item"]].values.tolist() == [["bob", "b"]]  # the new file's votes only


def test_item_loads_read_from_the_counters_equal_a_recount(tmp_path):
    """item_loads (the counters, what an arrival's is_full reads) equals recount_loads (a
    COUNT over the votes) after random votes, changed votes, undos, skips and unassigned
    votes, and after the counters are rebuilt for a file made before them."""
    import sqlite3

    store = Store(tmp_path / "v.sqlite", "s")
    other = Store(tmp_path / "v.sqlite", "t")  # another study in the same file is not counted
    items = [f"t{i}" for i in range(6)]
    rng = np.random.default_rng(5)
    for step in range(300):
        r, key = f"r{int(rng.integers(8))}", items[int(rng.integers(len(items)))]
        op = rng.random()
        if op < 0.4:
            got = store.next_item(r, lambda a, v, loads, key=key: key if key not in a else None)
            if got is not None:
                store.record_shown_vote(r, got, int(rng.integers(2)), session=r)
        elif op < 0.6:
            store.record_vote(r, key, int(rng.integers(2)))  # a change, or an unassigned vote
        elif op < 0.8:
            store.undo_last(r, session=r)
        elif op < 0.9:
            store.skip(r, key, reason="test")
        else:
            other.record_vote(r, key, 1)
        if step % 50 == 0:
            assert store.item_loads() == store.recount_loads()
    assert store.item_loads() == store.recount_loads() and store.recount_loads()
    with sqlite3.connect(tmp_path / "v.sqlite") as con:
        by_hand = dict(con.execute("SELECT item, COUNT(*) FROM votes WHERE study = 's' GROUP BY item"))
        con.executescript("DROP TABLE item_loads; DROP TRIGGER item_loads_assign;"
                          "DROP TRIGGER item_loads_vote; DROP TRIGGER item_loads_unvote;")
    assert Store(tmp_path / "v.sqlite", "s").item_loads() == by_hand
