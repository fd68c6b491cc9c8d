"""Breakdowns: per category (paper Table 2), per offset (Fig. 3), per encoder (Table 3).

All grouped statistics are columnar: one argsort per metric column, reused by every
grouping; group sums by ``np.bincount``. Undefined groups follow the rule of
:mod:`analysis.stats` (empty value + ``reason``).

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
from tqdm import tqdm

from analysis import stats
from nvrq.metrics import split_column

__all__ = ["category_table", "offset_table", "encoder_table", "MISSING_GROUP"]

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


def _clips_per_group(codes, n_groups, clip_codes_all, ok):
    """(G,) number of distinct clips per group (``ok``: row mask or None for all rows)."""
    if clip_codes_all is None or len(codes) == 0:
        return np.zeros(n_groups, dtype=np.int64)
    cc = clip_codes_all if ok is None else clip_codes_all[ok]
    n_clips = int(cc.max()) + 1
    present = np.zeros(n_groups * n_clips, dtype=bool)
    present[codes * n_clips + cc] = True
    return present.reshape(n_groups, n_clips).sum(axis=1)


def offset_table(
    items: pd.DataFrame, columns: list[str], *, offset_col: str = "y_offset_m"
) -> pd.DataFrame:
    """Long table ``y_offset_m, column, n, mean, std`` (sample std, ddof=1; NaN for n = 1).

    Only finite values count; rows without an offset are left out.
    """
    off = items[offset_col].to_numpy(np.float64)
    keep = np.isfinite(off)
    codes, uniques = pd.factorize(off[keep], sort=True)
    g = len(uniques)
    frames = []
    for c in columns:
        v = items[c].to_numpy(np.float64)[keep]
        ok = np.isfinite(v)
        cc, vv = codes[ok], v[ok]
        n = np.bincount(cc, minlength=g).astype(np.float64)
        with np.errstate(invalid="ignore", divide="ignore"):
            mean = np.bincount(cc, weights=vv, minlength=g) / n
            dev = vv - mean[cc]
            std = np.sqrt(np.bincount(cc, weights=dev * dev, minlength=g) / (n - 1))
        std[n < 2] = np.nan
        frames.append(
            pd.DataFrame(
                {
                    "y_offset_m": uniques,
                    "column": c,
                    "n": n.astype(np.int64),
                    "mean": mean,
                    "std": std,
                }
            )
        )
    if not frames:
        return pd.DataFrame(columns=["y_offset_m", "column", "n", "mean", "std"])
    return pd.concat(frames, ignore_index=True)


def encoder_table(summary: pd.DataFrame) -> pd.DataFrame:
    """Paper Table 3: one row per encoder with |PLCC| and |SRCC| of ``nvrq`` and ``nvrq_ca``.

    Empty when the summary has no encoder-family columns (``nvrq:ENC``, ``nvrq_ca:ENC``).
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
