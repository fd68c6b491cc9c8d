"""Browser sessions in the vote store and the app: bounded undo, claim leases, too-fast presses,
and the review's attacks (issue 30): undo-all against another rater's earlier work and a
sybil flood of claims that are never voted on. Both designs follow the same rules.

Expected numbers are counted by hand from what each test does (votes cast, presses made),
never read back from the store's own summaries; the undo depth, lease and schema version are
the documented constants of annotate.store (docs/FORMATS.md §8).
"""

from __future__ import annotations

import sqlite3
import threading
import time

import pytest

import annotate.store as store_mod
from annotate.cli import main
from annotate.store import CLAIM_LEASE_S, SCHEMA_VERSION, UNDO_DEPTH, Store
from annotate.study import build_study, load_study
from tests.annotate.test_app import _app, _btn, _current, _page_text
from tests.annotate.toy import make_toy


@pytest.fixture(autouse=True)
def _instant_presses(monkeypatch):
    """AppTest presses a moment after drawing; the too-fast rule would drop them."""
    monkeypatch.setenv("ANNOTATE_MIN_RESPONSE_MS", "0")


def _later(monkeypatch, seconds: float) -> None:
    """Move the store's lease clock ``seconds`` into the future."""
    monkeypatch.setattr(store_mod, "_clock", lambda: time.time() + seconds)


def _vote_shown(s: Store, rater: str, item: str, *, session: str, vote: int = 1) -> None:
    assert s.next_item(rater, lambda *_: item) == item
    assert s.record_shown_vote(rater, item, vote, session=session) == "recorded"


# ---- undo ---------------------------------------------------------------------------------

def test_undo_reaches_only_the_last_votes_of_its_own_session(tmp_path):
    assert UNDO_DEPTH == 3  # docs/FORMATS.md §8 states this number
    s = Store(tmp_path / "v.sqlite", "s")
    for item in "abcde":  # five votes in one browser session
        _vote_shown(s, "alice", item, session="old")
    s.record_vote("alice", "f", 0)  # a vote without a session (simulated raters, scripts)
    # another session of the same rater (a reopened link) presses U twenty times
    assert [s.undo_last("alice", session="new") for _ in range(20)] == [None] * 20
    assert sorted(s.votes("alice")["item"]) == list("abcdef")
    # the session itself takes back at most its last three votes, newest first
    assert [s.undo_last("alice", session="old") for _ in range(5)] == ["e", "d", "c", None, None]
    # a new vote (on c, the oldest open item) enters the window of the last three votes,
    # c, e, d: only c stands among them; b, the 4th newest, stays out of reach
    _vote_shown(s, "alice", "c", session="old", vote=0)
    assert s.undo_last("alice", session="old") == "c"
    assert s.undo_last("alice", session="old") is None
    hist = s.history()
    assert (hist["action"] == "undo").sum() == 4  # e, d, c, c: every undo is kept
    assert sorted(s.votes("alice")["item"]) == list("abf")
    assert s.action_counts().set_index("rater").loc["alice", "votes_undone"] == 4
    with pytest.raises(ValueError, match="session"):
        s.undo_last("alice", session="")


def test_undo_never_removes_a_vote_that_another_session_replaced(tmp_path):
    s = Store(tmp_path / "v.sqlite", "s")
    _vote_shown(s, "bob", "a", session="tab1")
    assert s.undo_last("bob", session="tab1") == "a"
    _vote_shown(s, "bob", "a", session="tab2", vote=0)  # a's vote now belongs to tab2
    assert s.undo_last("bob", session="tab1") is None
    assert s.votes("bob")[["item", "vote"]].values.tolist() == [["a", 0]]


def _binary(tmp_path, **kw):
    scene, pairs = make_toy(tmp_path / "in")
    opts = dict(scene=str(scene), tracks=1, frames_per_track=1, n_training=1, n_gold=1,
                n_repeats=1, size=64, progress=False)
    return load_study(build_study(tmp_path / "study", pairs, **{**opts, **kw}))


def _pairwise(tmp_path, **kw):
    scene, pairs = make_toy(tmp_path / "in", methods={"alpha": 0.5, "beta": 1.5})
    opts = dict(scene=str(scene), tracks=1, frames_per_track=1, n_training=1, n_gold=1,
                n_repeats=1, size=64, image_format="png", design="pairwise",
                methods="alpha,beta", progress=False)
    return load_study(build_study(tmp_path / "study", pairs, **{**opts, **kw}))


