"""The vote store: one SQLite file per study, safe for many raters at once.

Every vote is committed at once (WAL journal, ``synchronous=FULL``, a busy timeout) so a vote
the app has acknowledged survives a killed server. Each operation takes a connection of its
own from a small per-process pool (:data:`POOL_SIZE`): opening one costs a parse of the schema,
about 1 ms a vote; a pooled connection is used only while the file is still the one it opened.
``votes`` holds one row per ``(study, rater, item)`` (a changed vote replaces the old one);
``history`` is append-only and records every vote, undo and too-fast press with its time and
the browser session it came from.

The store also hands out items: :meth:`Store.next_item` returns the rater's next unrated
item, assigning a new one (see :mod:`annotate.chooser`) inside one
``BEGIN IMMEDIATE`` transaction so two raters never race for the last slot of an item. An
assigned item without a vote is a *claim* that holds one of the item's ``votes_per_item``
slots for :data:`CLAIM_LEASE_S` seconds after it was drawn (never renewed), then frees it.

Undo is bounded (:meth:`Store.undo_last`): a browser session can take back only its own
:data:`UNDO_DEPTH` most recent votes, never a vote of an earlier session of the same rater.

>>> import tempfile, pathlib
>>> s = Store(pathlib.Path(tempfile.mkdtemp()) / "votes.sqlite", "demo")
>>> s.record_vote("ann", "item-1", 1, response_ms=800)
>>> s.record_vote("ann", "item-1", 0, response_ms=500)   # changed vote replaces the old one
>>> s.votes()[["rater", "item", "vote"]].values.tolist()
[['ann', 'item-1', 0]]
>>> len(s.history())
2
"""

from __future__ import annotations

import contextlib
import hashlib
import hmac
import json
import os
import sqlite3
import threading
import time
from collections.abc import Callable, Iterator
from datetime import datetime, timezone
from pathlib import Path

import pandas as pd

from data_schema.errors import InputError

__all__ = ["Store", "utc_now_iso", "token_digest", "UNDO_DEPTH", "CLAIM_LEASE_S", "SCHEMA_VERSION"]

#: How many of its own most recent votes a browser session can undo.
UNDO_DEPTH = 3
#: Seconds an item handed out but not voted on holds its slot, counted from the draw (showing
#: it again does not renew it: only a vote or a skip ends a claim early).
CLAIM_LEASE_S = 120.0
#: ``PRAGMA user_version`` of a store file in the current layout (0: before sessions and
#: leases; 1: before the token index).
SCHEMA_VERSION = 2

_SCHEMA = """
CREATE TABLE IF NOT EXISTS raters (
    study TEXT NOT NULL, rater TEXT NOT NULL, token_sha256 TEXT, created_at TEXT NOT NULL,
    plan TEXT NOT NULL DEFAULT '{}', UNIQUE (study, rater));
CREATE TABLE IF NOT EXISTS assignments (
    id INTEGER PRIMARY KEY AUTOINCREMENT, study TEXT NOT NULL, rater TEXT NOT NULL,
    item TEXT NOT NULL, assigned_at REAL NOT NULL, active_at REAL, UNIQUE (study, rater, item));
CREATE TABLE IF NOT EXISTS votes (
    study TEXT NOT NULL, rater TEXT NOT NULL, item TEXT NOT NULL,
    vote INTEGER NOT NULL CHECK (vote IN ({votes})), voted_at TEXT NOT NULL, response_ms INTEGER,
    UNIQUE (study, rater, item));
{history}CREATE INDEX IF NOT EXISTS assignments_item ON assignments (study, item);
CREATE TABLE IF NOT EXISTS skipped (
    study TEXT NOT NULL, rater TEXT NOT NULL, item TEXT NOT NULL, at TEXT NOT NULL,
    reason TEXT, UNIQUE (study, rater, item));
CREATE TABLE IF NOT EXISTS participants (
    study TEXT NOT NULL, rater TEXT NOT NULL, participant TEXT NOT NULL, arrived_at TEXT NOT NULL,
    UNIQUE (study, participant));
"""

# The append-only log ({name}: the migration builds the new layout beside the old one).
_HISTORY = """
CREATE TABLE IF NOT EXISTS {name} (
    id INTEGER PRIMARY KEY AUTOINCREMENT, study TEXT NOT NULL, rater TEXT NOT NULL,
    item TEXT NOT NULL, action TEXT NOT NULL CHECK (action IN ('vote', 'undo', 'too_fast')),
    vote INTEGER, at TEXT NOT NULL, response_ms INTEGER, session TEXT);
"""

