"""What a study's votes say: the ratings table (docs/FORMATS.md §5), GVF, agreement, gold checks.

Layer: annotate (rating study).

- :func:`ratings_table`: one row per standing vote, docs/FORMATS.md §5 columns in order, then
  attributes and (when the study has them) metric columns.
- :func:`pairwise_votes_table`: the same for a pairwise study (docs/FORMATS.md §12);
  :func:`votes_table`: the one of the two the study's design calls for (``annotate export``).
- :func:`good_vote_fraction`: THE definition of the Good Vote Fraction (paper section 4):
  per item ``n_votes, n_good, gvf = n_good / n_votes, majority_good = gvf >= 0.5`` (a tie
  counts as good) and its Wilson 95% interval ``gvf_ci_lo, gvf_ci_hi``; used by
  :func:`gvf_table` here and by ``analysis.tables.labels.item_table``.
- :func:`gvf_table`: the same over the ``kind == test`` rows of a ratings table.
- :func:`alpha_nominal`: THE Krippendorff's alpha (nominal), from the maintained
  ``krippendorff`` package on (unit, value) pairs, with one rule for when it is undefined;
  :func:`nominal_alpha` applies it to the test votes of a ratings table.
- :func:`gold_failures`: gold votes that contradict the gold answer.

>>> r = pd.DataFrame({"item_id": ["a", "a", "b", "b", "b"], "kind": ["test"] * 5,
...                   "vote": [1, 0, 1, 1, 1], "rater_id": ["x", "y", "x", "y", "z"]})
>>> gvf_table(r)[["item_id", "n_votes", "n_good", "gvf", "majority_good"]].values.tolist()
[['a', 2, 1, 0.5, True], ['b', 3, 3, 1.0, True]]
"""

from __future__ import annotations

import krippendorff
import numpy as np
import pandas as pd

from annotate.pairwise import choice
from data_schema.tables import (
    ITEM_KINDS,
    PAIR_META_COLUMNS,
    PAIRWISE_VOTES_COLUMNS,
    RATINGS_COLUMNS,
)
from data_schema.text import plural
from data_schema.vocab import Answer, ItemKind, Side, StudyDesign

__all__ = [
    "ratings_table",
    "pairwise_votes_table",
    "votes_table",
    "good_vote_fraction",
    "wilson_interval",
    "gvf_table",
    "alpha_nominal",
    "nominal_alpha",
    "gold_failures",
    "rater_progress",
    "pairwise_raters",
]

#: z of the two-sided 95% Wilson interval
_Z95 = 1.959963984540054


def ratings_table(study) -> pd.DataFrame:
    """docs/FORMATS.md §5 table of ``study`` (an :class:`annotate.study.Study`).

    Parameters
    ----------
    study : Study
        An open single-image study (gold items keep their rows, without metrics).

    Returns
    -------
    pandas.DataFrame
        Columns of docs/FORMATS.md §5, one row per standing vote in vote order.
    """
    attrs = list(study.manifest.attribute_columns)
    # 6-DoF columns (absent: lateral study) and ``method`` (absent: single-method study)
    attrs = [*study.manifest.view_columns, *study.manifest.method_columns, *attrs]
    df = _voted_items(study, ["item_id", "kind", "pair_id", *PAIR_META_COLUMNS, *attrs])
    metric_cols, metrics = _study_metrics(study)
    if metrics is not None:
        df = df.merge(metrics, on="pair_id", how="left")
        # gold items show GT against GT or a broken copy: the pair's metrics do not apply
        df.loc[df["kind"] == ItemKind.GOLD, metric_cols] = np.nan
    cols = [*RATINGS_COLUMNS, *PAIR_META_COLUMNS, *attrs, *metric_cols]
    return _in_vote_order(df, cols)


