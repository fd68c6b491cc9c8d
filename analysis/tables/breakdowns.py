"""Breakdowns: per category (paper Table 2), per offset (Fig. 3), per encoder (Table 3).

Layer: analysis (statistics of votes and metrics).

All grouped statistics are columnar: one argsort per metric column, reused by every
grouping; group sums by ``np.bincount``. Undefined groups follow the rule of
:mod:`analysis.stats.stats` (empty value + ``reason``).

>>> import pandas as pd
>>> items = pd.DataFrame({"gvf": [0.0, 0.5, 1.0, 1.0, 0.2, 0.1], "m": [1, 2, 3, 4, 2, 1.0],
...                       "label_class": ["car"] * 3 + ["ped"] * 3, "clip_id": list("aabbcc")})
>>> t = category_table(items, ["m"], by=["label_class"], progress=False)
>>> t[["group", "n", "k", "srcc"]].to_dict("list")
{'group': ['car', 'ped'], 'n': [3, 3], 'k': [2, 2], 'srcc': [1.0, 1.0]}
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy import stats as _st
from tqdm import tqdm

from analysis.stats import stats
from nvrq.metrics import split_column

__all__ = ["category_table", "offset_table", "encoder_table", "breakdown_columns", "MISSING_GROUP",
           "ALL_CLASSES", "MAX_BREAKDOWNS", "MAX_GROUPS"]

#: At most this many attribute columns get a breakdown (besides ``label_class``).
MAX_BREAKDOWNS = 12
#: An attribute column with more distinct values than this (an id, a free text) gets none.
MAX_GROUPS = 20

MISSING_GROUP = "(missing)"
_CAT_COLUMNS = [
    "breakdown",
    "group",
    "metric",
    "n",
    "k",
    "plcc",
    "srcc",
    "plcc_signed",
    "srcc_signed",
    "reason",
]


def _codes(values: pd.Series):
    codes, uniques = pd.factorize(values, use_na_sentinel=False, sort=True)
    names = np.array([MISSING_GROUP if pd.isna(u) else str(u) for u in uniques], dtype=object)
    return codes.astype(np.intp), names


def category_table(
    items: pd.DataFrame,
    metrics: list[str],
    *,
    by: list[str],
    target: str = "gvf",
    clip_col: str = "clip_id",
    progress: bool = True,
) -> pd.DataFrame:
    """Long table: for each column in ``by``, each of its values and each metric:
    ``n`` items, ``k`` distinct clips, |PLCC|, |SRCC|, signed values and ``reason``.

    Parameters
    ----------
    items : pandas.DataFrame
        One row per item with the target, metric and attribute columns.
    metrics : list of str
        Metric columns.
    by : list of str
        Attribute columns to break down by.
    target : str, optional
        The target column.
    clip_col : str, optional
        The clip column (for ``k``).
    progress : bool, optional
        Show a progress bar.

    Returns
    -------
    pandas.DataFrame
    """
    y_all = items[target].to_numpy(np.float64)
    clip_codes_all = (
        pd.factorize(items[clip_col], use_na_sentinel=False)[0] if clip_col in items else None
    )
    # per grouping, for the usual case of all-finite rows: codes, names, k and target ranks
    # are the same for every metric and are computed once
    frames, cache = [], {}
    todo = [(m, b) for m in metrics for b in by]
    bar = tqdm(total=len(todo), desc="breakdowns", unit="table", disable=not progress)
    for m in metrics:
        x_all = items[m].to_numpy(np.float64)
        ok = np.isfinite(x_all) & np.isfinite(y_all)
        full = bool(ok.all())
        x, y = (x_all, y_all) if full else (x_all[ok], y_all[ok])
        x_order = np.argsort(x)
        y_order = None
        for b in by:
            if full and b in cache:
                codes, names, k, ry = cache[b]
            else:
                codes, names = _codes(items[b] if full else items[b][ok])
                k = _clips_per_group(codes, len(names), clip_codes_all, None if full else ok)
                if y_order is None:
                    y_order = np.argsort(y)
                ry = stats.rank_within(y, codes, order=y_order)
                if full:
                    cache[b] = (codes, names, k, ry)
            g = len(names)
            n = stats.group_counts(codes, g)
            r_p, why_p = stats.grouped_pearson(x, y, codes, g)
            rx = stats.rank_within(x, codes, order=x_order)
            r_s, _ = stats.grouped_pearson(rx, ry, codes, g)  # Spearman = Pearson of ranks
            del rx
            frames.append(
                pd.DataFrame(
                    {
                        "breakdown": b,
                        "group": names,
                        "metric": m,
                        "n": n,
                        "k": k,
                        "plcc": np.abs(r_p),
                        "srcc": np.abs(r_s),
                        "plcc_signed": r_p,
                        "srcc_signed": r_s,
                        "reason": why_p,
                    }
                )
            )
            bar.update()
    bar.close()
    if not frames:
        return pd.DataFrame(columns=_CAT_COLUMNS)
    return pd.concat(frames, ignore_index=True)[_CAT_COLUMNS]


def breakdown_columns(items: pd.DataFrame, attributes: list[str]) -> tuple[list[str], str | None]:
    """The columns ``analyze`` breaks the results down by, and a note on what it skipped.

    ``label_class`` always; then, in column order, the first :data:`MAX_BREAKDOWNS` attribute
    columns (the ratings' text columns that are not part of the contract) with at most
    :data:`MAX_GROUPS` distinct values. A breakdown costs a table per metric, so a ratings file
    with thousands of extra columns would otherwise take minutes; columns past the limit are
    not even counted.

    Parameters
    ----------
    items : pandas.DataFrame
        One row per item, with the ``attributes`` columns.
    attributes : list of str
        The attribute columns, in the table's order.

    Returns
    -------
    by : list of str
        ``label_class`` and the chosen attributes.
    note : str or None
        For the report: which columns got no breakdown and why; ``None`` when none was skipped.

    >>> t = pd.DataFrame({"label_class": ["car", "ped"], "day": ["a", "b"], "id": ["x", "y"]})
    >>> breakdown_columns(t, ["day", "id"])
    (['label_class', 'day', 'id'], None)
    """
    chosen, many = [], []
    for i, col in enumerate(attributes):
        if len(chosen) == MAX_BREAKDOWNS:
            rest = attributes[i:]
            break
        (chosen if items[col].nunique(dropna=False) <= MAX_GROUPS else many).append(col)
    else:
        rest = []
    if not many and not rest:
        return ["label_class"] + chosen, None
    parts = []
    if many:
        parts.append(f"{len(many)} with more than {MAX_GROUPS} values ({_names(many)})")
    if rest:
        parts.append(f"{len(rest)} past the first {MAX_BREAKDOWNS} ({_names(rest)})")
    return ["label_class"] + chosen, (
        f"Breakdowns by label_class and {len(chosen)} attribute columns; no breakdown for "
        + " and ".join(parts) + ". Drop the columns you do not need from the ratings table, or "
        "put the ones you do first.")


def _names(cols: list[str], k: int = 5) -> str:
    return ", ".join(cols[:k]) + (f", ... {len(cols) - k} more" if len(cols) > k else "")


def _clips_per_group(codes, n_groups, clip_codes_all, ok):
    """(G,) number of distinct clips per group (``ok``: row mask or None for all rows)."""
    if clip_codes_all is None or len(codes) == 0:
        return np.zeros(n_groups, dtype=np.int64)
    cc = clip_codes_all if ok is None else clip_codes_all[ok]
    n_clips = int(cc.max()) + 1
    present = np.zeros(n_groups * n_clips, dtype=bool)
    present[codes * n_clips + cc] = True
    return present.reshape(n_groups, n_clips).sum(axis=1)


ALL_CLASSES = "all"


def _sampling_std(items: pd.DataFrame, codes: np.ndarray, g: int) -> np.ndarray:
    """Per group: the spread of item GVF expected from vote sampling alone,
    ``sqrt(mean(gvf (1 - gvf) / (n_votes - 1)))`` (items with >= 2 votes)."""
    p = items["gvf"].to_numpy(np.float64)
    n = items["n_votes"].to_numpy(np.float64)
    ok = n >= 2
    var = np.where(ok, p * (1 - p) / np.where(ok, n - 1, 1), 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.sqrt(np.bincount(codes, weights=var, minlength=g)
                       / np.bincount(codes, weights=ok, minlength=g))


def offset_table(
    items: pd.DataFrame, columns: list[str], *, offset_col: str = "y_offset_m",
    by: str | None = None,
) -> pd.DataFrame:
    """Long table ``y_offset_m, label_class, column, n, mean, std, ci_lo, ci_hi,
    sampling_std`` per offset (``label_class = "all"``) or, with ``by``, per condition
    (offset x value of ``by``, e.g. ``label_class``, as ITU-T P.808 reports per condition).

    ``std``: sample std (ddof=1; NaN for n = 1); ``ci_lo, ci_hi``: 95% Student-t interval
    of the mean; ``sampling_std`` (GVF only): the item spread expected from vote sampling
    alone (:func:`_sampling_std`). Only finite values count; rows without an offset are
    left out.

    Parameters
    ----------
    items : pandas.DataFrame
        One row per item.
    columns : list of str
        Value columns summarised.
    offset_col : str, optional
        The offset column, metres.
    by : str, optional
        A condition column.

    Returns
    -------
    pandas.DataFrame
    """
    off = items[offset_col].to_numpy(np.float64)
    keep = np.isfinite(off)
    sub = items[keep]
    cls = sub[by].astype(str).to_numpy() if by else np.full(len(sub), ALL_CLASSES)
    codes, uniques = pd.factorize(pd.MultiIndex.from_arrays([off[keep], cls]), sort=True)
    g = len(uniques)
    key = {"y_offset_m": uniques.get_level_values(0), "label_class": uniques.get_level_values(1)}
    frames = [
        _offset_stats(sub[c].to_numpy(np.float64), codes, g, key, c) for c in columns
    ]
    if not frames:
        return pd.DataFrame(columns=["y_offset_m", "label_class", "column", "n", "mean", "std",
                                     "ci_lo", "ci_hi", "sampling_std"])
    if "gvf" in columns and "n_votes" in sub.columns:
        frames[columns.index("gvf")]["sampling_std"] = _sampling_std(sub, codes, g)
    return pd.concat(frames, ignore_index=True)


def _offset_stats(v, codes, g, key, column):
    ok = np.isfinite(v)
    cc, vv = codes[ok], v[ok]
    n = np.bincount(cc, minlength=g).astype(np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.bincount(cc, weights=vv, minlength=g) / n
        dev = vv - mean[cc]
        std = np.sqrt(np.bincount(cc, weights=dev * dev, minlength=g) / (n - 1))
        std[n < 2] = np.nan
        half = _st.t.ppf(0.975, n - 1) * std / np.sqrt(n)
    return pd.DataFrame({**key, "column": column, "n": n.astype(np.int64), "mean": mean,
                         "std": std, "ci_lo": mean - half, "ci_hi": mean + half,
                         "sampling_std": np.nan})


def encoder_table(summary: pd.DataFrame) -> pd.DataFrame:
    """Paper Table 3: one row per encoder with |PLCC| and |SRCC| of ``nvrq`` and ``nvrq_ca``.

    Empty when the summary has no encoder-family columns (``nvrq:ENC``, ``nvrq_ca:ENC``).

    Parameters
    ----------
    summary : pandas.DataFrame
        The analysis summary (``metric, plcc, srcc``).

    Returns
    -------
    pandas.DataFrame
    """
    rows = {}
    for _, r in summary.iterrows():  # one row per metric column, not per item
        family, enc = split_column(r["metric"])
        if enc is None or family not in ("nvrq", "nvrq_ca"):
            continue
        d = rows.setdefault(enc, {"encoder": enc})
        d[f"{family}_plcc"], d[f"{family}_srcc"], d[f"{family}_n"] = r["plcc"], r["srcc"], r["n"]
    cols = [
        "encoder",
        "nvrq_plcc",
        "nvrq_srcc",
        "nvrq_n",
        "nvrq_ca_plcc",
        "nvrq_ca_srcc",
        "nvrq_ca_n",
    ]
    return pd.DataFrame(list(rows.values()), columns=cols)
