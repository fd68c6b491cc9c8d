"""Correlation statistics of a metric against a per-item target, columnar and grouped.

Layer: analysis (statistics of votes and metrics).

Every function works on whole columns (numpy), optionally split into groups by integer
``codes`` — no per-row Python, so the same code runs on 30M rows and on 300.

The rule for undefined statistics (DESIGN habit 7), the same everywhere:

- fewer than 3 items with a finite metric and target -> ``"n < 3"``;
- a metric column constant over those items -> ``"constant metric"``;
- a target constant over those items -> ``"constant target"``;
- ROC AUC with only one class of the binary label -> ``"one class only"``;
- a logistic fit that does not converge -> ``"logistic fit did not converge"``.

The value is then ``NaN`` (an empty cell in the CSV) and the reason is reported beside it.
Constancy is exact (``max == min``): no epsilon decides it.

>>> import numpy as np
>>> x = np.array([1.0, 2.0, 2.0, 4.0]); y = np.array([0.0, 0.5, 0.5, 1.0])
>>> round(float(pearson(x, y)[0]), 6), float(spearman(x, y)[0])
(0.973329, 1.0)
>>> pearson(np.ones(4), y)
(nan, 'constant metric')
"""

from __future__ import annotations

import warnings

import numpy as np
from scipy import stats as _st
from scipy.optimize import OptimizeWarning, curve_fit

__all__ = [
    "N_MIN",
    "rank_within",
    "undefined_reason",
    "grouped_pearson",
    "grouped_spearman",
    "group_counts",
    "pearson",
    "spearman",
    "kendall",
    "roc_auc",
    "logistic4",
    "logistic_plcc",
]

#: Fewer items than this and a correlation is undefined.
N_MIN = 3


def rank_within(x: np.ndarray, codes: np.ndarray | None = None, *, order: np.ndarray | None = None):
    """Average ranks (1-based, ties share their mean rank) of ``x`` within each group.

    x: (n,) finite floats; codes: (n,) non-negative ints (group of each row; ``None`` = one
    group); order: optional precomputed ``np.argsort(x, kind='stable')`` to reuse between
    groupings. Returns (n,) float64 ranks, equal to ``scipy.stats.rankdata`` per group.

    Parameters
    ----------
    x : (n,) float64
        Finite values.
    codes : (n,) int, optional
        Group of each row, non-negative (``None``: one group).
    order : (n,) int, optional
        ``np.argsort(x, kind='stable')``, to reuse.

    Returns
    -------
    (n,) float64
        1-based average ranks within each group.

    >>> rank_within(np.array([3.0, 1.0, 3.0, 2.0]))
    array([3.5, 1. , 3.5, 2. ])
    >>> rank_within(np.array([3.0, 1.0, 3.0, 2.0]), np.array([0, 0, 1, 1]))
    array([2., 1., 2., 1.])
    """
    x = np.asarray(x, dtype=np.float64)
    n = x.shape[0]
    if n == 0:
        return np.empty(0)
    if order is None:
        order = np.argsort(x, kind="stable")
    if codes is not None:
        codes = np.asarray(codes)
        small = codes.astype(np.int16) if n and codes.max() < 2**15 else codes  # radix sort
        order = order[np.argsort(small[order], kind="stable")]
    xs = x[order]
    new = np.empty(n, dtype=bool)
    new[0] = True
    np.not_equal(xs[1:], xs[:-1], out=new[1:])
    if codes is not None:
        cs = codes[order]
        new[1:] |= cs[1:] != cs[:-1]
    starts = np.flatnonzero(new)
    ends = np.append(starts[1:], n)  # exclusive
    mid = (starts + ends - 1) / 2.0 + 1.0
    if codes is not None:
        # rank positions restart at each group's first sorted position
        gnew = np.empty(n, dtype=bool)
        gnew[0] = True
        gnew[1:] = cs[1:] != cs[:-1]
        gstart = np.flatnonzero(gnew)
        gid = np.cumsum(gnew) - 1
        mid = mid - gstart[gid[starts]]
    del xs
    run_id = np.cumsum(new) - 1
    out = np.empty(n, dtype=np.float64)
    out[order] = mid[run_id]
    return out