def pairwise_votes_table(study) -> pd.DataFrame:
    """docs/FORMATS.md §12 votes of a pairwise ``study``: one row per standing vote.

    Columns :data:`~data_schema.tables.PAIRWISE_VOTES_COLUMNS` (``side_a`` from the rater's
    plan, ``choice`` in {'a', 'b', 'tie'}), ``voted_at, response_ms``, the object's metadata, view and attribute
    columns, ``pair_id_a, pair_id_b`` (the renders' pairs; empty for the GT crop of a gold
    item) and, when the study has metrics, ``METRIC_a, METRIC_b`` per metric column.

    Parameters
    ----------
    study : Study
        An open pairwise study.

    Returns
    -------
    pandas.DataFrame
        The columns above, sorted by ``voted_at``, ``rater_id`` and ``item_id``.
    """
    attrs = [*study.manifest.view_columns, *study.manifest.attribute_columns]
    attrs = [c for c in attrs if c in study.items.columns]
    df = _voted_items(study, ["item_id", "kind", "method_a", "method_b", "pair_id_a", "pair_id_b",
                              *PAIR_META_COLUMNS, *attrs])
    plans = {r: study.plan_for(r)["sides"] for r in df["rater_id"].unique()}
    df["side_a"] = [plans[r][k] for r, k in zip(df["rater_id"], df["key"], strict=True)]
    df["choice"] = choice(df["vote"].to_numpy(), df["side_a"].to_numpy())
    df[["pair_id_a", "pair_id_b"]] = df[["pair_id_a", "pair_id_b"]].fillna("")
    metric_cols, metrics = _study_metrics(study)
    sided = []
    if metrics is not None:
        for side in ("a", "b"):
            named = metrics.rename(columns={"pair_id": f"pair_id_{side}",
                                            **{m: f"{m}_{side}" for m in metric_cols}})
            df = df.merge(named, on=f"pair_id_{side}", how="left")
        sided = [f"{m}_{side}" for m in metric_cols for side in ("a", "b")]
    cols = [*PAIRWISE_VOTES_COLUMNS, "voted_at", "response_ms", *PAIR_META_COLUMNS, *attrs, "pair_id_a", "pair_id_b", *sided]
    return _in_vote_order(df, cols)


def _voted_items(study, columns: list[str]) -> pd.DataFrame:
    """The study's standing votes joined with the ``columns`` of their items (``key`` kept;
    ``rater`` renamed ``rater_id``; ``response_ms`` as nullable integers)."""
    meta = study.items.loc[:, ["key", *columns]]
    df = study.store.votes().merge(meta, left_on="item", right_on="key", how="inner")
    df = df.rename(columns={"rater": "rater_id"})
    df["response_ms"] = df["response_ms"].astype("Int64")
    return df


def _in_vote_order(df: pd.DataFrame, columns: list[str]) -> pd.DataFrame:
    """``columns`` of ``df`` sorted (stably) by ``voted_at, rater_id, item_id``, index reset."""
    return df.loc[:, columns].sort_values(["voted_at", "rater_id", "item_id"], kind="stable"
                                          ).reset_index(drop=True)


def _study_metrics(study) -> tuple[list[str], pd.DataFrame | None]:
    """The study's metric columns and its ``metrics.csv`` (None without metrics or file)."""
    metric_cols = list(study.manifest.metric_columns)
    path = study.root / "metrics.csv"
    if metric_cols and path.is_file():
        return metric_cols, pd.read_csv(path, dtype={"pair_id": str})
    return metric_cols, None


def votes_table(study) -> pd.DataFrame:
    """The export of ``study``: :func:`pairwise_votes_table` or :func:`ratings_table`.

    Parameters
    ----------
    study : Study
        An open study of either design (its ``design`` picks the table).

    Returns
    -------
    pandas.DataFrame
        The §12 pairwise votes or the §5 ratings.
    """
    return pairwise_votes_table(study) if study.design == StudyDesign.PAIRWISE else ratings_table(study)


def wilson_interval(n_good, n, *, z: float = _Z95):
    """Wilson score interval of a proportion ``n_good / n`` (arrays); NaN where ``n == 0``.

    Parameters
    ----------
    n_good : array of int
        Successes.
    n : array of int
        Trials.
    z : float, optional
        Normal quantile (default: 95 %).

    Returns
    -------
    lo, hi : array of float64
        Bounds in [0, 1]; NaN where ``n == 0``.

    >>> lo, hi = wilson_interval(np.array([2]), np.array([3]))
    >>> round(float(lo[0]), 4), round(float(hi[0]), 4)
    (0.2077, 0.9385)
    """
    k, n = np.asarray(n_good, float), np.asarray(n, float)
    with np.errstate(invalid="ignore", divide="ignore"):
        p = k / n
        den = 1 + z * z / n
        mid = (p + z * z / (2 * n)) / den
        half = z * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / den
    return mid - half, mid + half


def _column(values) -> pd.Series:
    """``values`` (n,) as a Series (a Series as it is: no copy to Python objects)."""
    return values if isinstance(values, pd.Series) else pd.Series(np.asarray(values, dtype=object))