# Version 0 -> 1 (sessions and claim leases), in one transaction; each step checks the
# columns first, so a file made in the new layout only gets the indexes and the version.
_INDEXES_V1 = """
CREATE INDEX IF NOT EXISTS history_session ON history (study, rater, session);
CREATE INDEX IF NOT EXISTS assignments_live ON assignments (study, active_at);
"""

# Version 1 -> 2: a token is looked up through an index on its digest, never by reading
# every rater (measured: 107 ms a wrong token at 6,300 raters).
_INDEXES_V2 = """
CREATE INDEX IF NOT EXISTS raters_token ON raters (study, token_sha256);
"""

# Per-item counters kept by triggers, so handing out an item reads one row per item instead
# of every rater's assignments and votes: ``voted`` standing votes, ``claimed`` assignments
# without a vote, ``last_claim`` the newest assignment time. (Item hand-out reads ``voted``
# only; live claims come from ``assignments.active_at``, whose lease is per claim.)
_LOADS = """
CREATE TABLE item_loads (
    study TEXT NOT NULL, item TEXT NOT NULL, voted INTEGER NOT NULL DEFAULT 0,
    claimed INTEGER NOT NULL DEFAULT 0, last_claim REAL NOT NULL DEFAULT 0,
    PRIMARY KEY (study, item));
CREATE TRIGGER item_loads_assign AFTER INSERT ON assignments BEGIN
    INSERT INTO item_loads (study, item, claimed, last_claim) VALUES
        (NEW.study, NEW.item, 1, NEW.assigned_at)
    ON CONFLICT (study, item) DO UPDATE SET claimed = claimed + 1, last_claim = NEW.assigned_at;
END;
CREATE TRIGGER item_loads_vote AFTER INSERT ON votes BEGIN
    INSERT INTO item_loads (study, item, voted) VALUES (NEW.study, NEW.item, 1)
    ON CONFLICT (study, item) DO UPDATE SET voted = voted + 1, claimed = claimed - (
        SELECT COUNT(*) FROM assignments a WHERE a.study = NEW.study AND a.rater = NEW.rater
        AND a.item = NEW.item);
END;
CREATE TRIGGER item_loads_unvote AFTER DELETE ON votes BEGIN
    UPDATE item_loads SET voted = voted - 1, claimed = claimed + (
        SELECT COUNT(*) FROM assignments a WHERE a.study = OLD.study AND a.rater = OLD.rater
        AND a.item = OLD.item) WHERE study = OLD.study AND item = OLD.item;
END;
INSERT INTO item_loads (study, item, voted, claimed, last_claim)
    SELECT study, item, SUM(voted), SUM(claimed), MAX(last_claim) FROM (
        SELECT study, item, 1 AS voted, 0 AS claimed, 0 AS last_claim FROM votes
        UNION ALL
        SELECT a.study, a.item, 0, 1, a.assigned_at FROM assignments a WHERE NOT EXISTS (
            SELECT 1 FROM votes v WHERE v.study = a.study AND v.rater = a.rater
            AND v.item = a.item)
        UNION ALL
        SELECT study, item, 0, 0, assigned_at FROM assignments)
    GROUP BY study, item;
"""


def _clock() -> float:
    """Seconds since the epoch for claim leases (one place, so tests can move time on)."""
    return time.time()


def utc_iso(t: datetime) -> str:
    """``t`` (aware) as ISO 8601 in UTC with milliseconds, e.g. ``2026-01-01T12:00:00.123Z``."""
    return t.astimezone(timezone.utc).strftime("%Y-%m-%dT%H:%M:%S.%f")[:-3] + "Z"


def utc_now_iso() -> str:
    """Current time, ISO 8601 in UTC with milliseconds, e.g. ``2026-01-01T12:00:00.123Z``.

    Returns
    -------
    str
        The current UTC time in that format.
    """
    return utc_iso(datetime.now(timezone.utc))


def token_digest(token: str) -> str:
    """SHA-256 hex digest under which a rater token is stored (the token itself is not).

    Parameters
    ----------
    token : str
        The rater's sign-in token.

    Returns
    -------
    str
        64 lowercase hex digits: SHA-256 of the token's UTF-8 bytes.
    """
    return hashlib.sha256(token.encode("utf-8")).hexdigest()


#: the stored votes of a good/bad study and what they mean
BINARY_VOTES = {1: "good", 0: "bad"}


def _check_vote(rater: str, item: str, vote, votes: dict[int, str]) -> None:
    """Raise :class:`InputError` unless ``vote`` is one of ``votes`` (an int, not a bool)."""
    if vote not in votes or isinstance(vote, bool):
        named = [f"{v} ({what})" for v, what in votes.items()]
        raise InputError(param="vote", field=f"{rater}/{item}", expected=", ".join(named[:-1]) + " or " + named[-1],
                         got=repr(vote))


