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

__all__ = ["fit_logistic", "logistic_threshold", "clip_to_range", "vote_threshold", "view_thresholds", "pav",
           "monotone_view_thresholds", "MAX_ITER"]

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


def clip_to_range(value: float, lo: float, hi: float) -> tuple[float, str]:
    """A fitted threshold clipped to the range ``[lo, hi]`` of the rated metric values.

    A crossing outside the values people rated is an extrapolation of the logistic (with a
    slope near 0 it can lie far outside what the metric can take, e.g. a negative entropy):
    every rated value is then on one side of it, and the edge of the range classifies the rated
    items the same way.

    >>> clip_to_range(-0.77, 0.12, 3.4)
    (0.12, 'the fitted crossing (-0.77) lies below the rated values [0.12, 3.4]: clipped to 0.12')
    >>> clip_to_range(1.5, 0.12, 3.4)
    (1.5, '')
    >>> clip_to_range(-math.inf, 0.12, 3.4)[0]
    0.12

    Parameters
    ----------
    value : float
        The fitted threshold (NaN: undefined, returned as is; +-inf, the limit of a fit whose
        votes are all one outcome, becomes the edge).
    lo, hi : float
        The smallest and largest rated metric value.

    Returns
    -------
    tuple
        ``(value, note)``: the clipped value and why it was clipped (``''`` when it was not).
    """
    if math.isnan(value) or lo <= value <= hi:
        return value, ""
    side, edge = ("below", lo) if value < lo else ("above", hi)
    return edge, (f"the fitted crossing ({value:.4g}) lies {side} the rated values [{lo:.4g}, {hi:.4g}]: "
                  f"clipped to {edge:.4g}")


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
    from analysis.stats.bootstrap import interval_around, too_few_raters

    rater, track = np.asarray(rater, np.int64), np.asarray(track, np.int64)
    a, b = fit_logistic(x, y)
    raw = float(logistic_threshold(a, b, good_prob)[0])
    lo, hi = (float(np.min(x)), float(np.max(x))) if len(x) else (math.nan, math.nan)
    value, clipped = clip_to_range(raw, lo, hi)
    R, T = int(rater.max()) + 1 if len(rater) else 0, int(track.max()) + 1 if len(track) else 0
    out = {"value": value, "ci_lo": math.nan, "ci_hi": math.nan, "a": float(a[0]), "b": float(b[0]),
           "n_votes": len(x), "n_raters": R, "n_tracks": T, "reason": ""}
    if not math.isfinite(value):
        out["reason"] = "logistic fit undefined (one vote value only, or a constant metric)"
        return out
    notes = [clipped] if clipped else []
    if n_boot > 0 and too_few_raters(R):
        notes.append(too_few_raters(R))
    elif n_boot > 0 and T < 2:
        notes.append(f"no interval from {T} track: a bootstrap over tracks needs at least 2")
    elif n_boot > 0:
        rng = np.random.default_rng(seed)
        cr, ct = _counts(R, n_boot, rng), _counts(T, n_boot, rng)
        fits = (fit_logistic(x, y, cr[s][:, rater] * ct[s][:, track], start=(a[0], b[0]))
                for s in _chunks(n_boot, len(x)))
        reps = np.concatenate([logistic_threshold(fa, fb, good_prob) for fa, fb in fits])
        # clipping is monotone: the percentiles of the clipped replicates are the clipped percentiles
        reps = np.where(np.isfinite(reps), np.clip(reps, lo, hi), np.nan)
        out["ci_lo"], out["ci_hi"], why = interval_around(value, reps)
        notes += [why] if why else []
    out["reason"] = "; ".join(notes)
    return out


