"""Statistics against scipy.stats / sklearn.metrics (independent references) on data with ties."""

import numpy as np
import pytest
from scipy import stats as st
from sklearn.metrics import roc_auc_score

from analysis.stats import stats


def _tied(rng, n):
    # rounding creates many ties in both columns
    x = np.round(rng.normal(size=n), 1)
    y = np.round(0.5 * x + rng.normal(size=n), 1)
    return x, y


@pytest.mark.parametrize("seed", range(5))
def test_correlations_equal_scipy_with_ties(seed):
    rng = np.random.default_rng(seed)
    x, y = _tied(rng, 200)
    assert stats.pearson(x, y)[0] == pytest.approx(st.pearsonr(x, y).statistic, abs=1e-12)
    assert stats.spearman(x, y)[0] == pytest.approx(st.spearmanr(x, y).statistic, abs=1e-12)
    assert stats.kendall(x, y)[0] == pytest.approx(st.kendalltau(x, y).statistic, abs=1e-12)


@pytest.mark.parametrize("seed", range(5))
def test_roc_auc_equals_sklearn_with_ties(seed):
    rng = np.random.default_rng(seed)
    score = rng.integers(0, 6, 150).astype(float)  # heavy ties
    label = (score + rng.normal(0, 2, 150)) > 2.5
    assert stats.roc_auc(label, score)[0] == pytest.approx(roc_auc_score(label, score), abs=1e-12)


def test_rank_within_equals_rankdata_per_group():
    rng = np.random.default_rng(1)
    x = rng.integers(0, 10, 500).astype(float)
    codes = rng.integers(0, 4, 500)
    r = stats.rank_within(x, codes)
    for g in range(4):
        np.testing.assert_allclose(r[codes == g], st.rankdata(x[codes == g]))  # scipy reference


def test_grouped_correlations_equal_scipy_per_group():
    rng = np.random.default_rng(2)
    x, y = _tied(rng, 600)
    codes = rng.integers(0, 3, 600)
    p, _ = stats.grouped_pearson(x, y, codes, 3)
    s, _ = stats.grouped_spearman(x, y, codes, 3)
    for g in range(3):
        m = codes == g
        assert p[g] == pytest.approx(st.pearsonr(x[m], y[m]).statistic, abs=1e-12)
        assert s[g] == pytest.approx(st.spearmanr(x[m], y[m]).statistic, abs=1e-12)


def test_undefined_cases_are_empty_with_reason():
    y = np.array([0.1, 0.5, 0.9, 0.3])
    for fn in (stats.pearson, stats.spearman, stats.kendall):
        assert (
            np.isnan(fn(np.full(4, 2.0), y)[0]) and fn(np.full(4, 2.0), y)[1] == "constant metric"
        )
        assert fn(y, np.ones(4))[1] == "constant target"
        assert fn(y[:2], y[:2])[1] == "n < 3"
    v, why = stats.roc_auc(np.ones(4, bool), y)
    assert np.isnan(v) and why == "one class only"
    v, why, _ = stats.logistic_plcc(np.full(4, 1.0), y)
    assert np.isnan(v) and why == "constant metric"


def test_grouped_undefined_group_does_not_spoil_others():
    x = np.array([1.0, 2.0, 3.0, 5.0, 5.0, 5.0, 1.0])
    y = np.array([1.0, 2.0, 4.0, 1.0, 2.0, 3.0, 9.0])
    codes = np.array([0, 0, 0, 1, 1, 1, 2])
    r, why = stats.grouped_pearson(x, y, codes, 3)
    assert r[0] == pytest.approx(st.pearsonr(x[:3], y[:3]).statistic)
    assert np.isnan(r[1]) and why[1] == "constant metric"
    assert np.isnan(r[2]) and why[2] == "n < 3"


def test_logistic_plcc_recovers_a_logistic_relation():
    # y is exactly a VQEG logistic of x: the fitted PLCC is 1 while the linear one is lower
    x = np.linspace(-3, 3, 300)
    y = stats.logistic4(x, 5.0, 1.0, 0.5, 0.4)
    v, why, _ = stats.logistic_plcc(x, y)
    assert why is None and v == pytest.approx(1.0, abs=1e-6)
    assert abs(st.pearsonr(x, y).statistic) < 0.97
    # decreasing relation: same
    v, why, _ = stats.logistic_plcc(-x, y)
    assert v == pytest.approx(1.0, abs=1e-6)


def test_logistic_plcc_large_input_fits_on_a_sample_and_says_so():
    rng = np.random.default_rng(0)
    x = rng.normal(size=5000)
    y = stats.logistic4(x, 1.0, 0.0, 0.0, 0.5) + rng.normal(0, 0.05, 5000)
    v, why, note = stats.logistic_plcc(x, y, max_fit_points=1000)
    full, _, _ = stats.logistic_plcc(x, y)
    assert why is None and "1000" in note
    assert v == pytest.approx(full, abs=0.01)