def _columns(con: sqlite3.Connection, table: str) -> set[str]:
    return {row[1] for row in con.execute(f"PRAGMA table_info({table})")}


def _migrate(con: sqlite3.Connection) -> None:
    """Bring a store file to :data:`SCHEMA_VERSION` in one transaction; every row is kept.

    Version 1 adds ``history.session`` and the ``too_fast`` action (SQLite cannot change a
    CHECK constraint, so the log is copied, ids included, into a table of the new layout)
    and ``assignments.active_at``, the start of a claim's lease (an unvoted assignment's is
    its assignment time). Version 2 adds the index ``raters_token`` on the token digests
    (:meth:`Store.rater_for_token`). Another process migrating at the same time waits, then finds the
    version set and does nothing.
    """
    con.execute("BEGIN IMMEDIATE")
    try:
        version = con.execute("PRAGMA user_version").fetchone()[0]
        if version >= SCHEMA_VERSION:  # another process migrated it meanwhile
            con.execute("COMMIT")
            return
        if version < 1:
            if "session" not in _columns(con, "history"):
                con.execute(_HISTORY.replace("{name}", "history_v1"))
                con.execute("INSERT INTO history_v1 (id, study, rater, item, action, vote, at, "
                            "response_ms) SELECT id, study, rater, item, action, vote, at, "
                            "response_ms FROM history ORDER BY id")
                con.execute("DROP TABLE history")
                con.execute("ALTER TABLE history_v1 RENAME TO history")
            if "active_at" not in _columns(con, "assignments"):
                con.execute("ALTER TABLE assignments ADD COLUMN active_at REAL")
                con.execute("UPDATE assignments SET active_at = assigned_at WHERE NOT EXISTS ("
                            "SELECT 1 FROM votes v WHERE v.study = assignments.study AND "
                            "v.rater = assignments.rater AND v.item = assignments.item)")
            for statement in _INDEXES_V1.split(";")[:-1]:  # (executescript would commit)
                con.execute(statement)
        for statement in _INDEXES_V2.split(";")[:-1]:  # version 2: the token index
            con.execute(statement)
        con.execute(f"PRAGMA user_version = {SCHEMA_VERSION}")
    except BaseException:
        con.execute("ROLLBACK")
        raise
    con.execute("COMMIT")


def _ensure_wal(con: sqlite3.Connection, timeout_s: float) -> None:
    """Switch the file to WAL unless it already is; retried until ``timeout_s``.

    Changing the journal mode needs an exclusive lock, and SQLite reports "database is locked"
    at once (no busy handler) when another connection holds the file, as when several servers
    open an old rollback-journal store together; the first to get the lock switches it.
    """
    deadline = time.monotonic() + timeout_s
    while True:
        try:
            if con.execute("PRAGMA journal_mode").fetchone()[0].lower() != "wal":
                con.execute("PRAGMA journal_mode = WAL")
            return
        except sqlite3.OperationalError as err:
            if "locked" not in str(err) or time.monotonic() > deadline:
                raise
            time.sleep(0.01)


#: Idle connections a :class:`Store` keeps for reuse (more at once are opened and closed).
POOL_SIZE = 8


