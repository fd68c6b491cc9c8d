"""Rater screening: per-rater quality numbers, each with a test statistic and a p-value, and
an exclusion rule that acts only on significant evidence.

Consensus. Every rater is compared with the leave-one-out (LOO) consensus of the *other*
raters on the same test items: the others' good fraction ``f``; the consensus label is good
when ``f > 0.5``, bad when ``f < 0.5`` (ties and items nobody else rated are not compared).
Two passes: the second pass builds the consensus only from raters the first pass did not
flag on agreement, so one inverted or random rater cannot drag the consensus for the others.

Per rater (``raters.csv``):

- ``n_compared``, ``agreement`` (raw share equal to the LOO consensus label), ``kappa``
  (Cohen's kappa of vote against that label), ``sensitivity`` (good votes on consensus-good
  items, over ``n_cons_good``), ``specificity`` (bad votes on consensus-bad items, over
  ``n_cons_bad``), ``youden_j = sensitivity + specificity - 1`` (the chance-corrected skill:
  0 for a random or straight-lining rater whatever the base rate, negative when inverted),
  ``j_z`` and ``j_p``: the one-sided test of ``H0: J >= min_j``. ``j_z`` is the z statistic
  (standard error from the binomial variances at the point of the ``H0`` boundary nearest
  the observed rates); ``j_p`` is its normal p-value when the rater has more than
  ``EXACT_J_MAX_N`` compared items, and the exact p-value (:func:`j_exact_p`) at up to
  ``EXACT_J_MAX_N``, where the normal approximation is too optimistic (3 items gave z-test
  p = 0.0093 where the exact p is 0.041);
  ``loo_corr``: Pearson correlation of the vote with ``f`` (P.913's correlation with the mean).
- ``gold_failures``, ``gold_failure_rate`` and ``gold_p`` = P(X >= failures), X ~
  Bin(scored gold, ``max_gold_failure_rate``) (exact one-sided binomial). The expected answer
  is the column ``gold_expected`` (1 good, 0 bad) when present, else the item id prefix
  written by ``annotate``: ``gold-good:...`` good, ``gold-bad:...`` bad; gold rows with
  neither are counted in ``n_gold_unscored``.
- ``repeat_consistency`` over ``n_repeat_pairs`` (``kind == 'repeat'`` rows carry the test
  item's id) and ``repeat_p`` = P(X <= consistent), X ~ Bin(n, ``min_repeat_consistency``).
- ``skill_p``: one-sided Fisher exact test of ``H0``: the votes are independent of the
  consensus labels (no skill); computed when each consensus class has at least
  ``min_class_votes`` items.
- ``median_response_ms``, ``fast_share`` (share of test votes under
  ``min_response_ms``) and ``speed_p`` = P(X >= fast), X ~ Bin(n_test, 0.5): the median is
  significantly below the limit.
- ``modal_share`` (share of test votes equal to the rater's most frequent answer) and
  ``others_modal_share`` (the same for the consensus labels) are kept for reading; a
  straight-lining rater has ``youden_j = 0`` and is caught by the agreement test.
- ``simulated``: id starts with ``sim-``.

The screening rule (``analyze`` applies it by default; ``--no-screen`` keeps flagged
raters): a rater is excluded when any test above is significant at level ``alpha``
(one-sided, per test): agreement (``j_p``), gold (``gold_p``), repeats (``repeat_p``) or
speed (``speed_p``); or no skill shown: ``skill_p >= skill_alpha`` (with at least
``min_class_votes`` items in each consensus class, a rater whose votes cannot be told from a
coin or a single button at that level). Flags name every test that fired. Thresholds and
level are in :class:`ScreenRule`; the false-exclusion rate measured on simulated panels is
in docs/FORMATS.md.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import pandas as pd
from scipy import stats as _st

from data_schema.errors import InputError
from data_schema.raters import SIM_PREFIX
from data_schema.tables import ITEM_KINDS
from data_schema.vocab import ItemKind

__all__ = [
    "ScreenRule",
    "rater_table",
    "screen",
    "gold_expected",
    "consensus_stats",
    "j_test",
    "j_exact_p",
    "EXACT_J_MAX_N",
    "fisher_skill_p",
    "screen_agreement",
    "agreement_tests",
    "SIM_PREFIX",
]

EXACT_J_MAX_N = 40
"""Raters with at most this many compared items get the exact J test (:func:`j_exact_p`)."""

_EXACT_GRID = 801  # points on the H0 boundary where the exact p is maximised


@dataclass(frozen=True)
class ScreenRule:
    """Thresholds and test level of the screening rule (see the module docstring).

    Attributes
    ----------
    alpha : float
        Level of each one-sided test (agreement, gold, repeats, speed).
    min_j : float
        The Youden J the agreement test's ``H0: J >= min_j`` assumes.
    skill_alpha : float
        A rater with Fisher skill p at or above this shows no skill and is flagged.
    min_class_votes : int
        Items needed in each consensus class before the skill test is computed.
    max_gold_failure_rate : float
        Gold failure rate the gold test's binomial ``H0`` assumes.
    min_repeat_consistency : float
        Repeat consistency the repeat test's binomial ``H0`` assumes.
    min_response_ms : float
        Response time (ms) under which a test vote counts as fast.
    """

    alpha: float = 0.01
    min_j: float = 0.35
    skill_alpha: float = 0.05
    min_class_votes: int = 5
    max_gold_failure_rate: float = 0.25
    min_repeat_consistency: float = 0.7
    min_response_ms: float = 300.0


def gold_expected(gold: pd.DataFrame) -> np.ndarray:
    """Expected vote of gold rows: (n,) float 1.0 / 0.0, NaN where unknown.

    Parameters
    ----------
    gold : pandas.DataFrame
        Gold rows with ``item_id`` (``gold-good:``/``gold-bad:`` prefixes) and, optionally,
        ``gold_expected`` (1 good, 0 bad), which takes precedence where finite.

    Returns
    -------
    numpy.ndarray
        (n,) float64: 1.0 good, 0.0 bad, NaN where the expected answer is unknown.
    """
    ids = gold["item_id"].astype(str)
    exp = np.where(
        ids.str.startswith("gold-good:"),
        1.0,
        np.where(ids.str.startswith("gold-bad:"), 0.0, np.nan),
    )
    if "gold_expected" in gold.columns:
        col = pd.to_numeric(gold["gold_expected"], errors="coerce").to_numpy(np.float64)
        exp = np.where(np.isfinite(col), col, exp)
    return exp


def j_test(sens, spec, n_good, n_bad, *, min_j: float):
    """One-sided z-test of ``H0: sens + spec - 1 >= min_j`` (arrays broadcast).

    The standard error is taken at the point of the H0 boundary nearest the observed rates
    (the gap split evenly, clipped into [0, 1]), so a rater with ``sens = 1, spec = 0`` still
    gets a finite, honest z. Returns ``(z, p)``; NaN where a class has no item.

    Parameters
    ----------
    sens : array_like of float
        Sensitivity (share of good votes on consensus-good items).
    spec : array_like of float
        Specificity (share of bad votes on consensus-bad items).
    n_good : array_like of int
        Number of consensus-good items.
    n_bad : array_like of int
        Number of consensus-bad items.
    min_j : float
        The J of the null hypothesis boundary.

    Returns
    -------
    z : numpy.ndarray
        The z statistic (broadcast shape), NaN where a class has no item.
    p : numpy.ndarray
        Its one-sided normal p-value ``Phi(z)``.

    >>> z, p = j_test(1.0, 0.0, 48, 12, min_j=0.4)  # straight-lining "good"
    >>> round(float(z), 3), round(float(p), 4)
    (-2.828, 0.0023)
    """
    s, q = np.asarray(sens, float), np.asarray(spec, float)
    n1, n0 = np.asarray(n_good, float), np.asarray(n_bad, float)
    gap = (1.0 + min_j) - (s + q)
    s0, q0 = s + gap / 2, q + gap / 2
    for _ in range(2):  # move what falls outside [0, 1] onto the other rate
        over = np.clip(s0 - 1, 0, None) - np.clip(-s0, 0, None)
        s0, q0 = s0 - over, q0 + over
        over = np.clip(q0 - 1, 0, None) - np.clip(-q0, 0, None)
        q0, s0 = q0 - over, s0 + over
    s0, q0 = np.clip(s0, 0, 1), np.clip(q0, 0, 1)
    with np.errstate(invalid="ignore", divide="ignore"):
        se = np.sqrt(s0 * (1 - s0) / n1 + q0 * (1 - q0) / n0)
        z = (s + q - 1.0 - min_j) / se
    z = np.where((n1 > 0) & (n0 > 0), z, np.nan)
    return z, _st.norm.cdf(z)


@lru_cache(maxsize=512)
def _exact_table(n1: int, n0: int, min_j: float) -> np.ndarray:
    """(n1 + 1, n0 + 1) exact p of every outcome (a good-on-good, b bad-on-bad votes)."""
    lo, hi = max(0.0, min_j), min(1.0, 1.0 + min_j)
    s = np.linspace(lo, hi, _EXACT_GRID)
    pa = _st.binom.pmf(np.arange(n1 + 1)[None, :], n1, s[:, None])  # (G, n1 + 1)
    pb = _st.binom.pmf(np.arange(n0 + 1)[None, :], n0, (1.0 + min_j - s)[:, None])
    joint = (pa[:, :, None] * pb[:, None, :]).reshape(len(s), -1)  # (G, C)
    stat = (np.arange(n1 + 1)[:, None] / n1 + np.arange(n0 + 1)[None, :] / n0).ravel()
    lower = (stat[None, :] <= stat[:, None] + 1e-12).astype(np.float64)  # (C, C)
    return np.minimum((joint @ lower.T).max(axis=0), 1.0).reshape(n1 + 1, n0 + 1)


def j_exact_p(sens, spec, n_good, n_bad, *, min_j: float):
    """Exact one-sided p of ``H0: sens + spec - 1 >= min_j`` (arrays broadcast).

    The statistic is the observed ``J = a / n_good + b / n_bad - 1`` (``a`` good votes on the
    ``n_good`` consensus-good items, ``b`` bad votes on the ``n_bad`` consensus-bad ones,
    independent binomials). The p-value is the largest ``P(J' <= J)`` over the H0 region;
    the lower tail grows as either rate falls, so the largest is on the boundary
    ``s + q = 1 + min_j``, searched on an 801-point grid. Exact, hence never below the true
    size, unlike the z-test at small n.

    Parameters
    ----------
    sens, spec : array_like
        Observed sensitivity and specificity (shares of ``n_good`` and ``n_bad``).
    n_good, n_bad : array_like of int
        Consensus-good and consensus-bad items compared.
    min_j : float
        The H0 boundary of Youden's J.

    Returns
    -------
    numpy.ndarray
        The broadcast shape, p in [0, 1]; NaN where a consensus class is empty.

    >>> round(float(j_exact_p(0.0, 0.0, 2, 1, min_j=0.35)), 4)  # max (1-s)^2 (s-0.35)
    0.0407
    """
    s, q, n1, n0 = np.broadcast_arrays(*(np.asarray(x, np.float64) for x in
                                         (sens, spec, n_good, n_bad)))
    out = np.full(s.shape, np.nan)
    ok = (n1 > 0) & (n0 > 0) & np.isfinite(s) & np.isfinite(q)
    a, b = np.rint(np.where(ok, s * n1, 0)), np.rint(np.where(ok, q * n0, 0))
    for g, c in {(int(x), int(y)) for x, y in zip(n1[ok], n0[ok], strict=True)}:
        m = ok & (n1 == g) & (n0 == c)
        out[m] = _exact_table(g, c, float(min_j))[a[m].astype(int), b[m].astype(int)]
    return out


def _masked_sum(x, m):
    return np.where(m, x, 0.0).sum(axis=-1)


def consensus_stats(votes: np.ndarray, use: np.ndarray | None = None) -> dict:
    """Per-rater agreement with the LOO consensus of the raters in ``use``.

    votes: (..., R, I) float 0/1 with NaN where a rater did not rate an item (leading axes
    are independent panels: the simulated-panel tests screen all panels at once);
    use: (..., R) bool, the raters whose votes form the consensus (default all).
    Returns a dict of (..., R) arrays: ``n_compared, n_cons_good, n_cons_bad, agreement,
    kappa, sensitivity, specificity, youden_j, loo_corr``.

    Parameters
    ----------
    votes : (..., R, I) float array_like
        0/1 votes, NaN where a rater did not rate an item.
    use : (..., R) bool array_like or None
        The raters whose votes form the consensus; None for all.

    Returns
    -------
    dict of str to numpy.ndarray
        (..., R) arrays; the counts are int64, the rest float64 (NaN where undefined).
    """
    v = np.asarray(votes, dtype=np.float64)
    has = np.isfinite(v)
    v0 = np.where(has, v, 0.0)
    use = np.ones(v.shape[:-1], bool) if use is None else np.asarray(use, bool)
    w = (use[..., None] & has).astype(np.float64)  # (..., R, I) contributes to consensus
    tot_s, tot_c = (v0 * w).sum(axis=-2, keepdims=True), w.sum(axis=-2, keepdims=True)
    oth_s, oth_c = tot_s - v0 * w, tot_c - w
    with np.errstate(invalid="ignore", divide="ignore"):
        f = oth_s / oth_c
    cmp_ = has & (oth_c > 0) & (f != 0.5)
    good, bad = cmp_ & (f > 0.5), cmp_ & (f < 0.5)
    n1, n0 = good.sum(-1).astype(float), bad.sum(-1).astype(float)
    a = _masked_sum(v0, good)
    b = _masked_sum(1.0 - v0, bad)
    n = n1 + n0
    with np.errstate(invalid="ignore", divide="ignore"):
        sens, spec, agree = a / n1, b / n0, (a + b) / n
        p_r = _masked_sum(v0, cmp_) / n  # rater's good rate on compared items
        p_c = n1 / n
        pe = p_r * p_c + (1 - p_r) * (1 - p_c)
        kappa = np.where(pe < 1, (agree - pe) / (1 - pe), np.nan)
        corr = _pearson_masked(v0, np.where(has & (oth_c > 0), f, 0.0), has & (oth_c > 0))
    return {
        "n_compared": n.astype(np.int64),
        "n_cons_good": n1.astype(np.int64),
        "n_cons_bad": n0.astype(np.int64),
        "agreement": agree,
        "kappa": kappa,
        "sensitivity": sens,
        "specificity": spec,
        "youden_j": sens + spec - 1.0,
        "loo_corr": corr,
    }


def _pearson_masked(x, y, m):
    c = m.sum(-1).astype(float)
    with np.errstate(invalid="ignore", divide="ignore"):
        mx, my = _masked_sum(x, m) / c, _masked_sum(y, m) / c
        xc, yc = np.where(m, x - mx[..., None], 0), np.where(m, y - my[..., None], 0)
        sxx, syy = (xc * xc).sum(-1), (yc * yc).sum(-1)
        r = (xc * yc).sum(-1) / np.sqrt(sxx * syy)
    return np.where((sxx > 0) & (syy > 0) & (c >= 3), r, np.nan)


def _j_p(res: dict, rule: ScreenRule):
    """``(z, p)``: the z-test, its p replaced by the exact one at small n."""
    args = (res["sensitivity"], res["specificity"], res["n_cons_good"], res["n_cons_bad"])
    z, p = j_test(*args, min_j=rule.min_j)
    small = np.asarray(res["n_cons_good"] + res["n_cons_bad"]) <= EXACT_J_MAX_N
    if not np.any(small):
        return z, p
    exact = j_exact_p(*(np.where(small, x, 0) for x in args), min_j=rule.min_j)
    return z, np.where(small, exact, p)


def fisher_skill_p(res: dict):
    """One-sided Fisher exact p of "votes and consensus labels are positively associated"
    from :func:`consensus_stats` output: ``P(X >= a)``, X ~ Hypergeom(N compared items,
    n_cons_good, the rater's good votes), ``a`` = good votes on consensus-good items.
    NaN when a consensus class is empty.

    Parameters
    ----------
    res : dict
        :func:`consensus_stats` output (at least ``n_compared``, ``n_cons_good``,
        ``n_cons_bad``, ``sensitivity``, ``specificity``).

    Returns
    -------
    numpy.ndarray
        The p-values, float64 of the broadcast shape of ``res``'s arrays.

    >>> r = {"n_compared": np.array(4), "n_cons_good": np.array(2), "n_cons_bad": np.array(2),
    ...      "sensitivity": np.array(1.0), "specificity": np.array(1.0)}
    >>> float(fisher_skill_p(r))  # perfect on 2 + 2: 1 / C(4, 2)
    0.16666666666666666
    """
    n, n1, n0 = (np.asarray(res[k], np.float64) for k in ("n_compared", "n_cons_good",
                                                           "n_cons_bad"))
    with np.errstate(invalid="ignore"):
        a = np.rint(np.nan_to_num(res["sensitivity"] * n1))
        b = np.rint(np.nan_to_num(res["specificity"] * n0))
        p = _st.hypergeom.sf(a - 1, n, n1, a + (n0 - b))
    return np.where((n1 > 0) & (n0 > 0), p, np.nan)


def agreement_tests(res: dict, rule: ScreenRule):
    """``(j_z, j_p, skill_p, flag)`` of :func:`consensus_stats`-like output under ``rule``:
    the J test (:func:`j_test` against ``rule.min_j``), the Fisher skill test (NaN with fewer
    than ``rule.min_class_votes`` items in a consensus class) and the agreement flag. Also
    serves the pairwise screening (:func:`analysis.pairwise.rater_table`).

    Parameters
    ----------
    res : dict
        :func:`consensus_stats`-like output.
    rule : ScreenRule
        Thresholds and test level.

    Returns
    -------
    j_z : numpy.ndarray
        The J test's z statistic.
    j_p : numpy.ndarray
        The J test's p-value (exact at up to ``EXACT_J_MAX_N`` compared items).
    skill_p : numpy.ndarray
        The Fisher skill p-value, NaN where a consensus class is too small.
    flag : numpy.ndarray
        bool, ``j_p < rule.alpha`` or ``skill_p >= rule.skill_alpha``.
    """
    z, p = _j_p(res, rule)
    skill_p = fisher_skill_p(res)
    enough = np.minimum(res["n_cons_good"], res["n_cons_bad"]) >= rule.min_class_votes
    skill_p = np.where(enough, skill_p, np.nan)
    return z, p, skill_p, (p < rule.alpha) | (skill_p >= rule.skill_alpha)


def screen_agreement(votes: np.ndarray, *, rule: ScreenRule | None = None) -> dict:
    """Agreement screening of ``votes`` (..., R, I) by backward elimination.

    Start with every rater in the consensus; while a rater of the consensus is flagged, drop
    the flagged one with the lowest J from the consensus and recompute (at least two raters
    stay). Returns :func:`consensus_stats` against the final consensus plus ``j_z``, ``j_p``,
    ``skill_p``, ``in_consensus`` and ``flag_agreement`` (..., R).

    Parameters
    ----------
    votes : (..., R, I) float numpy.ndarray
        0/1 votes, NaN where a rater did not rate an item.
    rule : ScreenRule or None
        Thresholds and test level; None for the defaults.

    Returns
    -------
    dict of str to numpy.ndarray
        (..., R) arrays, as described above.
    """
    rule = rule or ScreenRule()
    v = np.asarray(votes, dtype=np.float64)
    use = np.ones(v.shape[:-1], bool)
    for _ in range(max(v.shape[-2] - 2, 0)):
        res = consensus_stats(v, use)
        flag = agreement_tests(res, rule)[3] & use
        j = np.where(flag, np.nan_to_num(res["youden_j"], nan=-2.0), np.inf)
        worst = np.argmin(j, axis=-1)[..., None]
        drop = flag.any(-1) & (use.sum(-1) > 2)
        if not drop.any():
            break
        np.put_along_axis(use, worst, np.take_along_axis(use, worst, -1) & ~drop[..., None], -1)
    out = consensus_stats(v, use)
    z, p, skill_p, flag = agreement_tests(out, rule)
    out.update(j_z=z, j_p=p, skill_p=skill_p, in_consensus=use, flag_agreement=flag)
    return out


def _per_rater(codes, n_r, values, mask=None):
    """(sum, count) of values per rater code, over rows in mask."""
    if mask is not None:
        codes, values = codes[mask], values[mask]
    return (
        np.bincount(codes, weights=values, minlength=n_r),
        np.bincount(codes, minlength=n_r).astype(np.float64),
    )


def _vote_matrix(votes: pd.DataFrame, raters) -> np.ndarray:
    """(R, I) test votes, NaN where missing (a rater's last test vote on an item)."""
    t = votes[votes["kind"] == ItemKind.TEST]
    r = pd.Index(raters).get_indexer(t["rater_id"])
    i, items = pd.factorize(t["item_id"])
    mat = np.full((len(raters), len(items)), np.nan)
    mat[r, i] = t["vote"].to_numpy(np.float64)
    return mat


def _agreement_columns(out, votes, raters, rule):
    res = screen_agreement(_vote_matrix(votes, raters), rule=rule)
    for k in ("n_compared", "n_cons_good", "n_cons_bad", "agreement", "kappa", "sensitivity",
              "specificity", "youden_j", "j_z", "j_p", "skill_p", "loo_corr"):
        out[k] = res[k]
    out["flag_agreement"] = res["flag_agreement"]


def _gold_columns(out, votes, r_codes, n_r, rule):
    kind, vote = votes["kind"].to_numpy(), votes["vote"].to_numpy(np.float64)
    g = kind == ItemKind.GOLD
    exp = gold_expected(votes[g])
    scored = np.isfinite(exp)
    fails = np.bincount(r_codes[g], weights=(vote[g] != exp) & scored, minlength=n_r)
    n_scored = np.bincount(r_codes[g], weights=scored, minlength=n_r)
    out["gold_failures"] = fails.astype(np.int64)
    out["n_gold_unscored"] = out["n_gold"] - n_scored.astype(np.int64)
    with np.errstate(invalid="ignore", divide="ignore"):
        out["gold_failure_rate"] = fails / n_scored
    p = _st.binom.sf(fails - 1, n_scored, rule.max_gold_failure_rate)
    out["gold_p"] = np.where(n_scored > 0, p, np.nan)


def _repeat_columns(out, votes, raters, rule):
    kind = votes["kind"].to_numpy()
    rep = votes[kind == ItemKind.REPEAT][["rater_id", "item_id", "vote"]]
    tst = votes[kind == ItemKind.TEST][["rater_id", "item_id", "vote"]]
    j = rep.merge(tst, on=["rater_id", "item_id"], how="inner", suffixes=("_rep", "_test"))
    jc = pd.Index(raters).get_indexer(j["rater_id"])
    same = (j["vote_rep"].to_numpy() == j["vote_test"].to_numpy()).astype(float)
    s, c = _per_rater(jc, len(raters), same)
    out["n_repeat_pairs"] = c.astype(np.int64)
    with np.errstate(invalid="ignore", divide="ignore"):
        out["repeat_consistency"] = s / c
    out["repeat_p"] = np.where(c > 0, _st.binom.cdf(s, c, rule.min_repeat_consistency), np.nan)


def _speed_columns(out, votes, r_codes, n_r, rule):
    t = votes["kind"].to_numpy() == ItemKind.TEST
    rt = pd.to_numeric(votes["response_ms"], errors="coerce").to_numpy(np.float64)[t]
    tr = r_codes[t]
    known = np.isfinite(rt)
    fast, n = _per_rater(tr, n_r, (rt < rule.min_response_ms).astype(float), known)
    with np.errstate(invalid="ignore", divide="ignore"):
        out["fast_share"] = fast / n
    out["speed_p"] = np.where(n > 0, _st.binom.sf(fast - 1, n, 0.5), np.nan)
    med = pd.Series(rt[known]).groupby(tr[known]).median()
    out["median_response_ms"] = med.reindex(range(n_r)).to_numpy()
    s, c = _per_rater(tr, n_r, votes["vote"].to_numpy(np.float64)[t])
    with np.errstate(invalid="ignore", divide="ignore"):
        out["modal_share"] = np.maximum(s / c, 1 - s / c)
        share_good = out["n_cons_good"] / out["n_compared"]
    out["others_modal_share"] = np.maximum(share_good, 1 - share_good)


def rater_table(votes: pd.DataFrame, *, rule: ScreenRule | None = None) -> pd.DataFrame:
    """Per-rater screening numbers from one-row-per-vote ``votes`` (all kinds).

    Parameters
    ----------
    votes : pandas.DataFrame
        One row per vote (columns ``rater_id``, ``kind``, ``item_id``, the vote and the
        response time, as in the ratings table).
    rule : ScreenRule or None
        Thresholds and test level; None for the defaults.

    Returns
    -------
    pandas.DataFrame
        One row per rater (sorted by id): ``rater_id``, ``simulated``, ``n_<kind>`` counts and
        the agreement, gold, repeat and speed columns (the module docstring lists them).
    """
    rule = rule or ScreenRule()
    r_codes, raters = pd.factorize(votes["rater_id"], sort=True)
    n_r = len(raters)
    kind = votes["kind"].to_numpy()
    out = pd.DataFrame({"rater_id": raters.astype(str)})
    out["simulated"] = out["rater_id"].str.startswith(SIM_PREFIX)
    for k in ITEM_KINDS:
        out[f"n_{k}"] = np.bincount(r_codes[kind == k], minlength=n_r)
    _agreement_columns(out, votes, raters, rule)
    _gold_columns(out, votes, r_codes, n_r, rule)
    _repeat_columns(out, votes, raters, rule)
    _speed_columns(out, votes, r_codes, n_r, rule)
    return out


def _checks(r: pd.DataFrame, rule: ScreenRule):
    a = rule.alpha
    return [
        (r["j_p"] < a, f"agreement with the others: J < {rule.min_j} (p < {a})"),
        (r["skill_p"] >= rule.skill_alpha, "no skill shown: votes independent of the others' "
         f"(Fisher p >= {rule.skill_alpha})"),
        (r["gold_p"] < a, f"gold failure rate > {rule.max_gold_failure_rate} (p < {a})"),
        (r["repeat_p"] < a, f"repeat consistency < {rule.min_repeat_consistency} (p < {a})"),
        (r["speed_p"] < a, f"median response < {rule.min_response_ms:g} ms (p < {a})"),
    ]


def screen(
    raters: pd.DataFrame, *, rule: ScreenRule | None = None, use_rule: bool, exclude: list[str] = ()
) -> pd.DataFrame:
    """Add ``flags`` (every significant test), ``excluded`` and ``excluded_reason``.

    Flags are always computed and reported; raters are excluded by ``exclude``
    (``--exclude-raters``) and, with ``use_rule`` (``analyze``'s default; ``--no-screen``
    turns it off), by a flag: ``excluded_reason`` is then ``screening: `` and the flags.

    Parameters
    ----------
    raters : pandas.DataFrame
        :func:`rater_table` output.
    rule : ScreenRule or None
        Thresholds and test level; None for the defaults.
    use_rule : bool
        Whether a flag excludes the rater.
    exclude : list of str
        Rater ids to exclude by hand.

    Returns
    -------
    pandas.DataFrame
        A copy of ``raters`` with ``flags``, ``excluded`` and ``excluded_reason`` added.

    Raises
    ------
    InputError
        When ``exclude`` names a rater not in ``raters``.
    """
    rule = rule or ScreenRule()
    unknown = sorted(set(exclude) - set(raters["rater_id"]))
    if unknown:
        raise InputError(
            param="exclude", field=unknown[0], expected="a rater id of the ratings", got="no such rater"
        )
    flags = [[] for _ in range(len(raters))]
    for mask, text in _checks(raters, rule):
        for i in np.flatnonzero(mask.fillna(False).to_numpy(bool)):
            flags[i].append(text)
    out = raters.copy()
    out["flags"] = ["; ".join(f) for f in flags]
    manual = out["rater_id"].isin(set(exclude)).to_numpy()
    by_rule = np.array([bool(f) for f in flags], dtype=bool) & use_rule
    out["excluded"] = manual | by_rule
    out["excluded_reason"] = [
        "; ".join((["--exclude-raters"] if m else []) + (["screening: " + f] if b else []))
        for m, b, f in zip(manual, by_rule, out["flags"], strict=True)
    ]
    return out
