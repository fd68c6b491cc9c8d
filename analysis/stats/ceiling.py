"""The noise ceiling: how well could any metric agree with these votes?

Layer: analysis (statistics of votes and metrics).

Split-half reliability of the per-item GVF: the raters are split at random into two halves,
each half gives every item its own GVF, and the correlation ``r`` of the two over items
(those with a vote in both halves) is Spearman-Brown corrected to the full panel:
``rel = 2 r / (1 + r)``. The reliability is averaged over every split of the raters into
halves (or ``n_splits`` random ones when there are more); its 95% interval comes from a
bootstrap over items with the same splits. A metric's correlation with a target whose
reliability is ``rel`` cannot exceed ``sqrt(rel)`` (the correlation of the true score with
the observed one), so ``plcc_ceiling = sqrt(rel_pearson)`` and ``srcc_ceiling =
sqrt(rel_spearman)`` (the same on ranks). Identical raters give ceiling 1.

>>> import numpy as np
>>> m = np.array([[1, 1, 1, 1], [1, 1, 0, 0], [0, 0, 0, 0], [1, 0, 1, 0.]])  # (items, raters)
>>> round(split_half(m, np.array([True, True, False, False]))["pearson"], 4)  # 0.3125 / 0.6875
0.4545
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pandas as pd
from scipy import sparse

from analysis.stats import stats
from analysis.stats.bootstrap import weighted_pearson

__all__ = ["split_half", "spearman_brown", "noise_ceiling", "vote_matrix"]


def spearman_brown(r):
    """Reliability of the full panel from the half-panel correlation ``r``: ``2r / (1 + r)``.

    Parameters
    ----------
    r : float or array
        Half-panel correlation.

    Returns
    -------
    float or array
        Shaped as ``r``.
    """
    r = np.asarray(r, dtype=np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):
        return 2 * r / (1 + r)


def vote_matrix(test_votes: pd.DataFrame) -> np.ndarray:
    """(items, raters) float 0/1 test votes, NaN where a rater did not rate an item; items and
    raters in sorted id order, so the random halves do not depend on the ratings' row order.

    Parameters
    ----------
    test_votes : pandas.DataFrame
        One row per test vote (``item_id``, ``rater_id``, ``vote``).

    Returns
    -------
    (I, R) float64
        0/1 votes, NaN where missing.
    """
    i, _ = pd.factorize(test_votes["item_id"], sort=True)
    r, raters = pd.factorize(test_votes["rater_id"], sort=True)
    m = np.full((i.max() + 1 if len(i) else 0, len(raters)), np.nan)
    m[i, r] = test_votes["vote"].to_numpy(np.float64)
    return m


def _half_gvf(mat: np.ndarray, half: np.ndarray):
    """Each half's GVF of every item and whether the item has a vote in both halves:
    ``(ga (I,), gb (I,), ok (I,) bool)``; ``ga, gb`` are meaningless where ``ok`` is False.

    The sums are of 0/1 votes, hence exact whatever the order, so a subset or a resample of
    the items indexes these arrays instead of recomputing them."""
    has = np.isfinite(mat)
    v = np.where(has, mat, 0.0)
    na, nb = has[:, half].sum(1), has[:, ~half].sum(1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return v[:, half].sum(1) / na, v[:, ~half].sum(1) / nb, (na > 0) & (nb > 0)


def split_half(mat: np.ndarray, half: np.ndarray) -> dict:
    """Pearson and Spearman correlation over items of the two halves' GVF (``half``: (R,)
    bool, True = first half); items without a vote in both halves are left out.

    Parameters
    ----------
    mat : (I, R) float64
        :func:`vote_matrix`.
    half : (R,) bool
        True for the raters of the first half.

    Returns
    -------
    dict
        ``pearson``, ``spearman`` and ``n`` (items used).
    """
    return _correlate(*_half_gvf(mat, half))


def _correlate(ga, gb, ok) -> dict:
    ga, gb = ga[ok], gb[ok]
    p, _ = stats.pearson(ga, gb)
    s, _ = stats.pearson(stats.rank_within(ga), stats.rank_within(gb))
    return {"pearson": p, "spearman": s, "n": int(ok.sum())}


def _mean_reliability(rs: np.ndarray) -> np.ndarray:
    """Mean Spearman-Brown reliability over splits of ``rs`` (S, 2) half correlations."""
    return np.nanmean(spearman_brown(rs), axis=0) if np.isfinite(rs).any() else np.full(2, np.nan)


def _boot_reliability(per_split, n_items: int, rng, n_boot: int) -> list[float]:
    """The Pearson reliability of ``n_boot`` resamples of the items (draws
    ``rng.integers(0, I, I)`` per replicate); ``per_split``: :func:`_half_gvf` of each split.

    Columnar: in each split an item is one of a few distinct pairs of half GVFs (fractions
    ``k / n``), so a resample is a count per pair, and its Pearson r the weighted r of the
    pairs (:func:`analysis.stats.bootstrap.weighted_pearson`: the r of the duplicated data, up to
    rounding), for every split at once: no pass over the items per split and replicate."""
    n_splits = len(per_split)
    codes, xs, ys = [], [], []  # per split: (I,) pair index (-1: not in both halves), values
    for ga, gb, ok in per_split:
        a, a_values = pd.factorize(ga[ok])
        b, b_values = pd.factorize(gb[ok])
        pair, pairs = pd.factorize(a.astype(np.int64) * len(b_values) + b)
        c = np.full(n_items, -1, dtype=np.int64)
        c[ok] = pair
        codes.append(c)
        xs.append(np.asarray(a_values, np.float64)[pairs // len(b_values)])
        ys.append(np.asarray(b_values, np.float64)[pairs % len(b_values)])
    width = max(1, max(len(x) for x in xs))
    sizes = np.array([len(x) for x in xs])
    start = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    n_bins = int(sizes.sum())
    flat = np.concatenate([np.where(c >= 0, c + s0, n_bins) for c, s0 in zip(codes, start, strict=True)])
    # (bins, items) 0/1: which pair of each split an item is; counts of a resample = it @ draws
    member = sparse.csr_matrix((np.ones(flat.size), (flat, np.tile(np.arange(n_items), n_splits))),
                               shape=(n_bins + 2, n_items))
    X, Y = np.zeros((n_splits, width)), np.zeros((n_splits, width))
    at = np.full((n_splits, width), n_bins + 1)  # padding: an always-empty bin
    for k in range(n_splits):
        X[k, : sizes[k]], Y[k, : sizes[k]] = xs[k], ys[k]
        at[k, : sizes[k]] = start[k] + np.arange(sizes[k])
    out = []
    for _ in range(n_boot):
        w = np.bincount(rng.integers(0, n_items, n_items), minlength=n_items).astype(np.float64)
        counts = member @ w
        rs = np.zeros((n_splits, 2))  # column 1 (Spearman) is not needed here
        rs[:, 0] = weighted_pearson(X, Y, counts[at])
        out.append(_mean_reliability(rs)[0] if np.isfinite(rs[:, 0]).any() else np.nan)
    return out


def _halves(n_r: int, n_splits: int, rng) -> list[np.ndarray]:
    """Every split of the raters into halves when there are at most ``n_splits`` of them,
    else ``n_splits`` random ones; (R,) bool, True = first half."""
    if math.comb(n_r, n_r // 2) <= n_splits:
        combos = itertools.combinations(range(n_r), n_r // 2)
        return [np.isin(np.arange(n_r), c) for c in combos]
    out = []
    for _ in range(n_splits):
        h = np.zeros(n_r, bool)
        h[rng.permutation(n_r)[: n_r // 2]] = True
        out.append(h)
    return out


def noise_ceiling(mat: np.ndarray, *, n_splits: int = 20, n_boot: int = 200, seed: int = 0) -> dict:
    """Split-half reliability (Spearman-Brown) of GVF over ``mat`` (items, raters), its
    bootstrap 95% interval over items, and the ceilings on |PLCC| and |SRCC|.

    Returns a dict: ``reliability, reliability_ci_lo, reliability_ci_hi, plcc_ceiling,
    srcc_ceiling, srcc_reliability, reason`` (NaN values and a reason when fewer than two
    raters or three items make it undefined).

    Parameters
    ----------
    mat : (I, R) float64
        :func:`vote_matrix`.
    n_splits : int, optional
        Random rater splits averaged.
    n_boot : int, optional
        Bootstrap replicates over items.
    seed : int, optional
        Seed of the splits and the bootstrap.

    Returns
    -------
    dict
    """
    n_items, n_r = mat.shape
    nan = float("nan")
    out = dict.fromkeys(("reliability", "reliability_ci_lo", "reliability_ci_hi",
                         "plcc_ceiling", "srcc_ceiling", "srcc_reliability"), nan)
    if n_r < 2 or n_items < stats.N_MIN:
        return {**out, "reason": "needs >= 2 raters and >= 3 items"}
    rng = np.random.default_rng(seed)
    halves = _halves(n_r, n_splits, rng)
    per_split = [_half_gvf(mat, h) for h in halves]
    rs = np.array([[d["pearson"], d["spearman"]] for d in (_correlate(*g) for g in per_split)])
    rel_p, rel_s = _mean_reliability(rs)
    boot = _boot_reliability(per_split, n_items, rng, n_boot)
    lo, hi = (np.nanpercentile(boot, [2.5, 97.5]) if np.isfinite(boot).any() else (nan, nan))
    out.update(reliability=float(rel_p), reliability_ci_lo=float(lo), reliability_ci_hi=float(hi),
               srcc_reliability=float(rel_s),
               plcc_ceiling=float(np.sqrt(np.clip(rel_p, 0, 1))),
               srcc_ceiling=float(np.sqrt(np.clip(rel_s, 0, 1))))
    why = None if np.isfinite(rel_p) else "split halves have no defined correlation"
    return {**out, "reason": why}