DESIGNS = {"binary": (_binary, "vote_good"), "pairwise": (_pairwise, "vote_left")}


@pytest.mark.parametrize("design", sorted(DESIGNS))
def test_attack_undo_all_from_a_new_session_removes_nothing(design, tmp_path, monkeypatch,
                                                           capsys):
    """The review's attack: open ``?rater=alice`` in a fresh session and press U 20 times."""
    build, vote_button = DESIGNS[design]
    study = build(tmp_path)
    monkeypatch.setenv("ANNOTATE_STUDY", str(study.root))
    at = _app(rater="alice")
    at.button(key="start").click().run()
    for _ in range(5):
        _btn(at, vote_button).click().run()
    before = study.store.votes("alice")
    assert len(before) == 5
    attacker = _app(rater="alice")  # a new browser session of the same name
    for _ in range(20):
        _btn(attacker, "undo").click().run()
    assert study.store.votes("alice").equals(before)
    assert not (study.store.history()["action"] == "undo").any()
    assert "Nothing to undo" in _page_text(attacker)
    # alice's own session can still take back her last UNDO_DEPTH answers, and no more
    for _ in range(UNDO_DEPTH + 2):
        _btn(at, "undo").click().run()
    assert len(study.store.votes("alice")) == 5 - UNDO_DEPTH
    assert main(["export", str(study.root), "--out", str(tmp_path / "out.csv")]) == 0
    assert f"rater alice: {UNDO_DEPTH} votes undone, 0 presses too fast" in capsys.readouterr().err
    adm = _app(admin=study.admin_token())
    raters = next(df.value for df in adm.dataframe if "votes_undone" in df.value.columns)
    assert raters.set_index("rater_id").loc["alice", "votes_undone"] == UNDO_DEPTH


# ---- claims -------------------------------------------------------------------------------

def _first_free(assigned, voted, loads):
    """Quota 1: the first of x, y not assigned to the rater and not voted or claimed."""
    return next((k for k in "xy" if k not in assigned and loads.get(k, 0) < 1), None)


def test_a_claim_holds_its_slot_for_the_lease_then_frees_it(tmp_path, monkeypatch):
    assert CLAIM_LEASE_S == 120  # docs/FORMATS.md §8 states this number
    s = Store(tmp_path / "v.sqlite", "s")
    assert s.next_item("gone", _first_free) == "x"  # claimed, never voted on
    assert s.next_item("ann", _first_free) == "y"  # x is held by the claim
    s.record_shown_vote("ann", "y", 1, session="t")
    _later(monkeypatch, CLAIM_LEASE_S - 5)
    assert s.next_item("cat", _first_free) is None  # still within the lease
    _later(monkeypatch, CLAIM_LEASE_S + 5)
    assert s.next_item("cat", _first_free) == "x"  # lease over: x is free again
    # the claimant coming back gets its own open item (its lease is not renewed: issue 38)
    assert s.next_item("gone", _first_free) == "x"
    assert s.next_item("dan", _first_free) is None
    s.record_shown_vote("gone", "x", 0, session="g")  # a vote ends its claim
    seen = {}
    s.next_item("eve", lambda a, v, loads: seen.update(loads))
    assert seen == {"x": 2, "y": 1}  # two votes and cat's live claim on x
    _later(monkeypatch, 2 * CLAIM_LEASE_S + 10)  # cat's lease is over too
    seen.clear()
    s.next_item("fay", lambda a, v, loads: seen.update(loads))
    assert seen == {"x": 1, "y": 1}  # only the votes


def test_attack_sybil_claim_flood_cannot_lock_out_a_real_rater(tmp_path, monkeypatch):
    """Thirty names that only start and walk away; quota 2, twelve test items (24 slots)."""
    study = _binary(tmp_path, tracks=2, frames_per_track=2, n_training=0, votes_per_item=2)
    tests = set(study.keys("test"))
    assert len(tests) == 12
    sybils = [f"sybil{i}" for i in range(30)]
    claimed = [study.next_item(name) for name in sybils]
    assert set(claimed[:24]) == tests  # every slot of every test item is claimed
    got = []
    while (key := study.next_item("carol")) is not None:  # carol votes on whatever is free
        study.store.record_shown_vote("carol", key, 1, session="c")
        got.append(key)
    assert not tests & set(got)  # nothing free yet: only the golds (repeats need an original)
    assert study.waiting("carol")  # "no item is free right now", never "all done"
    _later(monkeypatch, CLAIM_LEASE_S + 1)  # the sybils' leases run out
    while (key := study.next_item("carol")) is not None:
        study.store.record_shown_vote("carol", key, 1, session="c")
        got.append(key)
    assert len(got) == len(set(got))  # each item once
    gold = set(study.keys("gold"))
    # every item but the gold pool's, and carol's own share of the pool (issue 38, item 31)
    assert set(got) - gold == set(study.items.index) - gold
    assert len(set(got) & gold) == study.gold_per_rater
    assert not study.waiting("carol")


