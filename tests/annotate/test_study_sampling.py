"""Active and adaptive sampling while a study is served (issue 37; annotate/study_sampling.py).

Expected values are computed independently of the sampler: the posterior by replaying the
standing votes from the prior with :func:`annotate.sampling.posterior_from_votes`, the A/B
outcome from ``annotate export``'s ``choice`` column (annotate.pairwise.choice), the gains
with :func:`annotate.sampling.pair_gain` (each checked against a direct formula in
tests/annotate/test_sampling.py), the closed binary items with
:func:`annotate.sampling.majority_settled` written out as in docs/FORMATS.md §5.
"""

from __future__ import annotations

import importlib.util
import json
import shutil
from itertools import combinations
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from annotate.cli import main
from annotate.sampling import (
    SIGMA_JOD,
    gvf_uncertainty,
    majority_settled,
    pair_gain,
    posterior_from_votes,
)
from annotate.study import build_study, load_study

_spec = importlib.util.spec_from_file_location("annotate_toy_ss", Path(__file__).with_name("toy.py"))
toy = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(toy)

OLD = Path(__file__).resolve().parents[1] / "data" / "pre_sampling"
METHODS = {"alpha": 0.5, "gamma": 1.0, "beta": 1.5}


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    """(pairwise scene, pairs), (binary scene, pairs) of the toy clip."""
    tmp = tmp_path_factory.mktemp("ss")
    return toy.make_toy(tmp / "pw", methods=METHODS), toy.make_toy(tmp / "bin")


def _build(tmp_path, scene_pairs, name="study", **kw):
    scene, pairs = scene_pairs
    opts = dict(scene=str(scene), tracks=2, frames_per_track=2, n_training=1, n_gold=1,
                n_repeats=1, size=32, image_format="png", progress=False, votes_per_item=3)
    opts.update(kw)
    return load_study(build_study(tmp_path / name, pairs, **opts))


def _replayed(study, exported: pd.DataFrame):
    """The posterior of the study's standing test votes, replayed in history order from
    the export's A/B choices (independent of the sampler)."""
    tests = study.items[study.items["kind"] == "test"]
    views = list(dict.fromkeys(tests["pair_id"]))
    methods = study.manifest.methods
    hist = study.store.history()
    order = hist[hist["action"] == "vote"].groupby(["rater", "item"])["id"].max()
    ex = exported[exported["kind"] == "test"].copy()
    ex["key"] = ex["item_id"]
    ex["hid"] = [order[(r, k)] for r, k in zip(ex["rater_id"], ex["key"], strict=True)]
    votes = [(views.index(tests.loc[k, "pair_id"]), methods.index(a), methods.index(b),
              {"a": 1.0, "b": 0.0, "tie": 0.5}[c])
             for k, a, b, c in ex.sort_values("hid")[["key", "method_a", "method_b", "choice"]].itertuples(
                 index=False)]
    return posterior_from_votes(len(views), len(methods), votes), views


def _export(study, tmp_path) -> pd.DataFrame:
    out = tmp_path / "votes.csv"
    assert main(["export", str(study.root), "--out", str(out)]) == 0
    return pd.read_csv(out)


# --- building -----------------------------------------------------------------------------

@pytest.mark.parametrize("args, message", [
    (["--design", "pairwise", "--sampling", "adaptive"], "--sampling: expected 'uniform' or 'active'"),
    (["--sampling", "active"], "--sampling: expected 'uniform' or 'adaptive' with --design binary"),
    (["--max-votes-per-item", "7"], "--max-votes-per-item: expected no cap unless --sampling is adaptive"),
    (["--sampling", "adaptive", "--max-votes-per-item", "4"], "--max-votes-per-item: expected an integer >= "),
])
def test_build_refuses_a_sampling_of_the_other_design(tmp_path, inputs, capsys, args, message):
    scene, pairs = inputs[0]
    rc = main(["build", str(tmp_path / "s"), "--pairs", str(pairs), "--scene", str(scene),
               "--size", "32x32", "--quiet", *args])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and message in err and len(err.splitlines()) == 1, err
    assert not (tmp_path / "s").exists()


def test_manifest_records_the_sampling(tmp_path, inputs):
    pw = _build(tmp_path, inputs[0], "pw", design="pairwise", sampling="active")
    assert (pw.manifest.sampling, pw.manifest.max_votes_per_item) == ("active", None)
    b = _build(tmp_path, inputs[1], "b", sampling="adaptive")
    assert (b.manifest.sampling, b.manifest.max_votes_per_item) == ("adaptive", 3)  # the quota
    u = _build(tmp_path, inputs[1], "u", sampling="uniform")
    assert (u.manifest.sampling, u.sampler) == ("uniform", None)


