"""Rater screening: per-rater quality numbers and a documented exclusion rule.

Per rater (``raters.csv``):

- ``agreement``: share of the rater's test votes equal to the leave-one-out majority of the
  *other* raters' votes on the same item (others' good fraction >= 0.5 counts as good);
  ``n_compared`` votes had at least one other vote. ``loo_corr`` is the Pearson correlation
  of the rater's votes with the others' good fraction (P.913's "correlation with the mean").
- ``gold_failures`` / ``gold_failure_rate``: votes on gold items against the expected answer.
  The expected answer is the column ``gold_expected`` (1 good, 0 bad) when present, else the
  item id prefix written by ``annotate``: ``gold-good:...`` must be voted good,
  ``gold-bad:...`` bad. Gold rows with neither are counted in ``n_gold_unscored``.
- ``repeat_consistency``: ``kind == 'repeat'`` rows carry the item id of the original test
  item; the share of repeats the rater answered as on their test vote.
- ``modal_share``: share of the rater's test votes equal to their most frequent answer
  (straight-lining); ``others_modal_share``: the same for the others' majority on those items.
- ``median_response_ms`` over the rater's test votes; ``simulated``: id starts with ``sim-``.

The ``--screen`` rule (in the spirit of ITU-T P.910 / P.913 subject screening: drop subjects
who disagree with the panel, fail known answers, contradict themselves or do not look), one
pass, thresholds in :class:`ScreenRule`. A rater is excluded when any of:

1. ``agreement < 0.6`` over at least 10 compared votes;
2. ``gold_failure_rate > 0.25`` over at least 2 scored gold votes;
3. ``repeat_consistency < 0.7`` over at least 3 repeats;
4. straight-lining: at least 20 test votes, ``modal_share >= 0.95`` while the others'
   majority on the same items has ``others_modal_share <= 0.8``;
5. ``median_response_ms < 300`` over at least 10 test votes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from data_schema.errors import InputError
from data_schema.raters import SIM_PREFIX
from data_schema.tables import ITEM_KINDS

__all__ = ["ScreenRule", "rater_table", "screen", "gold_expected", "SIM_PREFIX"]



@dataclass(frozen=True)
class ScreenRule:
    """Thresholds of the ``--screen`` rule (see the module docstring)."""

    min_agreement: float = 0.6
    min_compared: int = 10
    max_gold_failure_rate: float = 0.25
    min_gold: int = 2
    min_repeat_consistency: float = 0.7
    min_repeats: int = 3
    straight_modal_share: float = 0.95
    straight_others_max: float = 0.8
    straight_min_votes: int = 20
    min_median_response_ms: float = 300.0
    min_votes_for_speed: int = 10


def gold_expected(gold: pd.DataFrame) -> np.ndarray:
    """Expected vote of gold rows: (n,) float 1.0 / 0.0, NaN where unknown."""
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


def _per_rater(codes, n_r, values, mask=None):
    """(sum, count) of values per rater code, over rows in mask."""
    if mask is not None:
        codes, values = codes[mask], values[mask]
    return (
        np.bincount(codes, weights=values, minlength=n_r),
        np.bincount(codes, minlength=n_r).astype(np.float64),
    )


def rater_table(votes: pd.DataFrame) -> pd.DataFrame:
    """Per-rater screening numbers from one-row-per-vote ``votes`` (all kinds)."""
    r_codes, raters = pd.factorize(votes["rater_id"], sort=True)
    n_r = len(raters)
    kind = votes["kind"].to_numpy()
    vote = votes["vote"].to_numpy(np.float64)
    out = pd.DataFrame({"rater_id": raters.astype(str)})
    out["simulated"] = out["rater_id"].str.startswith(SIM_PREFIX)
    for k in ITEM_KINDS:
        out[f"n_{k}"] = np.bincount(r_codes[kind == k], minlength=n_r)

    t = kind == "test"
    tv, tr = vote[t], r_codes[t]
    i_codes = pd.factorize(votes["item_id"].to_numpy()[t])[0]
    n_item = np.bincount(i_codes).astype(np.float64)
    g_item = np.bincount(i_codes, weights=tv)
    loo_n = n_item[i_codes] - 1
    with np.errstate(invalid="ignore", divide="ignore"):
        loo_gvf = (g_item[i_codes] - tv) / loo_n
    has = loo_n > 0
    loo_major = (loo_gvf >= 0.5).astype(np.float64)
    s, c = _per_rater(tr, n_r, (tv == loo_major).astype(np.float64), has)
    with np.errstate(invalid="ignore", divide="ignore"):
        out["n_compared"] = c.astype(np.int64)
        out["agreement"] = s / c
        # Pearson of own vote with others' fraction, per rater (group sums)
        sx, _ = _per_rater(tr, n_r, tv, has)
        sy, _ = _per_rater(tr, n_r, loo_gvf, has)
        mx, my = sx / c, sy / c
        xc = np.where(has, tv - mx[tr], 0.0)
        yc = np.where(has, loo_gvf - my[tr], 0.0)
        sxy = np.bincount(tr, weights=xc * yc, minlength=n_r)
        sxx = np.bincount(tr, weights=xc * xc, minlength=n_r)
        syy = np.bincount(tr, weights=yc * yc, minlength=n_r)
        out["loo_corr"] = sxy / np.sqrt(sxx * syy)
        out.loc[~((sxx > 0) & (syy > 0) & (c >= 3)), "loo_corr"] = np.nan

        g = kind == "gold"
        exp = gold_expected(votes[g])
        scored = np.isfinite(exp)
        fails = (vote[g] != exp) & scored
        out["gold_failures"] = np.bincount(r_codes[g], weights=fails, minlength=n_r).astype(
            np.int64
        )
        n_scored = np.bincount(r_codes[g], weights=scored, minlength=n_r)
        out["n_gold_unscored"] = out["n_gold"] - n_scored.astype(np.int64)
        out["gold_failure_rate"] = out["gold_failures"] / n_scored

        s, c = _per_rater(tr, n_r, tv)
        p_good = s / c
        out["modal_share"] = np.maximum(p_good, 1 - p_good)
        s2, c2 = _per_rater(tr, n_r, loo_major, has)
        p2 = s2 / c2
        out["others_modal_share"] = np.maximum(p2, 1 - p2)

    rep = votes[kind == "repeat"][["rater_id", "item_id", "vote"]]
    tst = votes[t][["rater_id", "item_id", "vote"]]
    j = rep.merge(tst, on=["rater_id", "item_id"], how="inner", suffixes=("_rep", "_test"))
    jc = pd.Categorical(j["rater_id"], categories=raters).codes
    s, c = _per_rater(
        jc, n_r, (j["vote_rep"].to_numpy() == j["vote_test"].to_numpy()).astype(float)
    )
    with np.errstate(invalid="ignore", divide="ignore"):
        out["n_repeat_pairs"] = c.astype(np.int64)
        out["repeat_consistency"] = s / c
    rt = votes["response_ms"].to_numpy(np.float64)
    med = pd.Series(rt[t]).groupby(tr).median()
    out["median_response_ms"] = med.reindex(range(n_r)).to_numpy()
    return out


def screen(
    raters: pd.DataFrame, *, rule: ScreenRule | None = None, use_rule: bool, exclude: list[str] = ()
) -> pd.DataFrame:
    """Add ``flags`` (every rule a rater breaks), ``excluded`` and ``excluded_reason``.

    Flags are always computed and reported; raters are excluded only by ``exclude``
    (``--exclude-raters``) or, with ``use_rule`` (``--screen``), by a broken rule.
    """
    rule = rule or ScreenRule()
    unknown = sorted(set(exclude) - set(raters["rater_id"]))
    if unknown:
        raise InputError(
            "--exclude-raters", unknown[0], "a rater id of the ratings", "no such rater"
        )
    r = raters
    checks = [
        (
            (r["agreement"] < rule.min_agreement) & (r["n_compared"] >= rule.min_compared),
            f"agreement with others' majority < {rule.min_agreement}",
        ),
        (
            (r["gold_failure_rate"] > rule.max_gold_failure_rate)
            & ((r["n_gold"] - r["n_gold_unscored"]) >= rule.min_gold),
            f"gold failure rate > {rule.max_gold_failure_rate}",
        ),
        (
            (r["repeat_consistency"] < rule.min_repeat_consistency)
            & (r["n_repeat_pairs"] >= rule.min_repeats),
            f"repeat consistency < {rule.min_repeat_consistency}",
        ),
        (
            (r["modal_share"] >= rule.straight_modal_share)
            & (r["others_modal_share"] <= rule.straight_others_max)
            & (r["n_test"] >= rule.straight_min_votes),
            "straight-lining",
        ),
        (
            (r["median_response_ms"] < rule.min_median_response_ms)
            & (r["n_test"] >= rule.min_votes_for_speed),
            f"median response < {rule.min_median_response_ms:g} ms",
        ),
    ]
    flags = [[] for _ in range(len(r))]
    for mask, text in checks:
        for i in np.flatnonzero(mask.fillna(False).to_numpy(bool)):
            flags[i].append(text)
    out = r.copy()
    out["flags"] = ["; ".join(f) for f in flags]
    manual = out["rater_id"].isin(set(exclude)).to_numpy()
    by_rule = np.array([bool(f) for f in flags]) & use_rule
    out["excluded"] = manual | by_rule
    reasons = []
    for i in range(len(out)):
        parts = (["--exclude-raters"] if manual[i] else []) + (
            ["--screen: " + out["flags"].iat[i]] if by_rule[i] else []
        )
        reasons.append("; ".join(parts))
    out["excluded_reason"] = reasons
    return out
