"""The one next-item chooser (annotate/chooser.py): gold hidden under every sampling.

The attack of the hardening review: 24 simulated raters at 3 votes per item; rank the items
by how many identities were handed each (the store's assignments), and ask how well that
ranking tells gold from test items. The AUC is computed by scikit-learn
(``roc_auc_score``, independent of the chooser). Before the chooser took the gold cap into
every sampling, active reached AUC 0.88 (a gold item 8 raters, a test item at most 6) and
adaptive 0.91 (8 against 3).
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest
from sklearn.metrics import roc_auc_score

from annotate.chooser import (
    ActiveChooser,
    AdaptiveChooser,
    RaterState,
    UniformChooser,
    gold_partners,
)
from annotate.simulate import simulate
from annotate.study import build_study, load_study

_spec = importlib.util.spec_from_file_location("annotate_toy_ch", Path(__file__).with_name("toy.py"))
toy = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(toy)

METHODS = {"alpha": 0.5, "gamma": 1.0, "beta": 1.5}
CASES = [("binary", "uniform", UniformChooser), ("binary", "adaptive", AdaptiveChooser),
         ("pairwise", "uniform", UniformChooser), ("pairwise", "active", ActiveChooser)]


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("ch")
    return {"pairwise": toy.make_toy(tmp / "pw", methods=METHODS), "binary": toy.make_toy(tmp / "bin")}


def _study(tmp_path, inputs, design, sampling, name="study"):
    scene, pairs = inputs[design]
    return load_study(build_study(tmp_path / name, pairs, scene=str(scene), tracks=2,
                                  frames_per_track=3, n_training=1, n_gold=1, n_repeats=1, size=32,
                                  image_format="png", progress=False, votes_per_item=3,
                                  design=design, sampling=sampling))


def _exposure(study) -> tuple[np.ndarray, np.ndarray]:
    """(test, gold) exposures: distinct raters handed each item."""
    seen = study.store.assignments().groupby("item")["rater"].nunique()
    return (np.array([seen.get(k, 0) for k in study.keys("test")]),
            np.array([seen.get(k, 0) for k in study.keys("gold")]))


@pytest.mark.parametrize(("design", "sampling", "kind"), CASES)
def test_counting_identities_does_not_find_the_gold(tmp_path, inputs, design, sampling, kind):
    study = _study(tmp_path, inputs, design, sampling)
    assert type(study.chooser) is kind  # every sampling passes through the one chooser
    simulate(study, raters=24, seed=0, progress=False)
    tests, golds = _exposure(study)
    auc = roc_auc_score(np.r_[np.zeros(len(tests)), np.ones(len(golds))], np.r_[tests, golds])
    print(f"{design}/{sampling}: gold-vs-test exposure AUC {auc:.2f}; most-seen gold {golds.max()}, "
          f"test {tests.max()}")
    assert auc <= 0.75
    assert golds.max() <= tests.max()
    assert golds.sum() > 0  # gold is still shown (screening needs it)


@pytest.mark.parametrize(("design", "sampling"), [("binary", "uniform"), ("binary", "adaptive"),
                                                  ("pairwise", "active")])
def test_a_rater_with_no_test_item_left_gets_no_gold(tmp_path, inputs, design, sampling):
    """Raters arriving one after another: once the test items are taken, a newcomer gets its
    training item and is done (the old code served adaptive and active newcomers gold only)."""
    study = _study(tmp_path, inputs, design, sampling)
    only_gold = 0
    for i in range(24):
        kinds = []
        while (key := study.next_item(f"r{i}")) is not None:
            kinds.append(study.items.at[key, "kind"])
            study.store.record_vote(f"r{i}", key, 1)
        only_gold += "gold" in kinds and "test" not in kinds
    tests, golds = _exposure(study)
    assert only_gold == 0
    assert golds.max() <= tests.max()


def test_gold_shadows_its_partner_under_a_sampler():
    """A sampled study's gold item is open while fewer raters hold it than its partner."""

    class Everything:  # a sampler that hands out the first open key
        def pick(self, open_keys, loads):
            return open_keys[0] if open_keys else None

        def room(self, open_keys, loads):
            return len(open_keys)

        def refresh(self, rows_after):
            pass

    partners = gold_partners(["a", "b", "c"], ["g"], seed=1)
    ch = ActiveChooser(Everything(), partners)
    p = partners["g"]
    plan = {"training": [], "order": ["a", "b", "c"], "specials": [[1, "g"]], "repeat_of": {},
            "gold_quota": True}
    state = RaterState(plan, ["a"], {"a"}, {p: 2, "g": 2})
    assert ch.next(state) == "b"  # g as often as its partner: closed, a test item instead
    assert ch.next(RaterState(plan, ["a"], {"a"}, {p: 2, "g": 1})) == "g"