def test_a_pairwise_study_is_active_unless_told_otherwise(tmp_path, inputs, capsys):
    """Issue 37: once bench_sampling showed active ahead of uniform, active became the
    pairwise default (said once at build); binary studies stay uniform; uniform on request."""
    (scene, pairs), (bscene, bpairs) = inputs
    common = ["--tracks", "2", "--frames-per-track", "2", "--size", "32x32", "--image-format",
              "png", "--training", "1", "--gold", "1", "--repeats", "1", "--quiet"]
    for name, extra, want in [("pw", ["--design", "pairwise"], "active"),
                              ("pwu", ["--design", "pairwise", "--sampling", "uniform"], "uniform"),
                              ("bin", [], "uniform")]:
        p, sc = (bpairs, bscene) if name == "bin" else (pairs, scene)
        assert main(["build", str(tmp_path / name), "--pairs", str(p), "--scene", str(sc),
                     *common, *extra]) == 0
        out = capsys.readouterr().out
        assert load_study(tmp_path / name).manifest.sampling == want, name
        assert ("sampling: active (the default for pairwise studies" in out) == (name == "pw"), out
    assert _build(tmp_path, inputs[0], "api", design="pairwise").manifest.sampling == "active"
    assert _build(tmp_path, inputs[1], "apib").manifest.sampling == "uniform"


# --- active pairwise ----------------------------------------------------------------------

def _vote(study, rater, key, rng):
    study.store.record_shown_vote(rater, key, int(rng.choice([0, 1, 2], p=[0.2, 0.5, 0.3])),
                                  response_ms=600, session=f"s-{rater}")


def test_active_hands_out_the_largest_gain_of_the_current_posterior(tmp_path, inputs):
    study = _build(tmp_path, inputs[0], design="pairwise", sampling="active", n_gold=0, n_repeats=0,
                   n_training=0)
    tests = study.items[study.items["kind"] == "test"]
    methods = study.manifest.methods
    rng = np.random.default_rng(3)
    budget = 3 * len(tests)
    for step in range(budget + 5):
        rater = f"r{step % 7}"
        posterior, views = _replayed(study, _export(study, tmp_path)) if step else (None, None)
        key = study.next_item(rater)
        if key is None:
            break
        plan = study.plan_for(rater)
        had = set(study.store.assignments(rater)["item"]) - {key}
        open_ = [k for k in plan["order"] if k not in had]
        if posterior is not None:  # the expected choice: largest gain, ties by the rater's order
            i, j = np.triu_indices(len(methods), 1)
            g = pair_gain(posterior)
            gain = {k: g[views.index(tests.loc[k, "pair_id"]),
                         int(np.flatnonzero((i == methods.index(tests.loc[k, "method_a"]))
                                            & (j == methods.index(tests.loc[k, "method_b"])))[0])]
                    for k in open_}
            best = max(gain.values())
            assert gain[key] == pytest.approx(best, rel=1e-12, abs=1e-15), step
            np.testing.assert_allclose(study.sampler.post.mu, posterior.mu, atol=1e-12)
            np.testing.assert_allclose(study.sampler.post.var, posterior.var, atol=1e-12)
        _vote(study, rater, key, rng)
    n = study.store.votes()["item"].isin(tests.index).sum()
    assert n == budget and study.is_full()  # the uniform design's budget, not more


def test_raters_busy_at_once_get_different_comparisons(tmp_path, inputs):
    study = _build(tmp_path, inputs[0], design="pairwise", sampling="active", n_gold=0, n_repeats=0,
                   n_training=0)
    got = [study.next_item(f"r{k}") for k in range(10)]  # ten raters, nobody has voted yet
    assert len(set(got)) == 10
    # at the prior every gain is the same: the first rater gets its own first item, the
    # others their first item that nobody holds
    for k, key in enumerate(got):
        order = study.plan_for(f"r{k}")["order"]
        assert key == next(i for i in order if i not in got[:k])


def test_undo_and_a_second_process_see_the_same_posterior(tmp_path, inputs):
    study = _build(tmp_path, inputs[0], design="pairwise", sampling="active", n_gold=0, n_repeats=0,
                   n_training=0)
    other = load_study(study.root)  # another server process: its own sampler
    rng = np.random.default_rng(5)
    for step in range(30):
        s = study if step % 2 else other
        rater = f"r{step % 4}"
        _vote(s, rater, s.next_item(rater), rng)
        if step in (9, 20):
            assert s.store.undo_last(rater, session=f"s-{rater}") is not None
    for s in (study, other):
        s.sampler.refresh(s.store.history_after)
    posterior, _ = _replayed(study, _export(study, tmp_path))
    for s in (study, other):
        np.testing.assert_allclose(s.sampler.post.mu, posterior.mu, atol=1e-12)
        np.testing.assert_allclose(s.sampler.post.var, posterior.var, atol=1e-12)
    assert np.abs(posterior.mu).max() > 0.1  # the votes moved it


def test_sigma_is_the_jod_unit():
    from scipy.stats import norm
    assert norm.cdf(1 / SIGMA_JOD) == pytest.approx(0.75)  # 1 JOD: 75% prefer


# --- adaptive binary ----------------------------------------------------------------------

