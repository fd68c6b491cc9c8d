"""Seeded cluster bootstrap over tracks: confidence intervals and paired differences.

Layer: analysis (statistics of votes and metrics).

Items of one object track (``(clip_id, track_id)``) are not independent (the same car at
several offsets and frames), so the bootstrap resamples *tracks* with replacement and keeps
all items of every drawn track. A draw is represented by per-item weights (how many times
the item's track was drawn), and every statistic is computed on the weighted data, which is
exactly the statistic of the resampled (duplicated) data set:

- weighted Pearson r;
- Spearman rho = weighted Pearson of the *weighted* average ranks (a tie block of total
  weight T after cumulative weight C has rank C + (T + 1) / 2);
- ROC AUC = Mann-Whitney with those ranks.

All replicates share the same track draws, so differences between metrics are paired.

>>> import numpy as np
>>> w = np.array([[2.0, 0.0, 1.0, 1.0]])
>>> weighted_ranks(np.array([1.0, 2.0, 2.0, 3.0]), w)
array([[1.5, 3. , 3. , 4. ]])
"""

from __future__ import annotations

import numpy as np

from analysis.stats.stats import N_MIN

__all__ = [
    "CHUNK_CELLS",
    "draw_cluster_counts",
    "weighted_ranks",
    "weighted_pearson",
    "replicate_stats",
    "percentile_ci",
    "MIN_RATERS",
    "too_few_raters",
    "interval_around",
    "paired_difference",
    "replicates_for",
]

#: The most cells (bootstrap replicates x items, tracks or clusters) one weighted product of
#: the bootstrap holds at a time; replicates are processed in chunks of at most this size.
#: Chunking bounds the memory only: every replicate is computed on its own, so the results
#: do not depend on it.
CHUNK_CELLS = 8_000_000


def draw_cluster_counts(n_clusters: int, n_boot: int, *, seed: int) -> np.ndarray:
    """(B, K) int32: how often each of K clusters is drawn in each of B replicates.

    Parameters
    ----------
    n_clusters : int
        Clusters K.
    n_boot : int
        Replicates B.
    seed : int
        Seed of the draws.

    Returns
    -------
    (B, K) int32
    """
    rng = np.random.default_rng(seed)
    draws = rng.integers(0, n_clusters, size=(n_boot, n_clusters))
    counts = np.zeros((n_boot, n_clusters), dtype=np.int32)
    np.add.at(counts, (np.repeat(np.arange(n_boot), n_clusters), draws.ravel()), 1)
    return counts


