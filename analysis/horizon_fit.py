"""The threshold of the trust horizon from people's votes: where P(good | metric) = ``good_prob``.

Layer: ``analysis`` (votes in, a :class:`nvrq.horizon.Threshold` out; NumPy only).

Every test vote is a Bernoulli trial (1 good, 0 bad) at its item's metric value ``m``; the
model is the two-parameter logistic ``P(good | m) = 1 / (1 + exp(-(a + b m)))`` fitted by
maximum likelihood (Newton's method on the standardised metric, vectorised over bootstrap
replicates). The threshold is the metric value where the fitted P(good) equals ``good_prob``:
``m* = (logit(good_prob) - a) / b``. Its 95% interval is the percentile interval of a
two-way cluster bootstrap: raters and tracks are drawn with replacement independently, and a
vote's weight is (times its rater is drawn) x (times its track is drawn), so both sources of
dependence (a rater's own threshold, the same object at several offsets) are resampled.

>>> x = np.array([0.0, 1, 2, 3, 4, 5]); y = np.array([0, 0, 1, 0, 1, 1])
>>> a, b = fit_logistic(x, y)
>>> round(float((0 - a[0]) / b[0]), 6)  # P(good) = 0.5 where a + b m = 0; symmetric data: 2.5
2.5
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["fit_logistic", "logistic_threshold", "vote_threshold", "view_thresholds", "MAX_ITER"]

#: Newton iterations at most (a well-posed fit converges in under 10).
MAX_ITER = 100


def fit_logistic(x: np.ndarray, y: np.ndarray, w: np.ndarray | None = None, *,
                 tol: float = 1e-10, start: tuple[float, float] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Maximum-likelihood logistic ``P(y = 1 | x) = sigmoid(a + b x)``, once per weight row.

    Parameters
    ----------
    x : numpy.ndarray
        (n,) the predictor (finite).
    y : numpy.ndarray
        (n,) outcomes, 0 or 1.
    w : numpy.ndarray, optional
        (B, n) non-negative weights (a bootstrap replicate's counts); default one row of ones.
    tol : float, optional
        Convergence: the largest Newton step (standardised units) below it.
    start : tuple of float, optional
        ``(a, b)`` to start from (e.g. the fit to all votes, for the replicates); default 0, 0.

    Returns
    -------
    tuple of numpy.ndarray
        ``(a, b)``, each (B,); NaN where the fit is undefined (one outcome only, a constant x,
        no weight).
    """
    x = np.asarray(x, np.float64)
    y = np.asarray(y, np.float64)
    w = np.ones((1, len(x))) if w is None else np.asarray(w, np.float64)
    mu, sd = float(x.mean()), float(x.std()) or 1.0
    z = (x - mu) / sd
    theta = np.zeros((w.shape[0], 2))
    if start is not None and all(math.isfinite(v) for v in start):
        theta[:] = (start[0] + start[1] * mu, start[1] * sd)
    for _ in range(MAX_ITER):
        p = 1.0 / (1.0 + np.exp(-(theta[:, :1] + theta[:, 1:] * z)))
        r, v = w * (y - p), w * p * (1.0 - p)
        g0, g1 = r.sum(axis=1), (r * z).sum(axis=1)
        h00, h01, h11 = v.sum(axis=1), (v * z).sum(axis=1), (v * z * z).sum(axis=1)
        det = h00 * h11 - h01 * h01
        with np.errstate(invalid="ignore", divide="ignore"):
            step = np.stack([(h11 * g0 - h01 * g1) / det, (h00 * g1 - h01 * g0) / det], axis=1)
        step = np.where(np.isfinite(step), step, 0.0)
        size = np.abs(step).max(axis=1, keepdims=True)
        step *= np.minimum(1.0, 5.0 / np.maximum(size, 1e-300))  # damped: no overshoot under separation
        theta += step
        if size.max() < tol:
            break
    a = theta[:, 0] - theta[:, 1] * mu / sd
    b = theta[:, 1] / sd
    bad = ~_fit_defined(x, y, w)
    a[bad], b[bad] = np.nan, np.nan
    return a, b