@pytest.mark.parametrize("design", sorted(DESIGNS))
def test_attack_sybil_flood_in_the_app_says_retry_never_all_done(design, tmp_path, monkeypatch):
    build, vote_button = DESIGNS[design]
    study = build(tmp_path, n_training=0, votes_per_item=1)
    n_tests = len(study.keys("test"))
    assert n_tests == 3  # one object in one frame at three offsets (pairwise: one pair of methods)
    monkeypatch.setenv("ANNOTATE_STUDY", str(study.root))
    for i in range(n_tests):  # names that press Start, see an item, and leave
        _app(rater=f"sybil{i}").button(key="start").click().run()
    at = _app(rater="carol")
    at.button(key="start").click().run()
    while any(b.key.startswith(vote_button + "-") for b in at.button if b.key):
        _btn(at, vote_button).click().run()
    text = _page_text(at)
    assert "No item is free right now" in text and "All done" not in text
    assert not set(study.keys("test")) & set(study.store.votes("carol")["item"])
    _later(monkeypatch, CLAIM_LEASE_S + 1)
    at.button(key="retry").click().run()
    while any(b.key.startswith(vote_button + "-") for b in at.button if b.key):
        _btn(at, vote_button).click().run()
    assert "All done" in at.success[0].value
    got = study.store.votes("carol")["item"].tolist()
    gold = set(study.keys("gold"))  # carol sees her share of the gold pool (issue 38, item 31)
    assert set(got) - gold == set(study.items.index) - gold and len(got) == len(set(got))
    assert len(set(got) & gold) == study.gold_per_rater


# ---- too-fast presses -----------------------------------------------------------------------

def test_too_fast_press_is_told_and_counted(tmp_path, monkeypatch, capsys):
    study = _binary(tmp_path)
    monkeypatch.setenv("ANNOTATE_STUDY", str(study.root))
    monkeypatch.setenv("ANNOTATE_MIN_RESPONSE_MS", "60000")  # any press is too fast
    at = _app(rater="kit")
    at.button(key="start").click().run()
    shown = _current(at)
    for _ in range(2):
        _btn(at, "vote_good").click().run()
    assert any("Too fast" in w.value for w in at.warning)
    assert study.store.votes("kit").empty and _current(at) == shown
    hist = study.store.history()
    assert hist["action"].tolist() == ["too_fast", "too_fast"] and (hist["item"] == shown).all()
    assert main(["export", str(study.root), "--out", str(tmp_path / "out.csv")]) == 0
    assert "rater kit: 0 votes undone, 2 presses too fast" in capsys.readouterr().err


# ---- schema migration -----------------------------------------------------------------------

# The store's layout before sessions and leases (annotate/store.py up to issue 30), with the
# rows of a small study: two votes, one of them undone once and cast again, and an open claim.
_V0 = """
CREATE TABLE raters (study TEXT NOT NULL, rater TEXT NOT NULL, token_sha256 TEXT,
    created_at TEXT NOT NULL, plan TEXT NOT NULL DEFAULT '{}', UNIQUE (study, rater));
CREATE TABLE assignments (id INTEGER PRIMARY KEY AUTOINCREMENT, study TEXT NOT NULL,
    rater TEXT NOT NULL, item TEXT NOT NULL, assigned_at REAL NOT NULL, UNIQUE (study, rater, item));
CREATE TABLE votes (study TEXT NOT NULL, rater TEXT NOT NULL, item TEXT NOT NULL,
    vote INTEGER NOT NULL CHECK (vote IN (0, 1)), voted_at TEXT NOT NULL, response_ms INTEGER,
    UNIQUE (study, rater, item));
CREATE TABLE history (id INTEGER PRIMARY KEY AUTOINCREMENT, study TEXT NOT NULL,
    rater TEXT NOT NULL, item TEXT NOT NULL, action TEXT NOT NULL CHECK (action IN ('vote', 'undo')),
    vote INTEGER, at TEXT NOT NULL, response_ms INTEGER);
CREATE INDEX assignments_item ON assignments (study, item);
CREATE TABLE skipped (study TEXT NOT NULL, rater TEXT NOT NULL, item TEXT NOT NULL,
    at TEXT NOT NULL, reason TEXT, UNIQUE (study, rater, item));
INSERT INTO assignments (study, rater, item, assigned_at) VALUES
    ('s', 'ann', 'a', 1.0), ('s', 'ann', 'b', 2.0), ('s', 'bob', 'c', {recent});
INSERT INTO votes VALUES ('s', 'ann', 'a', 1, '2026-01-01T00:00:01.000Z', 800),
    ('s', 'ann', 'b', 0, '2026-01-01T00:00:04.000Z', 700);
INSERT INTO history (study, rater, item, action, vote, at, response_ms) VALUES
    ('s', 'ann', 'a', 'vote', 1, '2026-01-01T00:00:01.000Z', 800),
    ('s', 'ann', 'b', 'vote', 1, '2026-01-01T00:00:02.000Z', 600),
    ('s', 'ann', 'b', 'undo', NULL, '2026-01-01T00:00:03.000Z', NULL),
    ('s', 'ann', 'b', 'vote', 0, '2026-01-01T00:00:04.000Z', 700);
"""