def good_vote_fraction(item_ids, votes) -> pd.DataFrame:
    """Per item (first-seen order): ``item_id, n_votes, n_good, gvf, majority_good,
    gvf_ci_lo, gvf_ci_hi`` from parallel arrays of item ids and 0/1 test votes.

    Parameters
    ----------
    item_ids : (n,) array-like
        Item of each vote.
    votes : (n,) array of int
        0/1 test votes.

    Returns
    -------
    pandas.DataFrame
        One row per item.
    """
    codes, uniques = pd.factorize(_column(item_ids))
    n = np.bincount(codes, minlength=len(uniques))
    good = np.bincount(codes, weights=np.asarray(votes, np.float64), minlength=len(uniques))
    gvf = good / np.maximum(n, 1)
    lo, hi = wilson_interval(good, n)
    return pd.DataFrame({"item_id": np.asarray(uniques, dtype=object),
                         "n_votes": n.astype(np.int64), "n_good": good.astype(np.int64),
                         "gvf": gvf, "majority_good": gvf >= 0.5, "gvf_ci_lo": lo,
                         "gvf_ci_hi": hi})


def gvf_table(ratings: pd.DataFrame) -> pd.DataFrame:
    """Per-item GVF over ``kind == test`` votes, by item id; other item columns kept (first).

    Parameters
    ----------
    ratings : pandas.DataFrame
        A ratings table (docs/FORMATS.md §5).

    Returns
    -------
    pandas.DataFrame
        One row per test item.
    """
    test = ratings[ratings["kind"] == ItemKind.TEST]
    extra = [c for c in test.columns if c not in (*RATINGS_COLUMNS,)]
    out = good_vote_fraction(test["item_id"], test["vote"]).set_index("item_id").sort_index()
    if extra:
        out = out.join(test.groupby("item_id", sort=True)[extra].first())
    return out.rename_axis("item_id").reset_index()


def alpha_nominal(units, values) -> tuple[float, str | None]:
    """Krippendorff's alpha (nominal) of ``values`` (n,) given to ``units`` (n,), one per vote.

    Missing values are ignored. Returns ``(alpha, None)``, or ``(nan, reason)`` when it is
    undefined: no unit has two values, or only one value occurs.

    Parameters
    ----------
    units : (n,) array-like
        Unit (item) of each vote.
    values : (n,) array-like
        Nominal value of each vote.

    Returns
    -------
    alpha : float
        NaN when undefined.
    reason : str or None
        Why it is undefined.

    >>> alpha_nominal(["a", "a", "b", "b"], [1, 1, 0, 0])
    (1.0, None)
    """
    units, values = _column(units), _column(values)
    keep = values.notna().to_numpy()
    if not keep.all():
        units, values = units[keep], values[keep]
    u_codes, u_uniques = pd.factorize(units, use_na_sentinel=False)
    v_codes, v_uniques = pd.factorize(values)
    n_u, n_v = len(u_uniques), len(v_uniques)
    counts = np.bincount(u_codes * n_v + v_codes, minlength=n_u * n_v).reshape(n_u, n_v)  # (U, V)
    counts = counts.astype(np.float64)[counts.sum(axis=1) >= 2]
    if len(counts) == 0:
        return float("nan"), "no unit has two values"
    if (counts.sum(axis=0) > 0).sum() < 2:
        return float("nan"), "only one value occurs"
    return float(krippendorff.alpha(value_counts=counts, level_of_measurement="nominal")), None


def nominal_alpha(ratings: pd.DataFrame) -> tuple[float | None, str]:
    """Krippendorff's alpha (nominal) of test votes and a note; ``None`` when undefined.

    Parameters
    ----------
    ratings : pandas.DataFrame
        A ratings table.

    Returns
    -------
    alpha : float or None
        ``None`` when undefined.
    note : str
        What it was computed on, or why it is undefined.
    """
    test = ratings[ratings["kind"] == ItemKind.TEST]
    if test["rater_id"].nunique() < 2:
        return None, "needs votes from at least 2 raters"
    alpha, why = alpha_nominal(test["item_id"].to_numpy(), test["vote"].to_numpy())
    if why:
        return None, why
    n_items = int((test.groupby("item_id").size() >= 2).sum())
    return alpha, f"{plural(n_items, 'item')} with >= 2 votes"


def gold_failures(ratings: pd.DataFrame) -> pd.DataFrame:
    """Gold votes against the gold answer: columns rater_id, item_id, vote, expected.

    Parameters
    ----------
    ratings : pandas.DataFrame
        The ratings (:func:`ratings_table`); only its ``kind == 'gold'`` rows are read.

    Returns
    -------
    pandas.DataFrame
        ``rater_id, item_id, vote, expected``, one row per wrong gold vote.
    """
    gold = ratings[ratings["kind"] == ItemKind.GOLD].copy()
    gold["expected"] = gold["item_id"].str.startswith("gold-good:").astype(int)
    return gold.loc[gold["vote"] != gold["expected"], ["rater_id", "item_id", "vote", "expected"]
                    ].reset_index(drop=True)