def _fit_defined(x: np.ndarray, y: np.ndarray, w: np.ndarray) -> np.ndarray:
    """(B,) True where the weighted data have both outcomes and two distinct x."""
    drawn = w > 0
    both = (drawn & (y == 1)).any(axis=1) & (drawn & (y == 0)).any(axis=1)
    lo = np.where(drawn, x, np.inf).min(axis=1)
    hi = np.where(drawn, x, -np.inf).max(axis=1)
    return both & (hi > lo)


def logistic_threshold(a: np.ndarray, b: np.ndarray, good_prob: float) -> np.ndarray:
    """(B,) the x where ``sigmoid(a + b x) = good_prob`` (NaN where b is 0 or undefined).

    Parameters
    ----------
    a, b : numpy.ndarray
        (B,) the fitted intercept and slope.
    good_prob : float
        The probability, in (0, 1).

    Returns
    -------
    numpy.ndarray
        (B,) float64.
    """
    with np.errstate(invalid="ignore", divide="ignore"):
        t = (math.log(good_prob / (1.0 - good_prob)) - a) / b
    return np.where(np.isfinite(t), t, np.nan)


def _counts(n: int, n_boot: int, rng) -> np.ndarray:
    return rng.multinomial(n, np.full(n, 1.0 / n), size=n_boot).astype(np.float64)


def vote_threshold(x, y, rater, track, *, good_prob: float = 0.5, n_boot: int = 1000,
                   seed: int = 0) -> dict:
    """The threshold where P(good | metric) = ``good_prob`` and its two-way bootstrap interval.

    Parameters
    ----------
    x : numpy.ndarray
        (n,) the metric at each vote's item (finite).
    y : numpy.ndarray
        (n,) the votes, 1 good and 0 bad.
    rater, track : numpy.ndarray
        (n,) integer codes of each vote's rater and its item's track (0..R-1, 0..T-1).
    good_prob : float, optional
        The P(good) that defines the threshold, in (0, 1).
    n_boot, seed : int, optional
        Bootstrap replicates (0: no interval) and their seed.

    Returns
    -------
    dict
        ``value, ci_lo, ci_hi`` (metric units), ``a, b`` (the fit), ``n_votes``, ``n_raters``,
        ``n_tracks`` and ``reason`` (why the value or the interval is undefined, else ``''``).
    """
    from analysis.bootstrap import interval_around, too_few_raters

    rater, track = np.asarray(rater, np.int64), np.asarray(track, np.int64)
    a, b = fit_logistic(x, y)
    value = float(logistic_threshold(a, b, good_prob)[0])
    R, T = int(rater.max()) + 1 if len(rater) else 0, int(track.max()) + 1 if len(track) else 0
    out = {"value": value, "ci_lo": math.nan, "ci_hi": math.nan, "a": float(a[0]), "b": float(b[0]),
           "n_votes": len(x), "n_raters": R, "n_tracks": T, "reason": ""}
    if not math.isfinite(value):
        out["reason"] = "logistic fit undefined (one vote value only, or a constant metric)"
    elif n_boot > 0 and too_few_raters(R):
        out["reason"] = too_few_raters(R)
    elif n_boot > 0 and T < 2:
        out["reason"] = f"no interval from {T} track: a bootstrap over tracks needs at least 2"
    elif n_boot > 0:
        rng = np.random.default_rng(seed)
        cr, ct = _counts(R, n_boot, rng), _counts(T, n_boot, rng)
        fits = (fit_logistic(x, y, cr[s][:, rater] * ct[s][:, track], start=(a[0], b[0]))
                for s in _chunks(n_boot, len(x)))
        reps = np.concatenate([logistic_threshold(fa, fb, good_prob) for fa, fb in fits])
        out["ci_lo"], out["ci_hi"], why = interval_around(value, reps)
        out["reason"] = why or ""
    return out


