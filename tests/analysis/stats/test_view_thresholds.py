"""Per-view thresholds: one logistic, an intercept per view and a shared slope
(analysis.stats.horizon_fit.view_thresholds), against scikit-learn's unpenalised logistic
regression on the one-hot views plus the metric (the same maximum-likelihood model)."""

import numpy as np
import pytest
from sklearn.linear_model import LogisticRegression

from analysis.stats.horizon_fit import monotone_view_thresholds, pav, view_thresholds


def _votes(seed=0, n=3000):
    rng = np.random.default_rng(seed)
    view = rng.integers(0, 4, n)
    x = rng.normal(0, 1, n) - 0.5 * view  # the metric falls with the view
    a_true, b_true = np.array([0.5, 1.5, 2.5, 3.5]), 2.0  # the people forgive the view
    y = (rng.random(n) < 1 / (1 + np.exp(-(a_true[view] + b_true * x)))).astype(float)
    return x, y, view


def test_view_thresholds_equal_sklearn():
    x, y, view = _votes()
    r = view_thresholds(x, y, view, good_prob=0.7)
    X = np.c_[np.eye(4)[view], x]
    m = LogisticRegression(C=np.inf, fit_intercept=False, tol=1e-12, max_iter=10_000).fit(X, y)
    a, b = m.coef_[0][:4], m.coef_[0][4]
    assert np.allclose(r["a"], a, atol=1e-4) and np.isclose(r["b"], b, atol=1e-4)
    assert np.allclose(r["value"], (np.log(0.7 / 0.3) - a) / b, atol=1e-4)
    assert np.all(np.diff(r["value"]) < 0)  # farther views get a lower metric threshold


def test_a_view_with_one_outcome_gets_the_limit_and_changes_nothing_else():
    x, y, view = _votes(seed=1)
    y[view == 3] = 1.0
    r = view_thresholds(x, y, view)
    # every vote good at view 3: its intercept grows without bound, its threshold goes to -inf
    assert r["value"][3] == -np.inf and r["a"][3] == np.inf and np.isfinite(r["value"][:3]).all()
    keep = view < 3
    ref = view_thresholds(x[keep], y[keep], view[keep])
    assert np.allclose(r["value"][:3], ref["value"], atol=1e-9)  # the view left out changes nothing


def _nll(theta, x, y, view, V):
    z = theta[view] + theta[V] * x
    return float(np.sum(np.logaddexp(0.0, z) - y * z))


def test_view_thresholds_equal_a_direct_scipy_fit():
    from scipy.optimize import minimize

    x, y, view = _votes(seed=2, n=2000)
    r = view_thresholds(x, y, view, good_prob=0.5)
    best = minimize(_nll, np.zeros(5), args=(x, y, view, 4), method="BFGS", options={"gtol": 1e-10})
    a, b = best.x[:4], best.x[4]
    assert np.allclose(r["value"], -a / b, atol=1e-6)
    assert np.allclose(r["n"], np.bincount(view))


def test_weights_are_copies_of_the_votes():
    # a weight of k is the vote counted k times: the fit of the copied data, row by row
    x, y, view = _votes(seed=3, n=400)
    rng = np.random.default_rng(0)
    w = rng.integers(0, 3, (3, len(x))).astype(float)
    r = view_thresholds(x, y, view, w=w)
    for row in range(3):
        k = w[row].astype(int)
        ref = view_thresholds(np.repeat(x, k), np.repeat(y, k), np.repeat(view, k))
        assert np.allclose(r["value"][row], ref["value"], atol=1e-8)
        assert r["b"][row] == pytest.approx(ref["b"], abs=1e-8)


def test_pav_equals_sklearn_isotonic_regression():
    from sklearn.isotonic import IsotonicRegression

    rng = np.random.default_rng(5)
    y = (rng.random(300) < np.linspace(0.1, 0.9, 300)).astype(float)
    w = rng.uniform(0.5, 2.0, 300)
    ref = IsotonicRegression().fit(np.arange(300), y, sample_weight=w).predict(np.arange(300))
    assert np.allclose(pav(y, w), ref, atol=1e-12)


def test_monotone_thresholds_are_where_the_isotonic_fit_reaches_good_prob():
    from sklearn.isotonic import IsotonicRegression

    x, y, view = _votes(seed=6, n=1500)
    r = monotone_view_thresholds(x, y, view, good_prob=0.6)
    for v in range(4):
        on = view == v
        ux = np.unique(x[on])
        f = IsotonicRegression().fit(x[on], y[on]).predict(ux)
        k = int(np.argmax(f >= 0.6))
        assert 0 < k and r["value"][v] == pytest.approx(0.5 * (ux[k - 1] + ux[k]))
    # lower is better: the same fit of the negated metric, negated back
    low = monotone_view_thresholds(-x, y, view, good_prob=0.6, increasing=False)
    assert np.allclose(low["value"], -r["value"])
    # a view of good votes only: every object there is good (the limit -inf)
    y2 = np.where(view == 2, 1.0, y)
    assert monotone_view_thresholds(x, y2, view)["value"][2] == -np.inf