def undefined_reason(x: np.ndarray, y: np.ndarray) -> str | None:
    """The written rule: why a correlation of x (n,) with y (n,) is undefined, or ``None``.

    Parameters
    ----------
    x, y : (n,) float64
        Paired values.

    Returns
    -------
    str or None
        Why the correlation is undefined (n < 3, a constant column), or ``None``.
    """
    if x.shape[0] < N_MIN:
        return "n < 3"
    if x.min() == x.max():
        return "constant metric"
    if y.min() == y.max():
        return "constant target"
    return None


def group_counts(codes: np.ndarray, n_groups: int) -> np.ndarray:
    """Rows per group: (G,) int64.

    Parameters
    ----------
    codes : (n,) int
        The group code of every row; each must lie in ``[0, n_groups)``.
    n_groups : int
        G, the length of the result (groups without rows count 0).

    Returns
    -------
    (G,) int64
        How many rows carry each code.
    """
    return np.bincount(codes, minlength=n_groups)


def _group_minmax_constant(v: np.ndarray, codes: np.ndarray, n_groups: int) -> np.ndarray:
    """(G,) bool: True where v (n,) is constant (or empty) within the group (exact max == min)."""
    lo = np.full(n_groups, np.inf)
    hi = np.full(n_groups, -np.inf)
    np.minimum.at(lo, codes, v)
    np.maximum.at(hi, codes, v)
    return ~(hi > lo)


def grouped_pearson(x: np.ndarray, y: np.ndarray, codes: np.ndarray, n_groups: int):
    """Signed Pearson r of x (n,) with y (n,) within each of ``n_groups`` groups.

    Returns ``(r (G,) float64, reasons (G,) object)``; undefined groups have NaN and a reason.
    Two-pass (centred) sums, so large offsets do not lose precision.

    Parameters
    ----------
    x, y : (n,) float64
        Paired values.
    codes : (n,) int
        Group of each row, in ``[0, n_groups)``.
    n_groups : int
        Number of groups G.

    Returns
    -------
    r : (G,) float64
        NaN where undefined.
    reasons : (G,) object
        Why each undefined group is, else ``None``.
    """
    if n_groups == 1:  # fast path without group bookkeeping (same formulas)
        return _pearson_one(x, y)
    n = group_counts(codes, n_groups).astype(np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):
        mx = np.bincount(codes, weights=x, minlength=n_groups) / n
        my = np.bincount(codes, weights=y, minlength=n_groups) / n
        xc = x - mx[codes]
        yc = y - my[codes]
        sxy = np.bincount(codes, weights=xc * yc, minlength=n_groups)
        sxx = np.bincount(codes, weights=xc * xc, minlength=n_groups)
        syy = np.bincount(codes, weights=yc * yc, minlength=n_groups)
        r = np.clip(sxy / np.sqrt(sxx * syy), -1.0, 1.0)
    const_x = _group_minmax_constant(x, codes, n_groups)
    const_y = _group_minmax_constant(y, codes, n_groups)
    reasons = np.full(n_groups, None, dtype=object)
    reasons[const_y] = "constant target"
    reasons[const_x] = "constant metric"
    reasons[n < N_MIN] = "n < 3"
    r[reasons != None] = np.nan  # noqa: E711 (elementwise)
    return r, reasons


def _pearson_one(x: np.ndarray, y: np.ndarray):
    why = undefined_reason(x, y)
    if why:
        return np.array([np.nan]), np.array([why], dtype=object)
    xc = x - x.mean()
    yc = y - y.mean()
    r = np.dot(xc, yc) / np.sqrt(np.dot(xc, xc) * np.dot(yc, yc))
    return np.array([np.clip(r, -1.0, 1.0)]), np.array([None], dtype=object)