def test_gold_share_at_the_end_is_proportional_to_the_tests_had():
    """Tests ran out after 1 of 4 positions: a plan of 2 gold shows ceil(1 * 2 / 4) = 1."""
    plan = {"training": [], "order": ["a", "b", "c", "d"], "specials": [[3, "g1"], [4, "g2"]],
            "repeat_of": {}, "gold_quota": True}
    ch = UniformChooser(quota=1)
    full = {"b": 1, "c": 1, "d": 1}
    assert ch.next(RaterState(plan, ["a"], {"a"}, full)) == "g1"
    assert ch.next(RaterState(plan, ["a", "g1"], {"a", "g1"}, full)) is None
    assert ch.next(RaterState(plan, [], set(), {**full, "a": 1})) is None  # no test: no gold


def _test_votes(study) -> int:
    loads = study.store.item_loads()
    return sum(loads.get(k, 0) for k in study.keys("test"))


def test_simulate_room_of_an_adaptive_study_is_its_budget_and_cap(tmp_path, inputs):
    """Adaptive, cap = votes_per_item = 3: 4 raters spend the sampler's budget (items closed
    early included), so a fifth would vote on no test item. The old check counted
    ``votes_per_item`` less the votes of every item, closed ones too, and let it in."""
    from data_schema.errors import InputError

    scene, pairs = inputs["binary"]
    study = load_study(build_study(tmp_path / "a", pairs, scene=str(scene), tracks=2,
                                   frames_per_track=3, n_training=1, n_gold=1, n_repeats=1,
                                   size=32, image_format="png", progress=False, votes_per_item=3,
                                   sampling="adaptive"))
    simulate(study, raters=4, seed=0, progress=False)
    loads = study.store.item_loads()
    assert sum(max(3 - loads.get(k, 0), 0) for k in study.keys("test")) > 0  # the old room
    assert study.is_full()  # a new rater would get no test item
    with pytest.raises(InputError, match="raters: expected a study whose test items still need votes"):
        simulate(study, raters=1, seed=1, progress=False)


def test_simulate_room_of_an_adaptive_study_counts_up_to_its_cap(tmp_path, inputs):
    """Cap 5 above the quota 3: the room is the budget left (3 x 18 test votes in all), which
    the old check, counting each item only up to 3, under-counted as items passed 3."""
    from data_schema.errors import InputError

    scene, pairs = inputs["binary"]
    study = load_study(build_study(tmp_path / "a", pairs, scene=str(scene), tracks=2,
                                   frames_per_track=3, n_training=1, n_gold=1, n_repeats=1,
                                   size=32, image_format="png", progress=False, votes_per_item=3,
                                   sampling="adaptive", max_votes_per_item=5))
    simulate(study, raters=4, seed=0, progress=False)
    budget = 3 * len(study.keys("test"))
    left = budget - _test_votes(study)
    assert left > 0
    with pytest.raises(InputError, match=f"at most {left} more rater"):
        simulate(study, raters=left + 1, seed=1, progress=False)
    simulate(study, raters=left, seed=1, progress=False)
    assert _test_votes(study) == budget
