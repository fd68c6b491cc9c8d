"""JOD scaling of pairwise comparisons: Thurstone Case V by maximum likelihood.

Layer: analysis (pairwise study statistics).

A pairwise study gives, per pair of conditions (methods), how often each was preferred. The
Thurstone Case V observer prefers condition ``i`` to ``j`` with probability

    P(i > j) = Phi((q_i - q_j) / SIGMA_JOD),   SIGMA_JOD = 1 / Phi^-1(0.75) = 1.4826,

so a difference of 1 on the scale ``q`` is one JOD (just-objectionable difference): 75% of
observers prefer the better condition. This is the scale of pwcmp (Perez-Ortiz and
Mantiuk, "A practical guide and software for analysing pairwise comparison experiments",
2017); this module is an independent implementation of the same model.

- :func:`jod_ml`: the plain maximum-likelihood scale (binomial likelihood of the counts),
  by Newton's method on the concave log-likelihood; finite only when the comparison graph
  is strongly connected (every condition won and lost something, directly or through
  others).
- :func:`jod_scale`: the scale with pwcmp's prior for unanimous pairs, finite for any
  connected design. For each compared (ordered) pair ``r`` the prior takes the binomial
  likelihood of its counts with a unanimous answer softened by one vote (``n:0`` becomes
  ``n-1:1``), normalises it over the current distances of all compared pairs, and averages
  these normalised curves over ``r``; the posterior multiplies each pair's likelihood by
  this prior at its distance. Disconnected groups of conditions are joined by a single
  tie between their best conditions (pwcmp does the same), with a warning in the table.
  Fitted with L-BFGS and the analytic gradient, many count matrices at once. The prior is
  computed in log space (its normalised curves underflow at large counts); its log is
  bounded while the log-likelihood grows with the votes, so the scale converges to the
  maximum-likelihood one (within 1e-9 JOD from 3,000 votes on the tests' matrices).
- :func:`jod_bootstrap` and :func:`jod_table`: 95% percentile intervals over raters
  (resampled with replacement) and, per method in order of its scale value, the share of
  replicates in which it is above the next method (``p_better_than_next``) and the share
  of observers the model predicts to prefer it (``p_prefer_next``).

Counts ``D[i, j]`` are the (possibly fractional: a "can't tell" adds 0.5 to both cells)
wins of ``i`` over ``j``, as :func:`analysis.stats.bradley_terry.win_matrix` builds them. The scale
returned by the fitters has ``q[0] = 0`` (pwcmp's reference condition); the table reports
it centred (mean 0 over the methods with votes).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy import optimize
from scipy.special import gammaln, log_ndtr

from annotate.sampling import SIGMA_JOD

__all__ = ["SIGMA_JOD", "JOD_COLUMNS", "MAX_JOD_BOOT", "jod_ml", "jod_map", "jod_scale", "jod_bootstrap", "jod_table",
           "jod_views"]

#: Columns of jod.csv (docs/FORMATS.md §11).
JOD_COLUMNS = ["axis", "offset", "method", "n_votes", "jod", "jod_ci_lo", "jod_ci_hi", "next_method",
               "p_better_than_next", "p_prefer_next", "reason"]


def _lam(z: np.ndarray) -> np.ndarray:
    """phi(z) / Phi(z), stable for very negative z."""
    return np.exp(-0.5 * z * z - 0.5 * np.log(2 * np.pi) - log_ndtr(z))


def _logsumexp(x: np.ndarray, axis: int) -> np.ndarray:
    """log(sum(exp(x))) along ``axis``, kept; -inf where every entry is -inf."""
    top = x.max(axis=axis, keepdims=True)
    top = np.where(np.isfinite(top), top, 0.0)
    with np.errstate(divide="ignore"):
        return np.log(np.exp(x - top).sum(axis=axis, keepdims=True)) + top


def _check(d: np.ndarray) -> np.ndarray:
    d = np.asarray(d, dtype=np.float64)
    if d.ndim < 2 or d.shape[-1] != d.shape[-2] or (d < 0).any() or not np.isfinite(d).all():
        raise ValueError("count matrices must be (..., M, M), finite and >= 0")
    return d


def jod_ml(d: np.ndarray, *, tol: float = 1e-12, max_iter: int = 100) -> np.ndarray:
    """Maximum-likelihood Thurstone Case V scale (JOD) of one count matrix, without a prior.

    Maximises ``sum_ij D[i, j] log Phi((q_i - q_j) / SIGMA_JOD)`` over ``q`` with ``q[0] = 0``
    by Newton's method (the log-likelihood is concave) with step halving.

    Parameters
    ----------
    d : (M, M) float64
        ``d[i, j]``: wins of condition i over condition j (a tie: 0.5 to both cells).
    tol : float, optional
        Stop when the largest gradient component is below this.
    max_iter : int, optional
        Newton iterations at most.

    Returns
    -------
    (M,) float64
        Scale in JOD, ``q[0] = 0``.

    Raises
    ------
    ValueError
        The graph of wins is not strongly connected (no finite maximum).
    """
    from analysis.stats.bradley_terry import strongly_connected

    d = _check(d)
    m = d.shape[0]
    if not strongly_connected(d):
        raise ValueError("no finite maximum-likelihood scale: the comparison graph is not strongly "
                         "connected (a condition won or lost every comparison)")
    q = np.zeros(m)

    def loglik(q):
        return float((d * log_ndtr((q[:, None] - q[None, :]) / SIGMA_JOD)).sum())

    cur = loglik(q)
    for _ in range(max_iter):
        z = (q[:, None] - q[None, :]) / SIGMA_JOD
        lam = _lam(z)
        g = ((d * lam).sum(1) - (d * lam).sum(0)) / SIGMA_JOD
        c = d * lam * (z + lam)
        w = c + c.T
        h = (w - np.diag(w.sum(1))) / SIGMA_JOD ** 2
        if np.abs(g[1:]).max() < tol:
            break
        step = np.zeros(m)
        step[1:] = np.linalg.solve(h[1:, 1:], -g[1:])
        t = 1.0
        while t > 1e-10:
            new = loglik(q + t * step)
            if new >= cur - 1e-12:
                break
            t *= 0.5
        q, cur = q + t * step, new
    return q


def jod_map(d: np.ndarray, *, prior_sd: float = 2.5, tol: float = 1e-10, max_iter: int = 100) -> np.ndarray:
    """Maximum a posteriori Thurstone Case V scale with a Gaussian prior, many matrices at once.

    Maximises ``sum_ij D[i, j] log Phi((q_i - q_j) / SIGMA_JOD) - sum_i q_i**2 / (2 prior_sd**2)``
    (concave, so finite for any design) by Newton's method with step halving, per matrix.
    A weakly informative alternative to pwcmp's prior for sparse designs (every pair
    compared once or twice, mostly unanimous), where that prior leaves distances nearly free.

    Parameters
    ----------
    d : (M, M) or (B, M, M) float64
        Wins of condition i over j (a tie: 0.5 to both cells).
    prior_sd : float, optional
        Prior standard deviation of each condition's scale value, in JOD.
    tol : float, optional
        Convergence: every matrix's largest gradient component below this.
    max_iter : int, optional
        The most Newton steps, shared by all ``B`` matrices.

    Returns
    -------
    (M,) or (B, M) float64
        Scale in JOD (its mean is near 0: the prior centres it).
    """
    d = _check(d)
    one = d.ndim == 2
    dd = d[None] if one else d.reshape(-1, *d.shape[-2:])
    b, m, _ = dd.shape
    q = np.zeros((b, m))
    eye = np.eye(m)

    def post(q):
        z = (q[:, :, None] - q[:, None, :]) / SIGMA_JOD
        return (dd * log_ndtr(z)).sum((1, 2)) - (q * q).sum(1) / (2 * prior_sd ** 2)

    cur = post(q)
    for _ in range(max_iter):
        z = (q[:, :, None] - q[:, None, :]) / SIGMA_JOD
        lam = dd * _lam(z)
        g = (lam.sum(2) - lam.sum(1)) / SIGMA_JOD - q / prior_sd ** 2
        if np.abs(g).max() < tol:
            break
        c = lam * (z + _lam(z))
        w = c + np.swapaxes(c, 1, 2)
        h = (w - w.sum(2)[:, :, None] * eye) / SIGMA_JOD ** 2 - eye / prior_sd ** 2
        step = np.linalg.solve(h, -g[:, :, None])[:, :, 0]
        t = np.ones(b)
        for _ in range(40):
            new = post(q + t[:, None] * step)
            bad = new < cur - 1e-12
            if not bad.any():
                break
            t = np.where(bad, t / 2, t)
        q, cur = q + t[:, None] * step, new
    return q[0] if one else q.reshape(*d.shape[:-2], m)


def _link_components(d: np.ndarray) -> tuple[np.ndarray, bool]:
    """``d`` with one tie (0.5 each way) between the best conditions (largest share of wins)
    of its disconnected groups, and whether it had to add any."""
    m = d.shape[0]
    seen = (d + d.T) > 0
    group = -np.ones(m, dtype=int)
    for s in range(m):
        if group[s] >= 0:
            continue
        stack, group[s] = [s], s
        while stack:
            i = stack.pop()
            for j in np.flatnonzero(seen[i] & (group < 0)):
                group[j] = s
                stack.append(j)
    voted = seen.any(1)
    roots = [g for g in np.unique(group[voted])]
    if len(roots) < 2:
        return d, False
    share = d.sum(1) / np.maximum((d + d.T).sum(1), 1e-300)
    best = [np.flatnonzero(group == g)[np.argmax(share[group == g])] for g in roots]
    d = d.copy()
    for a in range(len(best)):
        for b in range(a + 1, len(best)):
            d[best[a], best[b]] += 0.5
            d[best[b], best[a]] += 0.5
    return d, True


class _Posterior:
    """Negative log-posterior of pwcmp's model (likelihood x prior) for B count matrices."""

    def __init__(self, d: np.ndarray):
        b, m, _ = d.shape
        self.m = m
        ii, jj = np.nonzero(~np.eye(m, dtype=bool))
        self.ii, self.jj = ii, jj
        self.incidence = np.zeros((len(ii), m))                 # d dist_e / d q
        self.incidence[np.arange(len(ii)), ii] = 1.0
        self.incidence[np.arange(len(ii)), jj] = -1.0
        k = d[:, ii, jj]                       # (B, E) wins of i over j
        n = k + d[:, jj, ii]
        self.k, self.n = k, n
        self.mask = n > 0
        lo = np.minimum(k, n - k)
        # the prior's counts: a unanimous answer softened by one vote
        self.kp = np.where(lo > 0, k, np.where(k > 0, k - 1.0, 1.0))
        self.kp = np.where(self.mask, self.kp, 0.0)
        self.cp = gammaln(n + 1) - gammaln(self.kp + 1) - gammaln(n - self.kp + 1)
        self.c = gammaln(n + 1) - gammaln(k + 1) - gammaln(n - k + 1)
        self.rows = np.maximum(self.mask.sum(1), 1)

    def __call__(self, x: np.ndarray) -> tuple[float, np.ndarray]:
        b, m = self.k.shape[0], self.m
        q = np.concatenate([np.zeros((b, 1)), x.reshape(b, m - 1)], axis=1)
        dist = (q[:, self.ii] - q[:, self.jj]) / SIGMA_JOD          # (B, E)
        lp, lm = log_ndtr(dist), log_ndtr(-dist)
        like = np.where(self.mask, self.c + self.k * lp + (self.n - self.k) * lm, 0.0)
        dlike = np.where(self.mask, self.k * _lam(dist) - (self.n - self.k) * _lam(-dist), 0.0)
        # prior rows r (B, R=E, 1) evaluated at every distance e (B, 1, E), all in log space: at
        # large counts a row's likelihood is sharply peaked and its values underflow far from it
        mr = (self.cp[:, :, None] + self.kp[:, :, None] * lp[:, None, :]
              + (self.n - self.kp)[:, :, None] * lm[:, None, :])
        both = self.mask[:, :, None] & self.mask[:, None, :]
        mr = np.where(both, mr, -np.inf)
        norm = _logsumexp(mr, axis=2)
        la = np.where(both, mr - np.where(np.isfinite(norm), norm, 0.0), -np.inf)   # (B, R, E) row-normalised
        lpi = _logsumexp(la, axis=1)[:, 0] - np.log(self.rows)[:, None]   # (B, E) log prior
        logpi = np.where(self.mask, lpi, 0.0)
        a = np.exp(la)
        # resp[r, e] = a[r, e] / (rows pi[e]): row r's share of the prior at e (sums to 1 over r)
        resp = np.where(both, np.exp(la - np.where(self.mask, lpi, 0.0)[:, None, :]), 0.0)
        resp = resp / self.rows[:, None, None]
        g = (self.kp[:, :, None] * _lam(dist)[:, None, :]
             - (self.n - self.kp)[:, :, None] * _lam(-dist)[:, None, :])   # (B, R, E) d/d(dist)
        g = np.where(both, g, 0.0)
        dprior = (g * (resp - a * resp.sum(2, keepdims=True))).sum(1)
        f = -(like.sum() + logpi.sum())
        gd = -(dlike + dprior) / SIGMA_JOD                         # (B, E) d f / d q_i - q_j
        return float(f), (gd @ self.incidence)[:, 1:].ravel()


