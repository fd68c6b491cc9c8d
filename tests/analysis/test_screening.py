"""Rater screening on hand-worked examples."""

import numpy as np
import pandas as pd
import pytest

from analysis.screening import ScreenRule, rater_table, screen
from data_schema.errors import InputError


def _votes(rows):
    df = pd.DataFrame(rows, columns=["rater_id", "item_id", "vote", "kind", "response_ms"])
    return df


def test_loo_agreement_gold_and_repeats_hand_worked():
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
    # a: x others (b1,c0) -> 0.5 -> good, a=1 agree; y others 0 -> bad, agree; z others b=0 -> disagree
    assert r.loc["a", "agreement"] == pytest.approx(2 / 3)
    assert r.loc["a", "n_compared"] == 3
    # c: x others (1,1) good, c=0 disagree; y others bad, agree
    assert r.loc["c", "agreement"] == pytest.approx(1 / 2)
    assert r.loc["c", "gold_failures"] == 1 and r.loc["c", "gold_failure_rate"] == pytest.approx(
        0.5
    )
    assert r.loc["a", "gold_failures"] == 0
    assert r.loc["c", "repeat_consistency"] == pytest.approx(0.5)  # x flipped, y kept
    assert r.loc["a", "repeat_consistency"] == 1.0
    assert np.isnan(r.loc["b", "repeat_consistency"])
    assert r.loc["a", "median_response_ms"] == 900
    assert r.loc["c", "modal_share"] == 1.0


def test_gold_expected_column_overrides_prefix():
    df = _votes([("a", "g1", 1, "gold", 500), ("a", "x", 1, "test", 500)])
    df["gold_expected"] = [0, np.nan]
    r = rater_table(df)
    assert r.loc[0, "gold_failures"] == 1


def test_screen_rule_and_manual_exclusion():
    raters = pd.DataFrame(
        {
            "rater_id": ["good", "fast", "liar"],
            "simulated": False,
            "n_test": [50, 50, 50],
            "n_gold": [4, 4, 4],
            "n_gold_unscored": [0, 0, 0],
            "n_compared": [50, 50, 50],
            "agreement": [0.9, 0.9, 0.4],
            "gold_failure_rate": [0.0, 0.0, 0.5],
            "n_repeat_pairs": [5, 5, 5],
            "repeat_consistency": [1.0, 1.0, 1.0],
            "modal_share": [0.6, 0.6, 0.6],
            "others_modal_share": [0.6, 0.6, 0.6],
            "median_response_ms": [1500.0, 120.0, 1500.0],
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
    assert ScreenRule().min_agreement == 0.6