def _old_store(path) -> list[tuple]:
    con = sqlite3.connect(path)
    con.executescript(_V0.replace("{recent}", repr(time.time())))
    rows = con.execute("SELECT * FROM history ORDER BY id").fetchall()
    con.close()
    return rows


def test_a_store_of_the_old_layout_is_migrated_with_every_row_kept(tmp_path):
    db = tmp_path / "votes.sqlite"
    old_history = _old_store(db)
    s = Store(db, "s")
    con = sqlite3.connect(db)
    assert con.execute("PRAGMA user_version").fetchone()[0] == SCHEMA_VERSION
    assert con.execute("SELECT * FROM history ORDER BY id").fetchall() == [
        (*row, None) for row in old_history]  # same ids and values, no session
    assert s.votes()[["item", "vote"]].values.tolist() == [["a", 1], ["b", 0]]
    # old votes belong to no session: nothing can undo them
    assert s.undo_last("ann", session="any") is None
    # bob's open claim (assigned just now) still holds c; ann's voted items hold no claim
    seen = {}
    s.next_item("cat", lambda a, v, loads: seen.update(loads))
    assert seen == {"a": 1, "b": 1, "c": 1}
    # the log continues after the old ids and takes the new actions
    s.record_too_fast("ann", "c", 1, response_ms=90, session="t")
    hist = s.history()
    assert hist["id"].tolist() == [1, 2, 3, 4, 5] and hist["action"].iloc[-1] == "too_fast"
    con.close()


def test_servers_opening_an_old_store_at_once_migrate_it_once(tmp_path):
    db = tmp_path / "votes.sqlite"
    old_history = _old_store(db)
    errors = []

    def open_store():
        try:
            Store(db, "s")
        except Exception as exc:  # pragma: no cover - reported below
            errors.append(exc)

    threads = [threading.Thread(target=open_store) for _ in range(6)]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    assert not errors
    con = sqlite3.connect(db)
    assert con.execute("SELECT * FROM history ORDER BY id").fetchall() == [
        (*row, None) for row in old_history]
    con.close()


def test_export_counts_read_singular_at_one(tmp_path, capsys):
    """Issue 38 item 17: "1 votes undone", "1 presses too fast" and "1 votes ->" read as
    singular nouns (data_schema.text.plural)."""
    study = _binary(tmp_path)
    first, second = study.next_item("kit"), None
    assert study.store.record_shown_vote("kit", first, 1, session="s") == "recorded"
    second = study.next_item("kit")
    assert study.store.record_shown_vote("kit", second, 1, session="s") == "recorded"
    assert study.store.undo_last("kit", session="s") == second  # 1 vote undone, 1 standing
    study.store.record_too_fast("kit", second, 1, response_ms=10, session="s")
    assert main(["export", str(study.root), "--out", str(tmp_path / "out.csv")]) == 0
    err = capsys.readouterr().err
    assert "rater kit: 1 vote undone, 1 press too fast" in err and "\n1 vote -> " in "\n" + err


def test_screening_text_reads_singular_at_one():
    """Issue 38 item 17 in the report: "No rater excluded (1 raters)" read wrong."""
    import pandas as pd

    from analysis.common.text import screening_text

    one = pd.DataFrame({"rater_id": ["ann"], "flags": [""], "excluded": [False], "excluded_reason": [""]})
    assert screening_text(one, applied=True) == "No rater excluded (1 rater)."