def test_adaptive_closes_settled_items_and_spends_no_more_than_uniform(tmp_path, inputs):
    study = _build(tmp_path, inputs[1], sampling="adaptive", max_votes_per_item=5, n_gold=0,
                   n_repeats=0, n_training=0)
    keys = study.keys("test")
    truth = dict(zip(keys, np.random.default_rng(7).random(len(keys)), strict=True))
    rng = np.random.default_rng(1)
    idle = 0
    for step in range(10 * len(keys)):
        rater = f"r{step % 12}"
        votes = study.store.votes()
        good = votes[votes["vote"] == 1]["item"].value_counts()
        bad = votes[votes["vote"] == 0]["item"].value_counts()
        g = np.array([good.get(k, 0) for k in keys])
        b = np.array([bad.get(k, 0) for k in keys])
        key = study.next_item(rater)
        idle = 0 if key is not None else idle + 1
        if idle == 12:  # no rater gets an item
            break
        if key is None:
            continue
        i = keys.index(key)
        n = g + b  # the item was open: not curtailed at the quota 3, not settled over 5, below 5
        assert not (majority_settled(g, b, 3)[i] and n[i] < 3)
        assert not majority_settled(g, b, 5)[i] and n[i] < 5
        mine = set(votes[votes["rater"] == rater]["item"])
        closed = (majority_settled(g, b, 3) & (n < 3)) | majority_settled(g, b, 5) | (n >= 5)
        cand = [k for k in keys if k not in mine and not closed[keys.index(k)]]
        u = gvf_uncertainty(g, b)
        assert u[i] == pytest.approx(max(u[keys.index(k)] for k in cand))  # the most uncertain
        study.store.record_shown_vote(rater, key, int(rng.random() < truth[key]), response_ms=600,
                                      session="s")
    votes = study.store.votes()
    per = votes["item"].value_counts()
    assert per.max() <= 5 and len(votes) <= 3 * len(keys) and study.is_full()
    assert (per < 3).any()  # some majorities were settled early


# --- studies built before --sampling --------------------------------------------------------

@pytest.mark.parametrize("design", ["binary", "pairwise"])
def test_a_study_built_before_sampling_opens_serves_and_exports_unchanged(tmp_path, design):
    """tests/data/pre_sampling/DESIGN was built and played by the code before this issue
    (its make_fixture.py): the same raters get the same items, the export the same rows."""
    root = tmp_path / design
    shutil.copytree(OLD / design, root)
    manifest = json.loads((root / "manifest.json").read_text())
    assert "sampling" not in manifest and "max_votes_per_item" not in manifest
    spec = importlib.util.spec_from_file_location("pre_sampling_fixture", OLD / "make_fixture.py")
    fixture = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(fixture)
    study = load_study(root)
    assert study.sampling == "uniform" and study.sampler is None
    seq = fixture.play(study)
    assert seq == json.loads((OLD / design / "sequence.json").read_text())
    out = tmp_path / "e.csv"
    assert main(["export", str(root), "--out", str(out)]) == 0
    # the same rows; their order is by vote time (ms), which ties differently from run to run
    # when votes come fast, and the order of each rater's items is the sequence checked above
    def rows(table: pd.DataFrame) -> pd.DataFrame:
        return table.sort_values(["rater_id", "item_id"], kind="stable").reset_index(drop=True)

    pd.testing.assert_frame_equal(rows(pd.read_csv(out).drop(columns=["voted_at"])),
                                  rows(pd.read_csv(OLD / design / "export.csv")))
    assert json.loads((root / "manifest.json").read_text()) == manifest  # nothing rewritten


def test_pairs_of_methods_index(tmp_path, inputs):
    """The sampler's (item, pair) of each test key is the key's own view and methods."""
    study = _build(tmp_path, inputs[0], design="pairwise", sampling="active")
    s = study.sampler
    methods = study.manifest.methods
    duos = list(combinations(range(len(methods)), 2))
    for k, flat in zip(s.keys, s.flat, strict=True):
        view, pair = divmod(int(flat), len(duos))
        row = study.items.loc[k]
        assert duos[pair] == (methods.index(row["method_a"]), methods.index(row["method_b"]))
        assert list(dict.fromkeys(study.items.loc[s.keys, "pair_id"]))[view] == row["pair_id"]


@pytest.mark.parametrize("design, sampling", [("binary", "uniform"), ("binary", "adaptive"),
                                              ("pairwise", "active"), ("pairwise", "uniform")])
def test_the_page_read_equals_next_item_then_progress(tmp_path, inputs, design, sampling):
    """What the page reads after a vote in one transaction (Study.next_with_progress) is
    what Study.next_item and then Study.progress give, at every step of 6 raters voting at
    random (each of them signing in again at random: an item already handed out)."""
    study = _build(tmp_path, inputs[0] if design == "pairwise" else inputs[1], design=design,
                   sampling=sampling, votes_per_item=2)
    rng = np.random.default_rng(0)
    codes, votes = (0, 1, 2) if design == "pairwise" else (0, 1), 0
    for step in range(300):
        rater = f"r{rng.integers(6)}"
        key, prog = study.next_with_progress(rater)
        assert key == study.next_item(rater) and prog == study.progress(rater), (step, rater)
        if key is not None and rng.random() < 0.8:
            assert study.store.record_shown_vote(rater, key, int(rng.choice(codes))) == "recorded"
            votes += 1
    assert votes > 30 and study.next_with_progress("r0")[1]["done"] > 0
