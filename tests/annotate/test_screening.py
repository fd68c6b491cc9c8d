"""Rater screening: hand-worked numbers, exact binomial p-values, and simulated panels."""

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from annotate.screening import (
    ScreenRule,
    consensus_stats,
    fisher_skill_p,
    j_exact_p,
    j_test,
    rater_table,
    screen,
    screen_agreement,
)
from data_schema.errors import InputError
from tests.annotate.panels import HONEST_ACCURACY, panels


def _votes(rows):
    return pd.DataFrame(rows, columns=["rater_id", "item_id", "vote", "kind", "response_ms"])


def test_loo_consensus_gold_and_repeats_hand_worked():
    rows = [
        # item x: a=1, b=1, c=0 ; item y: a=0, b=0, c=0 ; item z: a=1, b=0
        ("a", "x", 1, "test", 1000),
        ("b", "x", 1, "test", 1200),
        ("c", "x", 0, "test", 100),
        ("a", "y", 0, "test", 900),
        ("b", "y", 0, "test", 1100),
        ("c", "y", 0, "test", 100),
        ("a", "z", 1, "test", 800),
        ("b", "z", 0, "test", 1000),
        ("a", "gold-good:1", 1, "gold", 500),
        ("c", "gold-good:1", 0, "gold", 100),
        ("c", "gold-bad:2", 0, "gold", 100),
        ("a", "x", 1, "repeat", 700),
        ("c", "x", 1, "repeat", 100),
        ("c", "y", 0, "repeat", 100),
    ]
    r = rater_table(_votes(rows)).set_index("rater_id")
    # a: x others (b1, c0) tie -> not compared; y others bad, a=0 agrees; z others (b=0) bad,
    # a=1 disagrees -> 1 of 2, both consensus-bad: specificity 1/2, no consensus-good item
    assert r.loc["a", "n_compared"] == 2 and r.loc["a", "agreement"] == pytest.approx(0.5)
    assert r.loc["a", "specificity"] == pytest.approx(0.5) and np.isnan(r.loc["a", "j_p"])
    # c: x others (1, 1) good, c=0 misses; y others bad, c=0 agrees -> sens 0, spec 1, J 0
    assert r.loc["c", "sensitivity"] == 0 and r.loc["c", "specificity"] == 1
    assert r.loc["c", "youden_j"] == 0 and np.isnan(r.loc["c", "skill_p"])  # < 5 per class
    assert r.loc["c", "gold_failures"] == 1 and r.loc["c", "gold_failure_rate"] == 0.5
    # exact one-sided binomial: P(X >= 1), X ~ Bin(2, 0.25) = 1 - 0.75^2
    assert r.loc["c", "gold_p"] == pytest.approx(1 - 0.75**2)
    assert r.loc["c", "repeat_consistency"] == pytest.approx(0.5)  # x flipped, y kept
    # P(X <= 1), X ~ Bin(2, 0.7) = 1 - 0.7^2
    assert r.loc["c", "repeat_p"] == pytest.approx(1 - 0.7**2)
    assert r.loc["a", "repeat_consistency"] == 1.0
    assert np.isnan(r.loc["b", "repeat_consistency"])
    assert r.loc["a", "median_response_ms"] == 900
    # c: 2 test votes, both under 300 ms: P(X >= 2), X ~ Bin(2, 0.5) = 0.25
    assert r.loc["c", "fast_share"] == 1.0 and r.loc["c", "speed_p"] == pytest.approx(0.25)
    assert r.loc["c", "modal_share"] == 1.0