def grouped_spearman(x, y, codes, n_groups, *, x_order=None, y_order=None):
    """Signed Spearman rho within groups = Pearson of within-group average ranks.

    x, y, codes: (n,); optional argsorts of x and y to reuse. Returns like
    :func:`grouped_pearson`.

    Parameters
    ----------
    x, y : (n,) float64
        Paired values, ranked within their group (ties share the average rank).
    codes : (n,) int
        Group of each row, in ``[0, n_groups)``.
    n_groups : int
        Number of groups G.
    x_order, y_order : (n,) int, optional
        Stable argsorts of ``x`` and ``y``, to reuse.

    Returns
    -------
    rho : (G,) float64
        Spearman's rho of each group; NaN where the values make it undefined.
    reasons : (G,) object
        The rule's reason for each undefined group (as :func:`grouped_pearson`), else ``None``.
    """
    rx = rank_within(x, codes, order=x_order)
    ry = rank_within(y, codes, order=y_order)
    r, reasons = grouped_pearson(rx, ry, codes, n_groups)
    # constancy of ranks within a group == constancy of the values
    return r, reasons


def _one(fn, x, y):
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    r, why = fn(x, y, np.zeros(x.shape[0], dtype=np.intp), 1)
    return float(r[0]), why[0]


def pearson(x, y) -> tuple[float, str | None]:
    """Signed Pearson r of x (n,) and y (n,) (finite values), with the undefined-rule reason.

    Parameters
    ----------
    x : (n,) float64
        Metric values, finite.
    y : (n,) float64
        Target values, finite, paired with ``x``.

    Returns
    -------
    r : float
        Linear correlation in [-1, 1]; NaN when undefined.
    reason : str or None
        ``"n < 3"``, ``"constant metric"`` or ``"constant target"`` where NaN, else ``None``.
    """
    return _one(grouped_pearson, x, y)


def spearman(x, y) -> tuple[float, str | None]:
    """Signed Spearman rho (average ranks for ties) of x (n,) and y (n,).

    Parameters
    ----------
    x, y : (n,) float64
        Paired finite values; only their order within each column matters.

    Returns
    -------
    rho : float
        Pearson r of the two columns' average ranks, in [-1, 1]; NaN when undefined.
    reason : str or None
        Why rho is NaN (the rule of :func:`undefined_reason` on the values), else ``None``.
    """
    return _one(grouped_spearman, x, y)


def kendall(x, y) -> tuple[float, str | None]:
    """Kendall's tau-b of x (n,) and y (n,) (``scipy.stats.kendalltau``, O(n log n)).

    Parameters
    ----------
    x, y : (n,) float64
        Paired finite values; tied pairs enter the tau-b denominator.

    Returns
    -------
    tau : float
        Concordant minus discordant pairs over the tau-b norm, in [-1, 1]; NaN when undefined.
    reason : str or None
        The undefined-rule reason (n < 3 or a constant column), else ``None``.
    """
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    why = undefined_reason(x, y)
    if why:
        return float("nan"), why
    return float(_st.kendalltau(x, y).statistic), None


def roc_auc(labels, scores, *, ranks: np.ndarray | None = None) -> tuple[float, str | None]:
    """Area under the ROC curve of binary ``labels`` (n,) scored by ``scores`` (n,).

    Mann-Whitney form with average ranks, which equals ``sklearn.metrics.roc_auc_score``
    including ties. Undefined with one class only or n < 3. ``ranks`` (n,): precomputed
    :func:`rank_within` of ``scores``, to reuse.

    Parameters
    ----------
    labels : (n,) bool or {0, 1}
        Binary labels.
    scores : (n,) float64
        Scores, higher meaning label 1.
    ranks : (n,) float64, optional
        :func:`rank_within` of ``scores``.

    Returns
    -------
    auc : float
        In [0, 1]; NaN when undefined.
    reason : str or None

    >>> roc_auc(np.array([0, 0, 1, 1]), np.array([0.1, 0.4, 0.35, 0.8]))
    (0.75, None)
    """
    labels = np.asarray(labels).astype(bool)
    scores = np.asarray(scores, dtype=np.float64)
    if labels.shape[0] < N_MIN:
        return float("nan"), "n < 3"
    n1 = int(labels.sum())
    n0 = labels.shape[0] - n1
    if n1 == 0 or n0 == 0:
        return float("nan"), "one class only"
    if ranks is None:
        ranks = rank_within(scores)
    r1 = float(ranks[labels].sum())
    return (r1 - n1 * (n1 + 1) / 2.0) / (n1 * n0), None