def jod_scale(d: np.ndarray, *, prior: bool = True) -> np.ndarray:
    """JOD scale of one or many count matrices (module docstring), ``q[..., 0] = 0``.

    Parameters
    ----------
    d : (M, M) or (B, M, M) float64
        Wins of condition i over j (a tie: 0.5 to both cells).
    prior : bool, optional
        Use pwcmp's prior for unanimous pairs (default). Without it, the plain maximum
        likelihood (:func:`jod_ml`), which needs a strongly connected graph.

    Returns
    -------
    (M,) or (B, M) float64
        Scale in JOD; NaN for a condition without votes.

    Raises
    ------
    ValueError
        Malformed counts; without the prior, a graph that is not strongly connected.
    """
    d = _check(d)
    one = d.ndim == 2
    dd = d[None] if one else d.reshape(-1, *d.shape[-2:])
    m = dd.shape[-1]
    if not prior:
        out = np.stack([jod_ml(x) for x in dd])
    else:
        dd = np.stack([_link_components(x)[0] for x in dd])
        post = _Posterior(dd)
        res = optimize.minimize(post, np.zeros(dd.shape[0] * (m - 1)), jac=True, method="L-BFGS-B",
                                options={"maxiter": 2000, "gtol": 1e-9, "ftol": 1e-15})
        out = np.concatenate([np.zeros((dd.shape[0], 1)), res.x.reshape(-1, m - 1)], axis=1)
    voted = (dd + np.swapaxes(dd, -1, -2)).sum(-1) > 0
    out = np.where(voted, out, np.nan)
    return out[0] if one else out.reshape(*d.shape[:-2], m)