def test_kappa_and_j_against_sklearn_and_hand_worked_z():
    from sklearn.metrics import cohen_kappa_score

    rng = np.random.default_rng(3)
    v = (rng.random((4, 50)) < 0.6).astype(float)
    v[1] = v[0]  # two raters agree: the others' consensus is informative
    res = consensus_stats(v)
    others = (v.sum(0) - v[2]) / 3
    ok = others != 0.5
    label = (others > 0.5).astype(int)[ok]
    assert res["kappa"][2] == pytest.approx(cohen_kappa_score(v[2][ok].astype(int), label))
    # straight-lining "good" on 48 good / 12 bad items, H0: J >= 0.4; boundary point
    # (sens, spec) = (1, 0.4): se = sqrt(0.4 * 0.6 / 12), z = -0.4 / se
    z, p = j_test(1.0, 0.0, 48, 12, min_j=0.4)
    assert z == pytest.approx(-0.4 / np.sqrt(0.24 / 12))
    assert p == pytest.approx(stats.norm.cdf(z))


def test_fisher_skill_p_matches_scipy_fisher_exact():
    rng = np.random.default_rng(5)
    v = (rng.random((5, 80)) < 0.5).astype(float)
    v[1:3] = v[0]
    res = consensus_stats(v)
    others = (v.sum(0) - v[3]) / 4
    ok = others != 0.5
    lab, vote = others[ok] > 0.5, v[3][ok] == 1
    table = [[(vote & lab).sum(), (vote & ~lab).sum()], [(~vote & lab).sum(), (~vote & ~lab).sum()]]
    want = stats.fisher_exact(table, alternative="greater").pvalue
    assert fisher_skill_p(res)[3] == pytest.approx(want)


def test_three_test_votes_get_the_exact_j_test_not_the_z_test():
    """Issue 38 item 16: a rater with 3 test votes, all against the consensus (2 good, 1 bad
    items), was excluded on a z-test p of 0.0093. Exact: P(a = 0, b = 0) on the H0 boundary
    s + q = 1.35 is (1 - s)^2 (s - 0.35), largest at s = 1.7 / 3 (derivative zero):
    (1.3 / 3)^2 (0.65 / 3) = 0.040685 (hand-worked), not significant at 0.01."""
    rows = [(r, f"i{k}", int(k < 2), "test", 1000) for r in ("o1", "o2") for k in range(3)]
    rows += [("x", f"i{k}", int(k >= 2), "test", 1000) for k in range(3)]
    r = screen(rater_table(_votes(rows)), use_rule=True).set_index("rater_id")
    assert r.loc["x", "n_cons_good"] == 2 and r.loc["x", "n_cons_bad"] == 1
    assert r.loc["x", "j_p"] == pytest.approx(1.69 / 9 * 0.65 / 3, abs=2e-6)
    assert not r.loc["x", "excluded"], r.loc["x", "flags"]
    # one right vote of two on good items: (s - 0.35)(1 - s^2), largest at
    # s = (0.7 + sqrt(12.49)) / 6 (hand-worked root of 1 + 0.7 s - 3 s^2)
    s = (0.7 + np.sqrt(12.49)) / 6
    assert j_exact_p(0.5, 0.0, 2, 1, min_j=0.35) == pytest.approx((s - 0.35) * (1 - s * s),
                                                                  abs=2e-6)


def test_exact_j_p_matches_brute_force_binomials():
    """j_exact_p against an independent enumeration with scipy.stats.binom and a bounded
    scipy.optimize search over the H0 boundary (7 good, 5 bad items, 3 and 2 right)."""
    from scipy.optimize import minimize_scalar

    n1, n0, a, b, mj = 7, 5, 3, 2, 0.35

    def tail(s):
        q = 1 + mj - s
        return sum(stats.binom.pmf(i, n1, s) * stats.binom.pmf(k, n0, q)
                   for i in range(n1 + 1) for k in range(n0 + 1)
                   if i / n1 + k / n0 <= a / n1 + b / n0 + 1e-12)

    best = minimize_scalar(lambda s: -tail(s), bounds=(mj, 1.0), method="bounded",
                           options={"xatol": 1e-9})
    assert j_exact_p(a / n1, b / n0, n1, n0, min_j=mj) == pytest.approx(-best.fun, abs=1e-5)
    # vectorised over panels, NaN where a class is empty
    got = j_exact_p([a / n1, 0.0], [b / n0, 0.0], [n1, 3], [n0, 0], min_j=mj)
    assert got[0] == pytest.approx(-best.fun, abs=1e-5) and np.isnan(got[1])


