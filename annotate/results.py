"""What a study's votes say: the ratings table (SPEC section 5), GVF, agreement, gold checks.

- :func:`ratings_table`: one row per standing vote, SPEC section 5 columns in order, then
  attributes and (when the study has them) metric columns.
- :func:`gvf_table`: per test item ``n_votes, n_good, gvf = n_good / n_votes,
  majority_good = gvf >= 0.5`` (paper section 4; only ``kind == test`` counts).
- :func:`nominal_alpha`: Krippendorff's alpha (nominal) over test items, raters x items.
- :func:`gold_failures`: gold votes that contradict the gold answer.

>>> r = pd.DataFrame({"item_id": ["a", "a", "b", "b", "b"], "kind": ["test"] * 5,
...                   "vote": [1, 0, 1, 1, 1], "rater_id": ["x", "y", "x", "y", "z"]})
>>> gvf_table(r)[["item_id", "n_votes", "n_good", "gvf", "majority_good"]].values.tolist()
[['a', 2, 1, 0.5, True], ['b', 3, 3, 1.0, True]]
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from data_schema.tables import ITEM_KINDS, PAIR_META_COLUMNS, RATINGS_COLUMNS

__all__ = ["ratings_table", "gvf_table", "nominal_alpha", "gold_failures", "rater_progress"]


def ratings_table(study) -> pd.DataFrame:
    """SPEC section 5 table of ``study`` (an :class:`annotate.study.Study`)."""
    votes = study.store.votes()
    items = study.items
    attrs = list(study.manifest.get("attribute_columns", []))
    attrs = [*study.manifest.get("view_columns", []), *attrs]  # 6-DoF columns (absent: lateral study)
    meta = items.loc[:, ["key", "item_id", "kind", "pair_id", *PAIR_META_COLUMNS, *attrs]]
    df = votes.merge(meta, left_on="item", right_on="key", how="inner")
    df = df.rename(columns={"rater": "rater_id"})
    df["response_ms"] = df["response_ms"].astype("Int64")
    metric_cols = list(study.manifest.get("metric_columns", []))
    if metric_cols and (study.root / "metrics.csv").is_file():
        metrics = pd.read_csv(study.root / "metrics.csv", dtype={"pair_id": str})
        df = df.merge(metrics, on="pair_id", how="left")
        # gold items show GT against GT or a broken copy: the pair's metrics do not apply
        df.loc[df["kind"] == "gold", metric_cols] = np.nan
    cols = [*RATINGS_COLUMNS, *PAIR_META_COLUMNS, *attrs, *metric_cols]
    return df.loc[:, cols].sort_values(["voted_at", "rater_id", "item_id"], kind="stable"
                                       ).reset_index(drop=True)


def gvf_table(ratings: pd.DataFrame) -> pd.DataFrame:
    """Per-item GVF over ``kind == test`` votes; other columns of the item are kept (first)."""
    test = ratings[ratings["kind"] == "test"]
    extra = [c for c in test.columns if c not in (*RATINGS_COLUMNS,)]
    g = test.groupby("item_id", sort=True)
    out = pd.DataFrame({"n_votes": g["vote"].size(), "n_good": g["vote"].sum().astype(int)})
    out["gvf"] = out["n_good"] / out["n_votes"]
    out["majority_good"] = out["gvf"] >= 0.5
    if extra:
        out = out.join(g[extra].first())
    return out.reset_index()


def nominal_alpha(ratings: pd.DataFrame) -> tuple[float | None, str]:
    """Krippendorff's alpha (nominal) of test votes and a note; ``None`` when undefined."""
    import krippendorff

    test = ratings[ratings["kind"] == "test"]
    if test["rater_id"].nunique() < 2:
        return None, "needs votes from at least 2 raters"
    mat = test.pivot_table(index="rater_id", columns="item_id", values="vote", aggfunc="last")
    mat = mat.loc[:, mat.notna().sum(axis=0) >= 2]
    if mat.shape[1] == 0:
        return None, "no item has votes from 2 raters"
    values = mat.to_numpy(dtype=float)
    if np.unique(values[np.isfinite(values)]).size < 2:
        return None, "all votes are equal (alpha undefined)"
    return float(krippendorff.alpha(reliability_data=values, level_of_measurement="nominal")), \
        f"{mat.shape[1]} items with >= 2 votes"


def gold_failures(ratings: pd.DataFrame) -> pd.DataFrame:
    """Gold votes against the gold answer: columns rater_id, item_id, vote, expected."""
    gold = ratings[ratings["kind"] == "gold"].copy()
    gold["expected"] = gold["item_id"].str.startswith("gold-good:").astype(int)
    return gold.loc[gold["vote"] != gold["expected"], ["rater_id", "item_id", "vote", "expected"]
                    ].reset_index(drop=True)


def rater_progress(study) -> pd.DataFrame:
    """Per rater: votes by kind, gold failures, median response time (ms)."""
    ratings = ratings_table(study)
    raters = study.store.raters()
    counts = ratings.pivot_table(index="rater_id", columns="kind", values="vote", aggfunc="size",
                                 fill_value=0).reindex(raters, fill_value=0)
    out = counts.reindex(columns=list(ITEM_KINDS), fill_value=0).astype(int)
    fails = gold_failures(ratings).groupby("rater_id").size()
    out["gold_failures"] = fails.reindex(out.index, fill_value=0).astype(int)
    out["median_response_ms"] = ratings.groupby("rater_id")["response_ms"].median().reindex(out.index)
    return out.rename_axis("rater_id").reset_index()
