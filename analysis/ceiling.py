"""The noise ceiling: how well could any metric agree with these votes?

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

from analysis import stats

__all__ = ["split_half", "spearman_brown", "noise_ceiling", "vote_matrix"]


def spearman_brown(r):
    """Reliability of the full panel from the half-panel correlation ``r``: ``2r / (1 + r)``."""
    r = np.asarray(r, dtype=np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):
        return 2 * r / (1 + r)


def vote_matrix(test_votes: pd.DataFrame) -> np.ndarray:
    """(items, raters) float 0/1 test votes, NaN where a rater did not rate an item; items and
    raters in sorted id order, so the random halves do not depend on the ratings' row order."""
    i, _ = pd.factorize(test_votes["item_id"], sort=True)
    r, raters = pd.factorize(test_votes["rater_id"], sort=True)
    m = np.full((i.max() + 1 if len(i) else 0, len(raters)), np.nan)
    m[i, r] = test_votes["vote"].to_numpy(np.float64)
    return m


def split_half(mat: np.ndarray, half: np.ndarray) -> dict:
    """Pearson and Spearman correlation over items of the two halves' GVF (``half``: (R,)
    bool, True = first half); items without a vote in both halves are left out."""
    has = np.isfinite(mat)
    v = np.where(has, mat, 0.0)
    na, nb = has[:, half].sum(1), has[:, ~half].sum(1)
    ok = (na > 0) & (nb > 0)
    ga = v[ok][:, half].sum(1) / na[ok]
    gb = v[ok][:, ~half].sum(1) / nb[ok]
    p, _ = stats.pearson(ga, gb)
    s, _ = stats.pearson(stats.rank_within(ga), stats.rank_within(gb))
    return {"pearson": p, "spearman": s, "n": int(ok.sum())}


def _reliability(mat, halves):
    rs = np.array([[d["pearson"], d["spearman"]] for d in (split_half(mat, h) for h in halves)])
    return np.nanmean(spearman_brown(rs), axis=0) if np.isfinite(rs).any() else np.full(2, np.nan)


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
    raters or three items make it undefined)."""
    n_items, n_r = mat.shape
    nan = float("nan")
    out = dict.fromkeys(("reliability", "reliability_ci_lo", "reliability_ci_hi",
                         "plcc_ceiling", "srcc_ceiling", "srcc_reliability"), nan)
    if n_r < 2 or n_items < stats.N_MIN:
        return {**out, "reason": "needs >= 2 raters and >= 3 items"}
    rng = np.random.default_rng(seed)
    halves = _halves(n_r, n_splits, rng)
    rel_p, rel_s = _reliability(mat, halves)
    boot = [_reliability(mat[rng.integers(0, n_items, n_items)], halves)[0]
            for _ in range(n_boot)]
    lo, hi = (np.nanpercentile(boot, [2.5, 97.5]) if np.isfinite(boot).any() else (nan, nan))
    out.update(reliability=float(rel_p), reliability_ci_lo=float(lo), reliability_ci_hi=float(hi),
               srcc_reliability=float(rel_s),
               plcc_ceiling=float(np.sqrt(np.clip(rel_p, 0, 1))),
               srcc_ceiling=float(np.sqrt(np.clip(rel_s, 0, 1))))
    why = None if np.isfinite(rel_p) else "split halves have no defined correlation"
    return {**out, "reason": why}