def rater_progress(study, ratings: pd.DataFrame | None = None) -> pd.DataFrame:
    """Per rater: votes by kind, gold failures, median response time (ms).

    ``ratings`` is :func:`ratings_table` of ``study`` when the caller has it already.

    Parameters
    ----------
    study : Study
        An open study.
    ratings : pandas.DataFrame, optional
        Its ratings table, when already made.

    Returns
    -------
    pandas.DataFrame
        One row per rater.
    """
    if ratings is None:
        ratings = ratings_table(study)
    raters = study.store.raters()
    counts = ratings.pivot_table(index="rater_id", columns="kind", values="vote", aggfunc="size",
                                 fill_value=0).reindex(raters, fill_value=0)
    out = counts.reindex(columns=list(ITEM_KINDS), fill_value=0).astype(int)
    fails = gold_failures(ratings).groupby("rater_id").size()
    out["gold_failures"] = fails.reindex(out.index, fill_value=0).astype(int)
    out["median_response_ms"] = ratings.groupby("rater_id")["response_ms"].median().reindex(out.index)
    return out.rename_axis("rater_id").reset_index()


def pairwise_raters(votes: pd.DataFrame, raters: list[str]) -> pd.DataFrame:
    """Per rater of a pairwise study (:func:`pairwise_votes_table` rows): votes by kind, the
    share of test answers ``a``/``b``/``tie``, ``left_share`` (of the test answers naming a
    side, the share pressed on the left: near 0.5 for a rater without a side bias, as A's side
    is counterbalanced), ``gold_failures`` (gold answers other than ``a``, the GT crop itself),
    ``repeat_agreement`` (repeats answered as their original, in A/B terms, sides swapped) over
    ``n_repeat_pairs``, and the median response time (ms).

    Parameters
    ----------
    votes : pandas.DataFrame
        Pairwise votes table rows.
    raters : list of str
        The raters to report.

    Returns
    -------
    pandas.DataFrame
        One row per rater.

    >>> v = pd.DataFrame({"rater_id": ["x"] * 4, "kind": ["test", "repeat", "gold", "test"],
    ...                   "item_id": ["i", "i", "g", "j"], "choice": ["a", "b", "a", "tie"],
    ...                   "side_a": ["left", "right", "left", "left"], "response_ms": [1, 2, 3, 4]})
    >>> r = pairwise_raters(v, ["x"]).iloc[0]
    >>> [float(r[c]) for c in ("test", "gold_failures", "repeat_agreement", "left_share")]
    [2.0, 0.0, 0.0, 1.0]

    (``i`` answered ``a`` then, sides swapped, ``b``: agreement 0; the one sided test answer,
    ``a`` with A on the left, was pressed on the left.)
    """
    out = votes.pivot_table(index="rater_id", columns="kind", values="choice", aggfunc="size",
                            fill_value=0).reindex(index=raters, columns=list(ITEM_KINDS),
                                                  fill_value=0).astype(int)
    test = votes[votes["kind"] == ItemKind.TEST]
    shares = pd.crosstab(test["rater_id"], test["choice"], normalize="index")
    for c in ("a", "b", "tie"):
        out[f"share_{c}"] = shares.get(c, pd.Series(dtype=float)).reindex(out.index)
    sided = test[test["choice"] != Answer.TIE]
    left = (sided["choice"] == Answer.A) == (sided["side_a"] == Side.LEFT)
    out["left_share"] = left.groupby(sided["rater_id"]).mean().reindex(out.index)
    gold = votes[votes["kind"] == ItemKind.GOLD]
    out["gold_failures"] = (gold["choice"] != Answer.A).groupby(gold["rater_id"]).sum().reindex(
        out.index, fill_value=0).astype(int)
    rep = votes[votes["kind"] == ItemKind.REPEAT].merge(test, on=["rater_id", "item_id"],
                                                 suffixes=("", "_orig"))
    same = (rep["choice"] == rep["choice_orig"]).groupby(rep["rater_id"])
    out["n_repeat_pairs"] = same.size().reindex(out.index, fill_value=0).astype(int)
    out["repeat_agreement"] = same.mean().reindex(out.index)
    out["median_response_ms"] = votes.groupby("rater_id")["response_ms"].median().reindex(out.index)
    return out.rename_axis("rater_id").reset_index()