def jod_bootstrap(per_rater: np.ndarray, *, n_boot: int, seed: int = 0) -> np.ndarray:
    """Bootstrap replicates of the JOD scale, resampling raters with replacement.

    Parameters
    ----------
    per_rater : (R, M, M) float64
        Each rater's count matrix.
    n_boot : int
        Replicates B.
    seed : int, optional
        Seed of the draws.

    Returns
    -------
    (B, M) float64
        Each replicate's scale (with the prior), centred to mean 0 over the methods it has
        votes for (NaN elsewhere).
    """
    return _fit_with_replicates(_check(per_rater), n_boot, seed)[1]


def _fit_with_replicates(per_rater: np.ndarray, n_boot: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """The centred scale of all the votes (M,) and of ``n_boot`` resamples of the raters
    (B, M), in one fit: the estimate is fitted as replicate 0 of the same batch, so the prior
    and the optimiser treat it exactly as the replicates (a replicate that draws every rater
    once equals it)."""
    r = per_rater.shape[0]
    rng = np.random.default_rng(seed)
    counts = np.zeros((n_boot, r))
    np.add.at(counts, (np.repeat(np.arange(n_boot), r), rng.integers(0, r, size=(n_boot, r)).ravel()), 1)
    counts = np.concatenate([np.ones((1, r)), counts])
    reps = jod_scale(np.einsum("br,rij->bij", counts, per_rater))
    reps = reps - np.nanmean(reps, axis=1, keepdims=True)
    return reps[0], reps[1:]


def jod_table(per_rater: np.ndarray, methods: list[str], *, n_boot: int = 200, seed: int = 0) -> pd.DataFrame:
    """The JOD scale of one view with bootstrap intervals, best method first.

    Parameters
    ----------
    per_rater : (R, M, M) float64
        Each rater's count matrix (wins of method i over j; a tie 0.5 to both cells).
    methods : list of str
        The M method names.
    n_boot : int, optional
        Bootstrap replicates over raters (0: no intervals). Fewer than
        :data:`analysis.stats.bootstrap.MIN_RATERS` raters give no interval, and an interval that
        would not contain its estimate is left out (:func:`analysis.stats.bootstrap.interval_around`),
        each with the reason.
    seed : int, optional
        Seed of the bootstrap.

    Returns
    -------
    pandas.DataFrame
        Columns ``method, n_votes, jod, jod_ci_lo, jod_ci_hi, next_method,
        p_better_than_next, p_prefer_next, reason`` (the leading ``axis, offset`` of
        :data:`JOD_COLUMNS` are the caller's); ``jod`` centred to mean 0.
    """
    from analysis.stats.bootstrap import interval_around, too_few_raters

    per_rater = _check(per_rater)
    total = per_rater.sum(0)
    linked = _link_components(total)[1]
    few = too_few_raters(len(per_rater)) if n_boot > 0 else None
    if n_boot > 0 and few is None:
        q, reps = _fit_with_replicates(per_rater, n_boot, seed)
    else:
        q, reps = jod_scale(total), None
        q = q - np.nanmean(q) if np.isfinite(q).any() else q
    n = (total + total.T).sum(1)
    order = [i for i in np.argsort(-np.nan_to_num(q, nan=-np.inf), kind="stable")]
    rows = []
    for pos, i in enumerate(order):
        nxt = order[pos + 1] if pos + 1 < len(order) and np.isfinite(q[order[pos + 1]]) else None
        lo = hi = better = np.nan
        reason = []
        if n[i] == 0:
            reason.append("no votes")
        if linked:
            reason.append("comparison graph disconnected: groups joined by a tie between their best methods")
        if reps is not None and np.isfinite(q[i]):
            lo, hi, why = interval_around(q[i], reps[:, i])
            if why:
                reason.append(why)
            ok = np.isfinite(reps[:, i])
            if nxt is not None:
                both = ok & np.isfinite(reps[:, nxt])
                better = float((reps[both, i] > reps[both, nxt]).mean()) if both.any() else np.nan
        elif n[i] > 0:
            reason.append(few or "no bootstrap")
        rows.append({"method": methods[i], "n_votes": float(n[i]), "jod": q[i], "jod_ci_lo": lo,
                     "jod_ci_hi": hi, "next_method": methods[nxt] if nxt is not None else None,
                     "p_better_than_next": better,
                     "p_prefer_next": float(_st_cdf((q[i] - q[nxt]) / SIGMA_JOD)) if nxt is not None else np.nan,
                     "reason": "; ".join(reason) or None})
    return pd.DataFrame(rows, columns=JOD_COLUMNS[2:])


def _st_cdf(z: float) -> float:
    return float(np.exp(log_ndtr(z)))


#: The most bootstrap replicates of the JOD intervals in ``analyze`` (each replicate is a
#: fit with pwcmp's prior; more would dominate the analysis' run time).
MAX_JOD_BOOT = 200


def jod_views(votes: pd.DataFrame, methods: list[str], *, n_boot: int, seed: int = 0) -> pd.DataFrame:
    """jod.csv (:data:`JOD_COLUMNS`): :func:`jod_table` overall (``axis = 'all'``) and per view,
    as :func:`analysis.pairwise.bt_table` splits the votes.

    Parameters
    ----------
    votes : pandas.DataFrame
        Test votes of the raters kept (``rater_id, method_a, method_b, choice`` and the views).
    methods : list of str
        The methods compared.
    n_boot : int
        Bootstrap replicates over raters; at most :data:`MAX_JOD_BOOT` are used (0: none).
    seed : int, optional
        Seed of the bootstrap.

    Returns
    -------
    pandas.DataFrame
        Columns :data:`JOD_COLUMNS`; the cell ``axis = 'all'`` first, then each view's.
    """
    from analysis.common.method_cells import view_cells
    from analysis.stats.bradley_terry import coded_votes

    m = len(methods)
    a, b, s = coded_votes(votes, methods)
    known = (a >= 0) & (b >= 0)
    r = pd.factorize(votes["rater_id"], sort=True)[0]
    n_r = int(r.max()) + 1 if len(r) else 0
    parts = []
    for axis, value, in_view in view_cells(votes):
        sel = in_view & known
        per_rater = np.zeros((n_r, m, m))
        np.add.at(per_rater, (r[sel], a[sel], b[sel]), s[sel])
        np.add.at(per_rater, (r[sel], b[sel], a[sel]), 1.0 - s[sel])
        per_rater = per_rater[per_rater.sum((1, 2)) > 0]
        t = jod_table(per_rater, methods, n_boot=min(n_boot, MAX_JOD_BOOT), seed=seed)
        t.insert(0, "offset", value)
        t.insert(0, "axis", axis)
        parts.append(t)
    return pd.concat(parts, ignore_index=True)[JOD_COLUMNS]