def weighted_ranks(x: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Average ranks of x (n,) in data where item i appears w[b, i] times: (B, n) float64.

    Parameters
    ----------
    x : (n,) float64
        Values.
    w : (B, n) int
        Multiplicity of each item in each replicate.

    Returns
    -------
    (B, n) float64
    """
    order = np.argsort(x, kind="stable")
    xs = x[order]
    new = np.r_[True, xs[1:] != xs[:-1]]
    starts = np.flatnonzero(new)
    run_id = np.cumsum(new) - 1
    tot = np.add.reduceat(w[:, order], starts, axis=1)  # (B, R) weight of each tie block
    before = np.cumsum(tot, axis=1) - tot
    mid = before + (tot + 1.0) / 2.0
    out = np.empty(w.shape, dtype=np.float64)
    out[:, order] = mid[:, run_id]
    return out


def weighted_pearson(x: np.ndarray, y: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Pearson r per replicate: x, y (n,) or (B, n); w (B, n). Returns (B,), NaN if undefined.

    Parameters
    ----------
    x, y : (n,) or (B, n) float64
        Paired values.
    w : (B, n) int
        Multiplicity of each item in each replicate.

    Returns
    -------
    (B,) float64
        NaN where undefined.
    """
    sw = w.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        mx = (w * x).sum(axis=1) / sw
        my = (w * y).sum(axis=1) / sw
        xc = x - mx[:, None]
        yc = y - my[:, None]
        sxy = (w * xc * yc).sum(axis=1)
        sxx = (w * xc * xc).sum(axis=1)
        syy = (w * yc * yc).sum(axis=1)
        r = sxy / np.sqrt(sxx * syy)
    # exact constancy among drawn items, as in the single-sample rule
    drawn = w > 0
    for v in (x, y):
        vv = np.broadcast_to(v, w.shape)
        lo = np.where(drawn, vv, np.inf).min(axis=1)
        hi = np.where(drawn, vv, -np.inf).max(axis=1)
        r[~(hi > lo)] = np.nan
    r[sw < N_MIN] = np.nan
    return np.clip(r, -1.0, 1.0)


def replicate_stats(x, y, label, cluster, counts, *, chunk_cells: int = CHUNK_CELLS):
    """Bootstrap replicates of signed plcc, srcc and roc_auc of metric x against target y.

    x, y: (n,) finite; label: (n,) bool or None (no AUC); cluster: (n,) int cluster index
    into the columns of counts (B, K). Returns dict name -> (B,) float64 (NaN = undefined).

    Parameters
    ----------
    x : (n,) float64
        Metric values, finite.
    y : (n,) float64
        Target values, finite.
    label : (n,) bool or None
        Binary target of the AUC (``None``: no AUC).
    cluster : (n,) int
        Cluster of each item, a column of ``counts``.
    counts : (B, K) int32
        :func:`draw_cluster_counts`.
    chunk_cells : int, optional
        Replicates x items computed at once (memory bound).

    Returns
    -------
    dict
        ``'plcc'``, ``'srcc'`` (and ``'roc_auc'``) -> (B,) float64, NaN where undefined.
    """
    n_boot = counts.shape[0]
    out = {k: np.full(n_boot, np.nan) for k in ("plcc", "srcc", "roc_auc")}
    step = max(1, chunk_cells // max(1, x.shape[0]))
    for b0 in range(0, n_boot, step):
        w = counts[b0 : b0 + step][:, cluster].astype(np.float64)  # (b, n)
        sl = slice(b0, b0 + w.shape[0])
        out["plcc"][sl] = weighted_pearson(x, y, w)
        rx = weighted_ranks(x, w)
        out["srcc"][sl] = weighted_pearson(rx, weighted_ranks(y, w), w)
        if label is not None:
            lw = w * label
            w1 = lw.sum(axis=1)
            w0 = w.sum(axis=1) - w1
            with np.errstate(invalid="ignore", divide="ignore"):
                auc = ((lw * rx).sum(axis=1) - w1 * (w1 + 1) / 2.0) / (w1 * w0)
            auc[(w1 == 0) | (w0 == 0)] = np.nan
            out["roc_auc"][sl] = auc
    return out


def percentile_ci(reps: np.ndarray, *, level: float = 0.95, min_defined: float = 0.5):
    """Percentile interval of replicates (B,). Returns ``(lo, hi, reason)``.

    Undefined replicates (NaN) are left out; if fewer than ``min_defined`` of them are
    defined the interval is empty with the reason.

    Parameters
    ----------
    reps : (B,) float64
        Replicates, NaN where undefined.
    level : float, optional
        Coverage of the interval.
    min_defined : float, optional
        Smallest share of defined replicates.

    Returns
    -------
    lo, hi : float
        NaN when undefined.
    reason : str or None
    """
    ok = np.isfinite(reps)
    if reps.shape[0] == 0 or ok.mean() < min_defined:
        return float("nan"), float("nan"), "bootstrap replicates mostly undefined"
    a = (1.0 - level) / 2.0
    lo, hi = np.quantile(reps[ok], [a, 1.0 - a])
    return float(lo), float(hi), None


#: The fewest raters a bootstrap over raters gives an interval from. R raters allow
#: C(2R - 1, R) distinct resamples: one rater only itself (a zero-width interval), two raters
#: three; below this many the table gives no interval and says why (:func:`too_few_raters`).
MIN_RATERS = 3


def too_few_raters(n_raters: int) -> str | None:
    """The reason a bootstrap over ``n_raters`` raters gives no interval, or ``None``.

    >>> too_few_raters(1)
    'no interval from 1 rater: a bootstrap over raters needs at least 3'
    >>> too_few_raters(3) is None
    True
    """
    if n_raters >= MIN_RATERS:
        return None
    return (f"no interval from {n_raters} rater{'' if n_raters == 1 else 's'}: a bootstrap over "
            f"raters needs at least {MIN_RATERS}")


def interval_around(estimate: float, reps: np.ndarray, *, level: float = 0.95,
                    min_defined: float = 0.5) -> tuple[float, float, str | None]:
    """:func:`percentile_ci` of ``reps``, given only when it contains ``estimate``.

    A percentile interval that misses its own estimate (replicates biased to one side, e.g.
    by a fit that stops elsewhere on a flat likelihood) would be read as the estimate's
    uncertainty; it is left out with the reason. A miss within rounding (1e-6 relative) is
    not one: the interval is widened to the estimate.

    Parameters
    ----------
    estimate : float
        The statistic on all the data.
    reps : (B,) float64
        Its bootstrap replicates, NaN where undefined.
    level, min_defined : float, optional
        As :func:`percentile_ci`.

    Returns
    -------
    lo, hi : float
        NaN when no interval is given.
    reason : str or None

    >>> interval_around(1.0, np.array([0.5, 1.0, 1.5]))[:2]
    (0.525, 1.475)
    >>> interval_around(4.732, np.full(10, 4.7086))[2]
    'the estimate lies outside its bootstrap interval [4.709, 4.709]: no interval given'
    """
    if not np.isfinite(estimate):
        return float("nan"), float("nan"), None
    lo, hi, why = percentile_ci(reps, level=level, min_defined=min_defined)
    if why:
        return lo, hi, why
    tol = 1e-6 * (1.0 + abs(estimate))
    if estimate < lo - tol or estimate > hi + tol:
        return float("nan"), float("nan"), (f"the estimate lies outside its bootstrap interval "
                                             f"[{lo:.4g}, {hi:.4g}]: no interval given")
    return min(lo, estimate), max(hi, estimate), None


def paired_difference(best: np.ndarray, other: np.ndarray, *, level: float = 0.95):
    """Paired bootstrap of ``best - other`` (B,) each. Returns ``(lo, hi, p_two_sided)``.

    The difference is significant at ``1 - level`` when the interval excludes 0. The p-value
    is ``2 * min(P(d <= 0), P(d >= 0))`` over defined replicates (capped at 1).

    Parameters
    ----------
    best, other : (B,) float64
        Paired replicates of two statistics.
    level : float, optional
        Coverage of the interval.

    Returns
    -------
    lo, hi : float
        Interval of ``best - other``.
    p : float
        Two-sided bootstrap p-value, in [0, 1].
    """
    d = best - other
    d = d[np.isfinite(d)]
    if d.shape[0] == 0:
        return float("nan"), float("nan"), float("nan")
    a = (1.0 - level) / 2.0
    lo, hi = np.quantile(d, [a, 1.0 - a])
    p = min(1.0, 2.0 * min(float((d <= 0).mean()), float((d >= 0).mean())))
    return float(lo), float(hi), p


def replicates_for(n_boot: int, n_tests: int, *, alpha: float = 0.05) -> int:
    """Replicates for ``n_tests`` Monte Carlo p-values under Holm: at least ``n_boot``, and
    enough that ``2 / (B + 1)`` (twice the floor of an add-one Monte Carlo p-value, such as
    the sign-flip test of :mod:`analysis.stats.signflip`) times ``n_tests`` is below ``alpha / 2``
    (``B >= 4 n_tests / alpha``), so a decisive difference can be called in a family that size.

    Parameters
    ----------
    n_boot : int
        The replicates asked for.
    n_tests : int
        Tests in the Holm family.
    alpha : float, optional
        Family-wise error rate.

    Returns
    -------
    int

    >>> replicates_for(1000, 12), replicates_for(1000, 32), replicates_for(0, 5)
    (1000, 2560, 0)
    """
    if n_boot <= 0:
        return 0
    return max(int(n_boot), int(np.ceil(4 * n_tests / alpha)))