class Store:
    """Votes, raters and assignments of one study in the SQLite file ``path``.

    Parameters
    ----------
    path : str or pathlib.Path
        The SQLite file; created (with its schema) if absent.
    study : str
        The study id the votes are recorded under.
    busy_timeout_ms : int
        How long (ms) an operation waits for another process's lock.
    synchronous : str
        ``'FULL'`` (default: every commit synced to disk) or ``'NORMAL'`` (see ``__init__``).
    votes : dict of int to str or None
        The vote values a new file accepts and their meaning; None for :data:`BINARY_VOTES`.
    """

    def __init__(self, path: str | Path, study: str, *, busy_timeout_ms: int = 30000,
                 synchronous: str = "FULL", votes: dict[int, str] | None = None):
        """``synchronous`` in {'FULL', 'NORMAL'}: FULL (default, the app) syncs every commit
        to disk, so an acknowledged vote survives even a power cut; NORMAL survives a killed
        process (WAL) but not an OS crash, and saves a disk sync (~3-10 ms) per vote.
        ``votes``: the vote values a new file accepts and their meaning (default
        :data:`BINARY_VOTES`, 1 good / 0 bad; a pairwise study: 1 left, 2 right, 0 can't tell)."""
        if synchronous not in ("FULL", "NORMAL"):
            raise InputError("Store", "synchronous", "one of {'FULL', 'NORMAL'}", synchronous)
        self.votes_allowed = dict(BINARY_VOTES if votes is None else votes)
        self.path = Path(path)
        self.study = str(study)
        self.busy_timeout_ms = int(busy_timeout_ms)
        self.synchronous = synchronous
        self._uri = self.path.resolve().as_uri()
        self._pool: list[tuple[sqlite3.Connection, str, tuple[int, int] | None]] = []
        self._pool_lock = threading.Lock()
        with self._connect(create=True) as con:
            con.executescript(_SCHEMA.replace("{votes}", ", ".join(map(str, sorted(self.votes_allowed))))
                              .replace("{history}", _HISTORY.replace("{name}", "history")))
            if not con.execute("SELECT 1 FROM sqlite_master WHERE name = 'item_loads'").fetchone():
                try:  # first use of this file: counters, triggers and backfill in one go
                    con.executescript("BEGIN IMMEDIATE;" + _LOADS + "COMMIT;")
                except sqlite3.OperationalError as err:  # another process was first
                    if con.in_transaction:
                        con.execute("ROLLBACK")
                    if "already exists" not in str(err):
                        raise
            if con.execute("PRAGMA user_version").fetchone()[0] < SCHEMA_VERSION:
                _migrate(con)
        # An idle connection held open for the store's lifetime: closing the *last* connection
        # of a WAL database checkpoints it (a sync each time); operations still each open
        # their own connection.
        self._keeper = sqlite3.connect(self.path, check_same_thread=False)
        self._keeper.execute("SELECT COUNT(*) FROM raters").fetchall()  # opens the WAL

    @contextlib.contextmanager
    def _connect(self, *, create: bool = False,
                 synchronous: str | None = None) -> Iterator[sqlite3.Connection]:
        """A connection of this operation alone (autocommit mode; transactions are explicit).

        Taken from the pool while the file is still the one the pooled connections opened
        (same device and inode: one ``stat``), else newly opened; given back afterwards
        unless the operation failed or left a transaction open. Only the constructor may
        create the file: a database deleted under a running server is an error, never
        silently replaced by an empty one (a deleted or replaced file empties the pool).
        """
        sync = synchronous or self.synchronous
        if create:
            con = self._open(f"{self._uri}?mode=rwc", sync)
            try:
                yield con
            finally:
                con.close()
            return
        con, ident = self._take(sync)
        try:
            yield con
        except BaseException:
            con.close()
            raise
        if con.in_transaction:
            con.close()
            return
        with self._pool_lock:
            if len(self._pool) < POOL_SIZE:
                self._pool.append((con, sync, ident))
                return
        con.close()

    def _take(self, sync: str) -> tuple[sqlite3.Connection, tuple[int, int] | None]:
        """A pooled connection to the file as it is now, else a new one; and the file's identity."""
        try:
            st = os.stat(self.path)
            ident = (st.st_dev, st.st_ino)
        except OSError:
            ident = None
        with self._pool_lock:  # those of a deleted or replaced file are closed
            stale = [e for e in self._pool if e[2] != ident]
            if stale:
                self._pool = [e for e in self._pool if e[2] == ident]
            entry = self._pool.pop() if self._pool else None
        for old, _sync, _ident in stale:
            old.close()
        if entry is None:  # a file replaced since the stat makes it stale at its next use
            return self._open(f"{self._uri}?mode=rw", sync), ident
        con, was, _ = entry
        if was != sync:
            con.execute(f"PRAGMA synchronous = {sync}")
        return con, ident

    def _open(self, uri: str, sync: str) -> sqlite3.Connection:
        con = sqlite3.connect(uri, uri=True, timeout=self.busy_timeout_ms / 1000,
                              isolation_level=None, check_same_thread=False)
        try:
            con.execute(f"PRAGMA busy_timeout = {self.busy_timeout_ms}")
            _ensure_wal(con, self.busy_timeout_ms / 1000)
            con.execute(f"PRAGMA synchronous = {sync}")
        except BaseException:
            con.close()
            raise
        return con

    @contextlib.contextmanager
    def _transaction(self, *, synchronous: str | None = None) -> Iterator[sqlite3.Connection]:
        with self._connect(synchronous=synchronous) as con:
            con.execute("BEGIN IMMEDIATE")
            try:
                yield con
            except BaseException:
                con.execute("ROLLBACK")
                raise
            con.execute("COMMIT")

    # ---- votes ---------------------------------------------------------------------------
    def record_vote(self, rater: str, item: str, vote: int, *, response_ms: int | None = None,
                    voted_at: str | None = None) -> None:
        """Store ``vote`` (1 good, 0 bad; see ``votes``) of ``rater`` on ``item``; durable
        when this returns."""
        _check_vote(rater, item, vote, self.votes_allowed)
        at = voted_at or utc_now_iso()
        rt = None if response_ms is None else int(response_ms)
        with self._transaction() as con:
            self._insert_vote(con, rater, item, vote, at, rt, None)

    def shift_vote_times(self, raters: list[str], seconds: float) -> None:
        """Move every vote time of ``raters`` (votes and their history) by ``seconds``; the
        simulated raters' clock is moved back with it so that no vote lies in the future."""
        shift = f"{float(seconds):+.3f} seconds"
        fmt = "strftime('%Y-%m-%dT%H:%M:%fZ', {col}, ?)"
        with self._transaction() as con:
            for rater in raters:
                con.execute(f"UPDATE votes SET voted_at = {fmt.format(col='voted_at')} "
                            "WHERE study = ? AND rater = ?", (shift, self.study, rater))
                con.execute(f"UPDATE history SET at = {fmt.format(col='at')} "
                            "WHERE study = ? AND rater = ?", (shift, self.study, rater))

    def record_shown_vote(self, rater: str, item: str, vote: int, *,
                          response_ms: int | None = None, session: str | None = None) -> str:
        """Record the vote of ``rater`` on ``item`` only if the item is theirs and still open.

        Returns ``'recorded'``, ``'already'`` (the rater voted on it already, e.g. in another
        tab: the standing vote is kept) or ``'unassigned'`` (not an item handed to the rater).
        The check and the write are one transaction, so two tabs cannot both record.
        ``session``: the browser session that cast it (logged; :meth:`undo_last` reaches only
        the votes of its own session).
        """
        _check_vote(rater, item, vote, self.votes_allowed)
        at, rt = utc_now_iso(), None if response_ms is None else int(response_ms)
        with self._transaction() as con:
            if con.execute("SELECT 1 FROM votes WHERE study = ? AND rater = ? AND item = ?",
                           (self.study, rater, item)).fetchone():
                return "already"
            if not con.execute("SELECT 1 FROM assignments WHERE study = ? AND rater = ? AND item = ?",
                               (self.study, rater, item)).fetchone():
                return "unassigned"
            self._insert_vote(con, rater, item, vote, at, rt, session)  # no standing vote: an insert
        return "recorded"

    def record_too_fast(self, rater: str, item: str, vote: int, *, response_ms: int,
                        session: str | None = None) -> None:
        """Log a press that came too soon after ``item`` was drawn (it is not a vote)."""
        _check_vote(rater, item, vote, self.votes_allowed)
        with self._transaction(synchronous="NORMAL") as con:
            con.execute("INSERT INTO history (study, rater, item, action, vote, at, response_ms, "
                        "session) VALUES (?, ?, ?, 'too_fast', ?, ?, ?, ?)",
                        (self.study, rater, item, int(vote), utc_now_iso(), int(response_ms), session))

    def _insert_vote(self, con: sqlite3.Connection, rater: str, item: str, vote: int, at: str,
                     rt: int | None, session: str | None) -> None:
        """Write the vote (replacing a standing one) and its history row, and end the rater's
        claim on the item, inside ``con``'s transaction."""
        con.execute(
            "INSERT INTO votes (study, rater, item, vote, voted_at, response_ms) "
            "VALUES (?, ?, ?, ?, ?, ?) ON CONFLICT (study, rater, item) DO UPDATE SET "
            "vote = excluded.vote, voted_at = excluded.voted_at, response_ms = excluded.response_ms",
            (self.study, rater, item, int(vote), at, rt))
        con.execute(
            "INSERT INTO history (study, rater, item, action, vote, at, response_ms, session) "
            "VALUES (?, ?, ?, 'vote', ?, ?, ?, ?)", (self.study, rater, item, int(vote), at, rt,
                                                    session))
        con.execute("UPDATE assignments SET active_at = NULL WHERE study = ? AND rater = ? AND "
                    "item = ?", (self.study, rater, item))

    def skip(self, rater: str, item: str, *, reason: str) -> None:
        """Take ``item`` out of the rater's queue (it cannot be shown); it is never handed out
        again, and the rater's claim on it ends."""
        with self._transaction() as con:
            con.execute("INSERT OR IGNORE INTO skipped (study, rater, item, at, reason) VALUES "
                        "(?, ?, ?, ?, ?)", (self.study, rater, item, utc_now_iso(), reason))
            con.execute("UPDATE assignments SET active_at = NULL WHERE study = ? AND rater = ? "
                        "AND item = ?", (self.study, rater, item))  # a skip ends its claim

    def undo_last(self, rater: str, *, session: str, depth: int = UNDO_DEPTH) -> str | None:
        """Take back the newest vote of ``rater`` that ``session`` cast and that still stands,
        among the ``depth`` most recent votes of that session; returns its item (or None).

        A vote stands for this session while it is the item's latest vote or undo in the log
        (not undone, not replaced since). A session that cast no vote undoes nothing, so
        opening the rater's link again cannot erase earlier work. The undo is logged, and
        the item is the rater's claim again (a new lease of :data:`CLAIM_LEASE_S` from the
        undo), so its slot is not handed to another rater while the rater votes again.

        >>> import tempfile, pathlib
        >>> s = Store(pathlib.Path(tempfile.mkdtemp()) / "votes.sqlite", "demo")
        >>> for item in "abcd":
        ...     _ = s.next_item("ann", lambda *_: item)
        ...     _ = s.record_shown_vote("ann", item, 1, session="tab1")
        >>> s.undo_last("ann", session="tab2")  # another session: nothing of tab1's
        >>> [s.undo_last("ann", session="tab1") for _ in range(4)]  # at most the last 3
        ['d', 'c', 'b', None]
        """
        if not session:
            raise InputError("undo_last", "session", "the browser session's id", repr(session))
        with self._transaction() as con:
            item = None
            for hid, candidate in con.execute(
                    "SELECT id, item FROM history WHERE study = ? AND rater = ? AND session = ? "
                    "AND action = 'vote' ORDER BY id DESC LIMIT ?",
                    (self.study, rater, session, int(depth))).fetchall():
                latest = con.execute(
                    "SELECT MAX(id) FROM history WHERE study = ? AND rater = ? AND item = ? AND "
                    "action IN ('vote', 'undo')", (self.study, rater, candidate)).fetchone()[0]
                if latest == hid:
                    item = candidate
                    break
            if item is None or not con.execute(
                    "DELETE FROM votes WHERE study = ? AND rater = ? AND item = ?",
                    (self.study, rater, item)).rowcount:
                return None
            con.execute("INSERT INTO history (study, rater, item, action, vote, at, session) "
                        "VALUES (?, ?, ?, 'undo', NULL, ?, ?)",
                        (self.study, rater, item, utc_now_iso(), session))
            # the item is the rater's open item again: its claim holds the slot (a new lease
            # from the undo), so no other rater takes it past its quota or cap meanwhile
            con.execute("UPDATE assignments SET active_at = ? WHERE study = ? AND rater = ? AND "
                        "item = ?", (_clock(), self.study, rater, item))
        return item

    def votes(self, rater: str | None = None) -> pd.DataFrame:
        """Current votes: columns rater, item, vote, voted_at, response_ms (oldest first)."""
        sql = "SELECT rater, item, vote, voted_at, response_ms FROM votes WHERE study = ?"
        params: tuple = (self.study,)
        if rater is not None:
            sql, params = sql + " AND rater = ?", params + (rater,)
        with self._connect() as con:
            return pd.read_sql_query(sql + " ORDER BY voted_at, rowid", con, params=params)

    def other_study_votes(self) -> int:
        """Votes in the file recorded under another study id (a study rebuilt in this folder)."""
        with self._connect() as con:
            return int(con.execute("SELECT COUNT(*) FROM votes WHERE study != ?",
                                   (self.study,)).fetchone()[0])

    def history(self) -> pd.DataFrame:
        """The append-only log: columns id, rater, item, action (``'vote'``, ``'undo'`` or
        ``'too_fast'``, a press that did not count), vote, at, response_ms, session (the
        browser session; empty for rows written before sessions were logged)."""
        with self._connect() as con:
            return pd.read_sql_query(
                "SELECT id, rater, item, action, vote, at, response_ms, session FROM history "
                "WHERE study = ? ORDER BY id", con, params=(self.study,))

    def action_counts(self) -> pd.DataFrame:
        """Per rater with any history: columns rater, votes_undone (undo rows) and too_fast
        (presses dropped as too fast), from the log."""
        with self._connect() as con:
            return pd.read_sql_query(
                "SELECT rater, SUM(action = 'undo') AS votes_undone, SUM(action = 'too_fast') "
                "AS too_fast FROM history WHERE study = ? GROUP BY rater ORDER BY MIN(id)",
                con, params=(self.study,))

    # ---- raters --------------------------------------------------------------------------
    def add_rater(self, rater: str, *, plan: dict, token: str | None = None) -> bool:
        """Register ``rater`` with its item plan (JSON-able); False if already registered.

        A given ``token`` replaces the stored one (the plan of a known rater is kept).
        """
        with self._transaction() as con:
            known = con.execute("SELECT 1 FROM raters WHERE study = ? AND rater = ?",
                                (self.study, rater)).fetchone()
            if known is None:
                con.execute("INSERT INTO raters (study, rater, token_sha256, created_at, plan) "
                            "VALUES (?, ?, ?, ?, ?)",
                            (self.study, rater, token and token_digest(token), utc_now_iso(),
                             json.dumps(plan)))
            elif token is not None:
                con.execute("UPDATE raters SET token_sha256 = ? WHERE study = ? AND rater = ?",
                            (token_digest(token), self.study, rater))
        return known is None

    def raters(self) -> list[str]:
        with self._connect() as con:
            rows = con.execute("SELECT rater FROM raters WHERE study = ? ORDER BY created_at, rowid",
                               (self.study,)).fetchall()
        return [r[0] for r in rows]

    def plan(self, rater: str) -> dict | None:
        with self._connect() as con:
            row = con.execute("SELECT plan FROM raters WHERE study = ? AND rater = ?",
                              (self.study, rater)).fetchone()
        return None if row is None else json.loads(row[0])

    def rater_for_token(self, token: str) -> str | None:
        """The rater whose token is ``token``, else None.

        The digest is looked up through the index ``raters_token`` (one B-tree search, so a
        wrong token costs the same at 10 or 10,000 raters) and the row found is compared
        with it again in constant time.
        """
        if not token:
            return None
        digest = token_digest(token)
        with self._connect() as con:
            row = con.execute("SELECT rater, token_sha256 FROM raters WHERE study = ? AND "
                              "token_sha256 = ? LIMIT 1", (self.study, digest)).fetchone()
        if row is None or not hmac.compare_digest(str(row[1]), digest):
            return None
        return row[0]

    def record_participant(self, rater: str, participant: str) -> None:
        """Record that crowd rater ``rater`` is the panel's participant ``participant`` (first
        arrival kept)."""
        with self._transaction() as con:
            con.execute("INSERT OR IGNORE INTO participants (study, rater, participant, arrived_at) "
                        "VALUES (?, ?, ?, ?)", (self.study, rater, participant, utc_now_iso()))

    def participants(self) -> pd.DataFrame:
        """Crowd raters and the panel's participant ids: columns rater, participant, arrived_at."""
        with self._connect() as con:
            return pd.read_sql_query("SELECT rater, participant, arrived_at FROM participants "
                                     "WHERE study = ? ORDER BY arrived_at, rowid", con, params=(self.study,))

    # ---- assignment ----------------------------------------------------------------------
    def next_item(self, rater: str, chooser: Callable[..., str | None], *,
                  lease_s: float = CLAIM_LEASE_S,
                  observe: Callable[[Callable[[int], list]], None] | None = None) -> str | None:
        """The rater's next unrated item: the oldest assigned, unvoted, unskipped one, else a new one.

        ``chooser(assigned: list[str], voted: set[str], loads: dict[str, int])`` picks the new
        item (or None when nothing is free for the rater); ``loads`` counts, per item, the
        standing votes plus the live claims of other raters: an item handed out and not voted
        on is claimed for ``lease_s`` seconds from its draw. Returning the rater's open item
        again does not renew the lease (measured: scripts that reloaded every 55 s held
        their claims for ever), so a claim never outlives ``lease_s`` without a vote; a vote
        or a skip ends it sooner. The work reads the rater's own rows, one counter row per item and
        the live claims (an index range), never the other raters' votes. An assignment is
        committed without a disk sync of its own (WAL, synchronous NORMAL): losing one to a
        power cut only means handing the item out again; the next vote's synced commit
        makes it durable too.

        ``observe`` (a study's sampler, :mod:`annotate.study_sampling`), when given, is called
        inside the same transaction just before ``chooser`` with a reader
        ``rows_after(watermark)`` of the history rows after that id (:meth:`history_after`),
        so the choice sees every vote committed before it.
        """
        return self._next(rater, chooser, lease_s=lease_s, observe=observe, state=False)[0]

    def next_item_state(self, rater: str, chooser: Callable[..., str | None], *,
                        lease_s: float = CLAIM_LEASE_S,
                        observe: Callable[[Callable[[int], list]], None] | None = None,
                        ) -> tuple[str | None, tuple[list[str], set[str], dict[str, int]]]:
        """:meth:`next_item` and, read in the same transaction, :meth:`rater_state` as it is
        once the item is handed out: ``(item, (assigned, voted, votes per item))``. One
        transaction serves what the page shows after a vote (the item and the progress).
        """
        return self._next(rater, chooser, lease_s=lease_s, observe=observe, state=True)

    def _next(self, rater: str, chooser, *, lease_s: float, observe, state: bool) -> tuple:
        """(item, rater state or None): the work of :meth:`next_item` (``state``: and the
        rater's state after it, :meth:`next_item_state`)."""
        now = _clock()
        with self._transaction(synchronous="NORMAL") as con:
            row = con.execute(
                "SELECT a.id, a.item FROM assignments a WHERE a.study = ? AND a.rater = ? AND NOT EXISTS "
                "(SELECT 1 FROM votes v WHERE v.study = a.study AND v.rater = a.rater AND "
                "v.item = a.item) AND NOT EXISTS (SELECT 1 FROM skipped s WHERE s.study = a.study "
                "AND s.rater = a.rater AND s.item = a.item) ORDER BY a.id LIMIT 1",
                (self.study, rater)).fetchone()
            if row is not None:  # the rater's open item; its lease still counts from its draw
                return row[1], (self._own(con, rater) + (self._standing(con),) if state else None)
            assigned, voted = self._own(con, rater)
            standing = self._standing(con)
            loads = dict(standing)
            for item, n in self._claims(con, now - lease_s, rater):
                loads[item] = loads.get(item, 0) + n
            if observe is not None:
                observe(lambda after: self._history_after(con, after))
            item = chooser(assigned, voted, loads)
            if item is not None:
                con.execute("INSERT INTO assignments (study, rater, item, assigned_at, active_at) "
                            "VALUES (?, ?, ?, ?, ?)", (self.study, rater, item, now, now))
                assigned.append(item)
            return item, ((assigned, voted, standing) if state else None)

    def _history_after(self, con: sqlite3.Connection, after: int) -> list[tuple]:
        # `+study`: a range of the primary key, not the history_session index on the study
        # (which read every row of the study and sorted them: 7 ms at 10^5 votes, per vote)
        return con.execute("SELECT id, rater, item, action, vote FROM history WHERE id > ? AND "
                           "+study = ? ORDER BY id", (int(after), self.study)).fetchall()

    def history_after(self, after: int) -> list[tuple]:
        """History rows with an id above ``after``, oldest first (a sampler's watermark).

        Parameters
        ----------
        after : int
            The last history id already read (0: from the start).

        Returns
        -------
        list of (id, rater, item, action, vote)
            ``action`` is ``'vote'``, ``'undo'`` (vote None) or ``'too_fast'``.
        """
        with self._connect() as con:
            return self._history_after(con, after)

    def _own(self, con: sqlite3.Connection, rater: str) -> tuple[list[str], set[str]]:
        assigned = [r[0] for r in con.execute(
            "SELECT item FROM assignments WHERE study = ? AND rater = ? ORDER BY id",
            (self.study, rater))]
        voted = {r[0] for r in con.execute(
            "SELECT item FROM votes WHERE study = ? AND rater = ?", (self.study, rater))}
        return assigned, voted

    def _standing(self, con: sqlite3.Connection) -> dict[str, int]:
        """Per item: its standing votes (items with none left out)."""
        return dict(con.execute("SELECT item, voted FROM item_loads WHERE study = ? AND voted > 0",
                                (self.study,)).fetchall())

    def _claims(self, con: sqlite3.Connection, after: float, rater: str) -> list[tuple]:
        """(item, live claims) of raters other than ``rater`` whose lease started after
        ``after`` (a claim ends with its vote, see :meth:`_insert_vote`)."""
        return con.execute("SELECT item, COUNT(*) FROM assignments WHERE study = ? AND active_at > ? "
                           "AND rater != ? GROUP BY item", (self.study, after, rater)).fetchall()

    def rater_state(self, rater: str) -> tuple[list[str], set[str], dict[str, int]]:
        """``(assigned, voted, votes per item)`` for progress: own rows plus the item counters."""
        with self._connect() as con:
            assigned, voted = self._own(con, rater)
            return assigned, voted, self._standing(con)

    def assignments(self, rater: str | None = None) -> pd.DataFrame:
        """Columns rater, item, assigned_at, voted (bool), in assignment order."""
        sql = ("SELECT a.rater, a.item, a.assigned_at, v.vote IS NOT NULL AS voted FROM assignments a "
               "LEFT JOIN votes v ON v.study = a.study AND v.rater = a.rater AND v.item = a.item "
               "WHERE a.study = ?")
        params: tuple = (self.study,)
        if rater is not None:
            sql, params = sql + " AND a.rater = ?", params + (rater,)
        with self._connect() as con:
            df = pd.read_sql_query(sql + " ORDER BY a.id", con, params=params)
        df["voted"] = df["voted"].astype(bool)
        return df

    def item_loads(self) -> dict[str, int]:
        """Votes per item over all raters (items without a vote left out).

        Read from the per-item counters the triggers keep (one row per item), so its cost
        does not grow with the votes: a crowd arrival asks it whether the study is full
        (counting the votes took 499 ms at a million of them).
        :meth:`recount_loads` counts the votes themselves.
        """
        with self._connect() as con:
            return self._standing(con)

    def recount_loads(self) -> dict[str, int]:
        """Votes per item counted from the votes table (what :meth:`item_loads` must equal;
        for checks and benchmarks: it reads every vote)."""
        with self._connect() as con:
            return dict(con.execute("SELECT item, COUNT(*) FROM votes WHERE study = ? GROUP BY item",
                                    (self.study,)).fetchall())