def _chunks(n_boot: int, n: int, cells: int = 4_000_000):
    """Slices of the replicates, at most ``cells`` replicate-votes each (bounds the memory)."""
    step = max(1, cells // max(1, n))
    return [slice(i, min(n_boot, i + step)) for i in range(0, n_boot, step)]


def view_thresholds(x, y, view, *, good_prob: float = 0.5, tol: float = 1e-10) -> dict:
    """Per-view thresholds from one logistic with an intercept per view cell and a shared slope.

    The model is ``P(good | m, view v) = sigmoid(a_v + b m)``, fitted by maximum likelihood
    (Newton's method on the standardised metric, the step damped as in :func:`fit_logistic`).
    Each view's threshold is ``m*_v = (logit(good_prob) - a_v) / b``: the metric value where a
    render *at that view* is judged good with probability ``good_prob``, so the change of view
    moves the threshold instead of reading as a failure.

    Parameters
    ----------
    x : numpy.ndarray
        (n,) the metric at each vote's item (finite).
    y : numpy.ndarray
        (n,) the votes, 1 good and 0 bad.
    view : numpy.ndarray
        (n,) integer view cell of each vote, 0..V-1.
    good_prob : float, optional
        The P(good) that defines the thresholds, in (0, 1).
    tol : float, optional
        Convergence: the largest Newton step below it.

    Returns
    -------
    dict
        ``a`` (V,) intercepts, ``b`` the shared slope, ``value`` (V,) thresholds (NaN for a
        view whose votes are all one outcome, where its intercept is not finite, or when the
        slope is undefined), ``reason`` ('' or why the fit is undefined).
    """
    x = np.asarray(x, np.float64)
    y = np.asarray(y, np.float64)
    view = np.asarray(view, np.int64)
    V = int(view.max()) + 1 if len(view) else 0
    nan = np.full(V, np.nan)
    if len(x) == 0 or x.min() == x.max():
        return {"a": nan, "b": math.nan, "value": nan, "reason": "constant metric or no votes"}
    mu, sd = float(x.mean()), float(x.std())
    z = (x - mu) / sd
    n1 = np.bincount(view, weights=y, minlength=V)
    n = np.bincount(view, minlength=V).astype(np.float64)
    mixed = (n1 > 0) & (n1 < n)  # views with both outcomes have a finite intercept
    keep = mixed[view]
    if not keep.any():
        return {"a": nan, "b": math.nan, "value": nan, "reason": "no view has both outcomes"}
    zk, yk, vk = z[keep], y[keep], view[keep]
    theta = np.zeros(V + 1)  # intercepts, then the slope
    for _ in range(MAX_ITER):
        p = 1.0 / (1.0 + np.exp(-(theta[vk] + theta[V] * zk)))
        r, w = yk - p, p * (1.0 - p)
        g = np.r_[np.bincount(vk, weights=r, minlength=V), (r * zk).sum()]
        H = np.zeros((V + 1, V + 1))
        H[np.arange(V), np.arange(V)] = np.bincount(vk, weights=w, minlength=V)
        hz = np.bincount(vk, weights=w * zk, minlength=V)
        H[:V, V] = H[V, :V] = hz
        H[V, V] = (w * zk * zk).sum()
        out_idx = np.flatnonzero(~mixed)
        H[out_idx, out_idx] = 1.0  # views left out: their intercepts stay 0 (reported NaN)
        step = np.linalg.solve(H, g)
        size = np.abs(step).max()
        step *= min(1.0, 5.0 / max(size, 1e-300))
        theta += step
        if size < tol:
            break
    b = theta[V] / sd
    a = theta[:V] - theta[V] * mu / sd
    a[~mixed] = np.nan
    reason = "" if b != 0 else "zero slope"
    value = logistic_threshold(a, np.full(V, b), good_prob)
    return {"a": a, "b": float(b), "value": value, "reason": reason}
