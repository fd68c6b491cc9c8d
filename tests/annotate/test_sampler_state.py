"""A sampler's state against its store: a restore under a running worker, undo and the
adaptive cap, the progress total of a sampled study.

Expected values come from a sampler made fresh on the store as it is (it reads the whole
history), from counting the votes in the store, and from the rule that a rater who is done
has seen all it will see (its total equals its done).
"""

from __future__ import annotations

import importlib.util
import sqlite3
from pathlib import Path

import numpy as np
import pytest

from annotate.simulate import simulate
from annotate.study import build_study, load_study
from annotate.study_sampling import make_sampler

_spec = importlib.util.spec_from_file_location("annotate_toy_st", Path(__file__).with_name("toy.py"))
toy = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(toy)

METHODS = {"alpha": 0.5, "gamma": 1.0, "beta": 1.5}


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("st")
    return {"pairwise": toy.make_toy(tmp / "pw", methods=METHODS), "binary": toy.make_toy(tmp / "bin")}


def _study(tmp_path, inputs, design, sampling, name="study", **kw):
    scene, pairs = inputs[design]
    opts = dict(scene=str(scene), tracks=2, frames_per_track=3, n_training=1, n_gold=1, n_repeats=1,
                size=32, image_format="png", progress=False, votes_per_item=3, design=design,
                sampling=sampling)
    opts.update(kw)
    return load_study(build_study(tmp_path / name, pairs, **opts))


def _same_state(a, b) -> None:
    np.testing.assert_array_equal(a.n, b.n)
    assert a.standing == b.standing
    if hasattr(a, "post"):
        np.testing.assert_allclose(a.post.mu, b.post.mu, atol=1e-12)
        np.testing.assert_allclose(a.post.var, b.post.var, atol=1e-12)
    else:
        np.testing.assert_array_equal(a.good, b.good)


@pytest.mark.parametrize(("design", "sampling"), [("pairwise", "active"), ("binary", "adaptive")])
def test_a_store_restored_under_a_running_worker_resets_its_sampler(tmp_path, inputs, design, sampling):
    study = _study(tmp_path, inputs, design, sampling)
    simulate(study, raters=1, seed=0, progress=False)
    backup = tmp_path / "backup.sqlite"
    with sqlite3.connect(study.store.path) as src, sqlite3.connect(backup) as dst:
        src.backup(dst)
    simulate(study, raters=2, seed=1, progress=False)
    worker = load_study(study.root)  # a running worker: its sampler has read every vote
    worker.next_item("late")
    ahead = worker.sampler.n.sum()
    with sqlite3.connect(backup) as src, sqlite3.connect(study.store.path) as dst:
        src.backup(dst)  # the restore, under the running worker
    simulate(study, raters=1, seed=2, progress=False)  # new votes take the lost rows' ids
    worker.is_full()  # any request refreshes the sampler
    fresh = make_sampler(load_study(study.root))
    fresh.refresh(study.store.history_after)
    assert fresh.n.sum() < ahead
    _same_state(worker.sampler, fresh)


def test_undo_cannot_push_an_adaptive_item_past_its_cap(tmp_path, inputs):
    """Cap 1: A votes on X and takes it back; X is A's claim again, so B is never handed X,
    and A's second vote leaves X at one vote (the old code gave X to B: two votes)."""
    study = _study(tmp_path, inputs, "binary", "adaptive", tracks=1, frames_per_track=1,
                   n_training=0, n_gold=0, n_repeats=0, votes_per_item=1)
    assert study.manifest.max_votes_per_item == 1
    x = study.next_item("A")
    assert study.store.record_shown_vote("A", x, 1, session="a") == "recorded"
    assert study.store.undo_last("A", session="a") == x
    got = []
    while (key := study.next_item("B")) is not None:
        got.append(key)
        study.store.record_shown_vote("B", key, 1, session="b")
    assert x not in got
    assert study.next_item("A") == x
    study.store.record_shown_vote("A", x, 0, session="a")
    votes = study.store.votes()
    assert votes.groupby("item").size().max() == 1


@pytest.mark.parametrize(("design", "sampling"), [("pairwise", "active"), ("binary", "adaptive"),
                                                  ("binary", "uniform")])
def test_a_rater_who_is_done_has_its_total(tmp_path, inputs, design, sampling):
    """After a simulation every rater is done: its progress total is what it did (the old
    active total counted every test item the rater had not had, whatever the budget)."""
    study = _study(tmp_path, inputs, design, sampling)
    simulate(study, raters=6, seed=0, progress=False)
    for rater in study.store.raters():
        assert study.next_item(rater) is None
        p = study.progress(rater)
        assert p["total"] == p["done"], (rater, p)


def _kept(sampler) -> bytes:
    import pickle

    return pickle.dumps({k: v for k, v in vars(sampler).items()
                         if k not in {"_plan", "lock", "watermark", "last_row", "_gain"}})


def test_the_pairwise_sampler_keeps_nothing_per_rater_beyond_its_standing_votes(tmp_path, inputs):
    """40 raters each vote on a test item and take it back: the sampler's state is then that
    of a sampler that read no vote (the old one kept every rater's sides, 0.54 MB a rater
    at the review's study size, for good)."""
    study = _study(tmp_path, inputs, "pairwise", "active", n_training=0, n_gold=0, n_repeats=0)
    empty = _kept(make_sampler(study))
    for i in range(40):
        rater = f"r{i}"
        key = study.next_item(rater)
        assert study.items.at[key, "kind"] == "test"
        study.store.record_shown_vote(rater, key, 1, session=rater)
        study.next_item(rater)  # the sampler reads the vote
        assert study.store.undo_last(rater, session=rater) == key
    study.is_full()
    assert study.sampler.watermark > 0 and not study.sampler.standing
    assert _kept(study.sampler) == empty


@pytest.mark.parametrize(("design", "sampling"), [("binary", "uniform"), ("binary", "adaptive"),
                                                  ("pairwise", "active")])
def test_an_arrival_reads_no_vote_and_no_history_row_but_the_new_ones(tmp_path, inputs, monkeypatch,
                                                                     design, sampling):
    """is_full (each crowd arrival) reads the per-item counters and the history after the
    sampler's watermark: SQLite's own query plans show no scan of the votes or the history
    and no sort (the old check counted every vote: 499 ms at 10^6; the history read used the
    study index and sorted every row). Its cost is measured by benchmarks/bench_arrival.py."""
    from annotate.store import Store

    study = _study(tmp_path, inputs, design, sampling, access="crowd")
    simulate(study, raters=3, seed=0, progress=False)
    study.is_full()
    statements: list[str] = []
    opened = Store._open

    def traced(self, uri, sync):
        con = opened(self, uri, sync)
        con.set_trace_callback(statements.append)
        return con

    monkeypatch.setattr(Store, "_open", traced)
    study.store._pool.clear()
    study.is_full()
    selects = [s for s in statements if s.lstrip().upper().startswith("SELECT")]
    assert selects
    con = sqlite3.connect(study.store.path)
    for sql in selects:
        plan = " | ".join(row[3] for row in con.execute("EXPLAIN QUERY PLAN " + sql))
        assert "TEMP B-TREE" not in plan, (sql, plan)
        assert not any(f"SCAN {t}" in plan for t in ("votes", "history", "assignments")), (sql, plan)
        assert "history_session" not in plan, (sql, plan)