def _chunks(n_boot: int, n: int, cells: int = 4_000_000):
    """Slices of the replicates, at most ``cells`` replicate-votes each (bounds the memory)."""
    step = max(1, cells // max(1, n))
    return [slice(i, min(n_boot, i + step)) for i in range(0, n_boot, step)]


def _view_fit(z: np.ndarray, y: np.ndarray, view: np.ndarray, V: int, w: np.ndarray, tol: float):
    """Newton's method for ``sigmoid(a_v + b z)``, one fit per weight row (z standardised).

    Parameters
    ----------
    z, y, view : numpy.ndarray
        (n,) the standardised metric, the outcomes and the view codes (0..V-1).
    V : int
        The number of views.
    w : numpy.ndarray
        (B, n) non-negative weights.
    tol : float
        Convergence: the largest Newton step below it.

    Returns
    -------
    tuple
        ``(theta (B, V + 1), good (B, V), n (B, V))``: the intercepts then the slope (0 for a
        view left out), and the weighted good votes and votes per view. A view whose weighted
        votes are all one outcome is left out of the fit (its intercept is infinite).
    """
    onehot = np.eye(V)[view]  # (n, V)
    n_v, good_v = w @ onehot, (w * y) @ onehot
    mixed = (good_v > 0) & (good_v < n_v)  # (B, V): views with both outcomes
    we = w * mixed[:, view]
    B = w.shape[0]
    theta = np.zeros((B, V + 1))
    eye = np.broadcast_to(np.eye(V + 1), (B, V + 1, V + 1))
    for _ in range(MAX_ITER):
        p = 1.0 / (1.0 + np.exp(-(theta[:, view] + theta[:, V:] * z)))
        r, v = we * (y - p), we * p * (1.0 - p)
        g = np.concatenate([r @ onehot, (r * z).sum(axis=1, keepdims=True)], axis=1)
        H = np.zeros((B, V + 1, V + 1))
        H[:, np.arange(V), np.arange(V)] = np.where(mixed, v @ onehot, 1.0)  # a view left out: 1
        H[:, :V, V] = H[:, V, :V] = (v * z) @ onehot
        H[:, V, V] = (v * z * z).sum(axis=1)
        ok = np.abs(np.linalg.det(H)) > 1e-300
        step = np.zeros_like(theta)
        step[ok] = np.linalg.solve(np.where(ok[:, None, None], H, eye)[ok], g[ok][..., None])[..., 0]
        size = np.abs(step).max(axis=1, keepdims=True)
        step *= np.minimum(1.0, 5.0 / np.maximum(size, 1e-300))  # damped: no overshoot under separation
        theta += step
        if size.max() < tol:
            break
    return theta, good_v, n_v


def view_thresholds(x, y, view, *, good_prob: float = 0.5, w=None, tol: float = 1e-10) -> dict:
    """Per-view thresholds from one logistic with an intercept per view cell and a shared slope.

    The model is ``P(good | m, view v) = sigmoid(a_v + b m)``, fitted by maximum likelihood
    (Newton's method on the standardised metric, the step damped as in :func:`fit_logistic`).
    Each view's threshold is ``m*_v = (logit(good_prob) - a_v) / b``: the metric value where a
    render *at that view* is judged good with probability ``good_prob``, so the change of view
    moves the threshold instead of reading as a failure.

    A view whose votes are all one outcome has an infinite intercept (the likelihood grows
    without bound along it): its threshold is the limit, ``-inf`` (every vote good, a positive
    slope) or ``+inf`` (every vote bad), which the caller clips to the rated values
    (:func:`clip_to_range`). The other views' fit is unchanged by it (its votes carry no
    information on the slope).

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
    w : numpy.ndarray, optional
        (B, n) non-negative weights, one fit per row (a bootstrap replicate's counts);
        default one row of ones.
    tol : float, optional
        Convergence: the largest Newton step below it.

    Returns
    -------
    dict
        ``a`` (B, V) intercepts (+-inf for a view of one outcome, NaN for a view without
        votes), ``b`` (B,) the shared slope, ``value`` (B, V) thresholds (+-inf for a view of one
        outcome, NaN without votes or when the slope is undefined), ``n`` (B, V) the (weighted)
        votes per view, ``reason`` ('' or why the fit is undefined). Without ``w``, B = 1 and
        each array loses that axis (``b`` a float).
    """
    x = np.asarray(x, np.float64)
    y = np.asarray(y, np.float64)
    view = np.asarray(view, np.int64)
    single = w is None
    w = np.ones((1, len(x))) if single else np.asarray(w, np.float64)
    V = int(view.max()) + 1 if len(view) else 0
    B = w.shape[0]
    if len(x) == 0 or x.min() == x.max():
        nan = np.full((B, V), np.nan)
        out = {"a": nan, "b": np.full(B, np.nan), "value": nan, "n": w @ np.eye(V)[view] if V else nan,
               "reason": "constant metric or no votes"}
        return _squeeze(out) if single else out
    mu, sd = float(x.mean()), float(x.std())
    theta, good, n = _view_fit((x - mu) / sd, y, view, V, w, tol)
    mixed = (good > 0) & (good < n)
    defined = mixed.any(axis=1)
    b = np.where(defined, theta[:, V] / sd, np.nan)
    a = theta[:, :V] - theta[:, V:] * mu / sd
    a = np.where(mixed, a, np.where(n == 0, np.nan, np.where(good > 0, np.inf, -np.inf)))
    with np.errstate(invalid="ignore", divide="ignore"):
        value = (math.log(good_prob / (1.0 - good_prob)) - a) / b[:, None]
    value = np.where(np.isnan(a) | ~np.isfinite(b)[:, None] | (b[:, None] == 0), np.nan, value)
    reason = "" if defined.all() else "no view has both outcomes"
    if single and defined[0] and b[0] == 0:
        reason = "zero slope"
    out = {"a": a, "b": b, "value": value, "n": n, "reason": reason}
    return _squeeze(out) if single else out


def _squeeze(out: dict) -> dict:
    return {"a": out["a"][0], "b": float(out["b"][0]), "value": out["value"][0], "n": out["n"][0],
            "reason": out["reason"]}


def pav(y: np.ndarray, w: np.ndarray) -> np.ndarray:
    """The weighted least-squares non-decreasing fit of ``y`` (pool adjacent violators).

    >>> pav(np.array([0.0, 1, 0, 1]), np.ones(4)).tolist()
    [0.0, 0.5, 0.5, 1.0]

    Parameters
    ----------
    y : numpy.ndarray
        (n,) values in the order of their predictor.
    w : numpy.ndarray
        (n,) positive weights.

    Returns
    -------
    numpy.ndarray
        (n,) the fitted values, non-decreasing.
    """
    means, weights, sizes = [], [], []
    for v, wv in zip(np.asarray(y, np.float64), np.asarray(w, np.float64), strict=True):
        m, s, k = v, wv, 1
        while means and means[-1] > m:  # pool with the block before while it violates the order
            pm, ps, pk = means.pop(), weights.pop(), sizes.pop()
            m, s, k = (pm * ps + m * s) / (ps + s), ps + s, pk + k
        means.append(m)
        weights.append(s)
        sizes.append(k)
    return np.repeat(means, sizes)


def _monotone_crossing(x: np.ndarray, y: np.ndarray, w: np.ndarray, good_prob: float) -> float:
    """The threshold of one view: where the non-decreasing fit of ``y`` on ``x`` reaches ``good_prob``.

    ``-inf`` when the fit is at or above it at the lowest ``x``, ``+inf`` when it stays below it,
    else the midpoint between the last value below and the first at or above; NaN without votes.
    """
    keep = w > 0
    if not keep.any():
        return math.nan
    ux, inv = np.unique(x[keep], return_inverse=True)  # ties pooled: one point per value
    sw = np.bincount(inv, weights=w[keep])
    f = pav(np.bincount(inv, weights=w[keep] * y[keep]) / sw, sw)
    up = f >= good_prob
    if up[0]:
        return -math.inf
    if not up[-1]:
        return math.inf
    k = int(np.argmax(up))
    return 0.5 * (ux[k - 1] + ux[k])


def monotone_view_thresholds(x, y, view, *, good_prob: float = 0.5, increasing: bool = True,
                             w=None) -> dict:
    """Per-view thresholds from a monotone fit of P(good | metric) inside each view cell.

    In each view the votes are fitted by isotonic regression on the metric (:func:`pav`; a
    non-decreasing fit where higher is better, non-increasing where lower is better), and the
    view's threshold is where the fit reaches ``good_prob``: the midpoint between the last
    rated value below it and the first at or above it. A view where the fit is at or above
    ``good_prob`` at every rated value gets the limit ``-inf`` (``+inf`` where lower is
    better): every object there is good; one where it stays below gets the other limit. The
    caller clips them to the rated values (:func:`clip_to_range`).

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
    increasing : bool, optional
        Higher is better (True) or lower is better (False).
    w : numpy.ndarray, optional
        (B, n) non-negative weights, one fit per row; default one row of ones.

    Returns
    -------
    dict
        ``value`` (B, V) thresholds (NaN for a view without votes) and ``n`` (B, V) the
        (weighted) votes per view; without ``w`` each loses its first axis.
    """
    x = np.asarray(x, np.float64)
    y = np.asarray(y, np.float64)
    view = np.asarray(view, np.int64)
    single = w is None
    w = np.ones((1, len(x))) if single else np.asarray(w, np.float64)
    V = int(view.max()) + 1 if len(view) else 0
    sign = 1.0 if increasing else -1.0
    value = np.full((w.shape[0], V), np.nan)
    n = np.zeros((w.shape[0], V))
    for v in range(V):
        on = view == v
        xs, ys = sign * x[on], y[on]
        for b in range(w.shape[0]):
            value[b, v] = sign * _monotone_crossing(xs, ys, w[b, on], good_prob)
            n[b, v] = w[b, on].sum()
    return {"value": value[0], "n": n[0]} if single else {"value": value, "n": n}
