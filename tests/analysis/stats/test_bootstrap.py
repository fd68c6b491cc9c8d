"""The weighted bootstrap statistics equal scipy/sklearn on the explicitly duplicated data."""

import numpy as np
import pytest
from scipy import stats as st
from sklearn.metrics import roc_auc_score

from analysis.stats import bootstrap as bs


def test_replicates_equal_statistics_of_the_resampled_data():
    rng = np.random.default_rng(3)
    n, k = 60, 12
    cluster = rng.integers(0, k, n)
    x = np.round(rng.normal(size=n), 1)
    y = np.round(x + rng.normal(size=n), 1)
    label = y > 0
    counts = bs.draw_cluster_counts(k, 5, seed=7)
    assert (counts.sum(axis=1) == k).all()
    reps = bs.replicate_stats(x, y, label, cluster, counts)
    for b in range(5):
        idx = np.repeat(np.arange(n), counts[b][cluster])  # the resampled data set itself
        xs, ys, ls = x[idx], y[idx], label[idx]
        assert reps["plcc"][b] == pytest.approx(st.pearsonr(xs, ys).statistic, abs=1e-10)
        assert reps["srcc"][b] == pytest.approx(st.spearmanr(xs, ys).statistic, abs=1e-10)
        assert reps["roc_auc"][b] == pytest.approx(roc_auc_score(ls, xs), abs=1e-10)


def test_draws_are_seeded():
    a = bs.draw_cluster_counts(10, 4, seed=1)
    assert (a == bs.draw_cluster_counts(10, 4, seed=1)).all()
    assert (a != bs.draw_cluster_counts(10, 4, seed=2)).any()


def test_percentile_ci_and_paired_difference():
    reps = np.arange(1001, dtype=float) / 1000  # quantiles of a known uniform grid
    lo, hi, why = bs.percentile_ci(reps)
    assert (lo, hi, why) == (pytest.approx(0.025), pytest.approx(0.975), None)
    lo, hi, why = bs.percentile_ci(np.full(10, np.nan))
    assert np.isnan(lo) and why
    lo, hi, p = bs.paired_difference(reps + 1.0, reps)  # always better by exactly 1
    assert lo == pytest.approx(1.0) and hi == pytest.approx(1.0) and p == 0.0


def test_replicates_for_a_holm_family():
    # (the add-one bootstrap p-value, monte_carlo_p, gave way to the sign-flip test over tracks
    # of analysis.stats.signflip in issue 29; its floor 1 / (B + 1) is below the 2 / (B + 1) here)
    # enough replicates that 2 / (B + 1) * m < alpha / 2
    for m in (1, 12, 80):
        b = bs.replicates_for(100, m)
        assert 2 / (b + 1) * m < 0.025 and b >= 100