def logistic4(x, b1, b2, b3, b4):
    """VQEG 4-parameter logistic: ``(b1 - b2) / (1 + exp(-(x - b3) / |b4|)) + b2``.

    Parameters
    ----------
    x : float or array
        Metric values.
    b1, b2 : float
        The two plateaus.
    b3 : float
        Midpoint.
    b4 : float
        Scale (its absolute value is used).

    Returns
    -------
    float or array
        Shaped as ``x``.
    """
    z = np.clip(-(x - b3) / (np.abs(b4) + 1e-300), -500, 500)
    return (b1 - b2) / (1.0 + np.exp(z)) + b2


def logistic_plcc(x, y, *, max_fit_points: int = 200_000, seed: int = 0):
    """|PLCC| between y (n,) and the VQEG 4-parameter logistic of x (n,) fitted to y.

    Robust initialisation: the curve's plateaus start at the target's extremes (swapped when
    the metric correlates negatively), the midpoint at the metric's median and the slope at
    its interquartile range; three scale guesses are tried. Above ``max_fit_points`` items the
    parameters are fitted on a seeded sample of that size (the PLCC is still computed on all).
    Returns ``(value, reason, note)``.

    Parameters
    ----------
    x : (n,) float64
        Metric values.
    y : (n,) float64
        Target values.
    max_fit_points : int, optional
        Largest sample the logistic is fitted on.
    seed : int, optional
        Seed of that sample.

    Returns
    -------
    value : float
        |PLCC| in [0, 1]; NaN when undefined.
    reason : str or None
        Why it is undefined.
    note : str or None
        Whether the fit used a sample.
    """
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    why = undefined_reason(x, y)
    if why:
        return float("nan"), why, None
    note = None
    xf, yf = x, y
    if x.shape[0] > max_fit_points:
        idx = np.random.default_rng(seed).choice(x.shape[0], max_fit_points, replace=False)
        xf, yf = x[idx], y[idx]
        note = f"logistic fitted on a seeded sample of {max_fit_points} items"
    sign = 1.0 if pearson(xf, yf)[0] >= 0 else -1.0
    lo, hi = float(yf.min()), float(yf.max())
    q1, med, q3 = np.percentile(xf, [25, 50, 75])
    spread = float(q3 - q1) or float(xf.std()) or 1.0
    b1, b2 = (hi, lo) if sign > 0 else (lo, hi)
    best = None  # (well determined, |PLCC|): a fit with estimable parameters is preferred
    for scale in (0.25, 1.0, 4.0):
        fit = _fit_logistic(xf, yf, [b1, b2, med, spread * scale])
        if fit is None:
            continue
        fitted = logistic4(x, *fit[0])
        if not np.all(np.isfinite(fitted)) or fitted.min() == fitted.max():
            continue
        r = abs(pearson(fitted, y)[0])
        if np.isfinite(r) and (best is None or (fit[1], r) > best):
            best = (fit[1], r)
    if best is None:
        return float("nan"), "logistic fit did not converge", note
    return float(best[1]), None if best[0] else DEGENERATE_FIT, note


#: The reason of a logistic fit whose parameters are not determined by the data.
DEGENERATE_FIT = ("degenerate fit, value kept: the parameters' covariance could not be "
                  "estimated (the target is a step or flat along the metric)")


def _fit_logistic(x, y, p0):
    """``(params, well_determined)`` of one :func:`logistic4` fit, ``None`` when it fails.

    SciPy's ``OptimizeWarning`` (parameter covariance not estimable: the fit is degenerate)
    becomes ``well_determined = False`` instead of a warning on the terminal; other warnings
    pass through."""
    with warnings.catch_warnings(record=True) as caught, np.errstate(all="ignore"):
        warnings.simplefilter("always", OptimizeWarning)
        try:
            p, _ = curve_fit(logistic4, x, y, p0=p0, maxfev=4000)
        except (RuntimeError, ValueError, FloatingPointError):
            p = None
    degenerate = False
    for w in caught:
        if issubclass(w.category, OptimizeWarning):
            degenerate = True
        else:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    return None if p is None else (p, not degenerate)