def test_five_repeats_never_exclude_an_honest_rater_alone():
    # an honest rater 80% self-consistent: the worst plausible 5 repeats (2 of 5 kept)
    rows = [("h", f"i{k}", 1, "test", 1000) for k in range(5)]
    rows += [("h", f"i{k}", int(k < 2), "repeat", 1000) for k in range(5)]
    r = screen(rater_table(_votes(rows)), use_rule=True)
    assert r.loc[0, "repeat_p"] == pytest.approx(stats.binom.cdf(2, 5, 0.7))
    assert not r.loc[0, "excluded"]


def test_screen_rule_and_manual_exclusion():
    raters = pd.DataFrame(
        {
            "rater_id": ["good", "fast", "liar"],
            "simulated": False,
            "j_p": [0.5, 0.5, 1e-6],
            "skill_p": [1e-9, 1e-9, 0.5],
            "gold_p": [0.9, 0.9, 1e-3],
            "repeat_p": [0.9, 0.9, 0.9],
            "speed_p": [0.9, 1e-9, 0.9],
        }
    )
    s = screen(raters, use_rule=True, exclude=["good"]).set_index("rater_id")
    assert s["excluded"].all()
    assert s.loc["good", "excluded_reason"] == "--exclude-raters"
    assert "median response" in s.loc["fast", "flags"]
    assert "agreement" in s.loc["liar", "flags"] and "gold" in s.loc["liar", "flags"]
    s2 = screen(raters, use_rule=False).set_index("rater_id")  # flags reported, nobody excluded
    assert not s2["excluded"].any() and s2.loc["liar", "flags"]
    with pytest.raises(InputError, match="nobody"):
        screen(raters, use_rule=False, exclude=["nobody"])


def test_simulated_panels_exclusion_rates():
    """Issue 14 acceptance: 20 seeds x good rate {0.2, 0.5, 0.8} x {60, 812} items; 5 honest
    raters (accuracy 0.83..0.95) + random + inverted + straight-lining, screened all at once."""
    h = len(HONEST_ACCURACY)
    honest_panels, bad_hits, n_panels = 0, np.zeros(3), 0
    for n_items in (60, 812):
        for good_rate in (0.2, 0.5, 0.8):
            votes, _ = panels(range(20), good_rate, n_items)
            flag = screen_agreement(votes, rule=ScreenRule())["flag_agreement"]  # (20, 8)
            honest_panels += int(flag[:, :h].any(axis=1).sum())
            bad_hits += flag[:, h:].sum(axis=0)
            n_panels += len(flag)
    honest_rate, bad_rate = honest_panels / n_panels, bad_hits / n_panels
    print(f"panels with an honest rater excluded: {honest_rate:.3f}; "
          f"random / inverted / straight excluded: {np.round(bad_rate, 3).tolist()}")
    assert honest_rate <= 0.02
    assert (bad_rate >= 0.95).all()


def test_random_rater_voting_at_the_base_rate_is_excluded():
    """The issue's real-panel failure: a random rater who votes good as often as the panel
    agrees with the majority 66-79% of the time; J stays 0 and the rule must catch it."""
    hits, n = 0, 0
    for n_items in (60, 812):
        for good_rate in (0.2, 0.5, 0.8):
            votes, _ = panels(range(20), good_rate, n_items)
            rng = np.random.default_rng([7, n_items, int(good_rate * 10)])
            votes[:, 5] = (rng.random(votes[:, 5].shape) < good_rate).astype(float)
            flag = screen_agreement(votes)["flag_agreement"]
            hits, n = hits + int(flag[:, 5].sum()), n + len(flag)
    assert hits / n >= 0.95
