"""Issue 38 items 22 and 23: what the report pages say about their input and their fits."""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd

from analysis.cli import main
from analysis.pairwise import BT_COLUMNS
from analysis.report.pairwise_report import bt_display
from analysis.stats.stats import DEGENERATE_FIT, logistic_plcc
from tests.analysis.test_all_pairs import _pairs


def _bt(methods):
    k = len(methods)
    p = np.arange(k, 0, -1, dtype=float)
    p /= p.sum()
    rows = [{"axis": "all", "offset": np.nan, "method": m, "n_votes": 10, "wins": 5, "ties": 0,
             "losses": 5, "score": p[i], "score_ci_lo": np.nan, "score_ci_hi": np.nan,
             "win_prob": np.mean([p[i] / (p[i] + p[j]) for j in range(k) if j != i]),
             "win_prob_ci_lo": np.nan, "win_prob_ci_hi": np.nan, "reason": None}
            for i, m in enumerate(methods)]
    return pd.DataFrame(rows, columns=BT_COLUMNS)


def test_two_methods_show_the_win_probability_once():
    # two methods: strengths sum to 1, so P(a beats b) = p_a / (p_a + p_b) = p_a, the BT score
    bt = _bt(["a", "b"])
    assert np.allclose(bt["score"], bt["win_prob"])
    t = bt_display(bt)
    assert "BT score" not in t.columns and "win probability" in t.columns
    assert "BT score" in bt_display(_bt(["a", "b", "c"])).columns  # differs from 3 methods on


def test_pairs_report_header_does_not_call_pairs_ratings(tmp_path, capsys):
    full = _pairs(np.random.default_rng(3))
    full.drop(columns=["clip_drop"]).to_csv(tmp_path / "pairs.csv", index=False)
    full[["pair_id", "clip_drop"]].to_csv(tmp_path / "proxy.csv", index=False)
    rc = main(["--pairs", str(tmp_path / "pairs.csv"), "--metrics-table", str(tmp_path / "proxy.csv"),
               "--target", "clip_drop", "--bootstrap", "0", "--out", str(tmp_path / "o"), "--quiet"])
    assert rc == 0, capsys.readouterr().err
    for page in ("report.html", "report.md"):
        text = (tmp_path / "o" / page).read_text()
        assert "Ratings:" not in text and "Pairs (no votes; analyze --pairs)" in text, page


def test_a_degenerate_logistic_fit_is_a_reason_not_a_warning():
    """Issue 38 item 23: 4 items whose target is not monotone in the metric (from the demo's
    per-class ceiling): every start of the 4-parameter fit ends with a singular covariance.
    SciPy's OptimizeWarning used to reach the terminal; it is now the value's reason."""
    x = np.array([4.0, 3.0, 2.0, 1.0])
    y = np.array([0.75, 1.0, 0.75, 0.25])
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # any warning fails the test
        value, why, _ = logistic_plcc(x, y)
    assert why == DEGENERATE_FIT and 0.0 <= value <= 1.0
    # a well-determined fit keeps no reason (noisy logistic, 200 points)
    rng = np.random.default_rng(0)
    x = rng.normal(size=200)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        value, why, _ = logistic_plcc(x, 1 / (1 + np.exp(-2 * x)) + rng.normal(0, 0.05, 200))
    assert why is None and value > 0.9
