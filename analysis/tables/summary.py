"""The per-metric table (docs/FORMATS.md §6): correlations, ROC AUC, logistic PLCC, bootstrap CIs,
the best metric and which differences from it are significant.

Columns of the returned table (one row per metric):

``metric, higher_better, n, plcc, srcc, roc_auc, krcc, plcc_logistic`` (absolute values, as
the paper reports), ``plcc_signed, srcc_signed, krcc_signed`` (signed, metric as given),
``{plcc,srcc,roc_auc}_ci_lo/_hi`` (95% percentile intervals of a seeded cluster bootstrap
over tracks), ``best`` (the metric with the highest ``rank_by`` value), ``diff_ci_lo/_hi``
and ``p_vs_best`` (paired bootstrap of best minus this metric), ``significant_vs_best`` (the
interval excludes 0), ``reason`` (why any value is empty) and ``note``.

``roc_auc`` scores the binary label (``majority_good`` for GVF; a 0/1 target otherwise) by the
metric, negated when lower is better, so 0.5 is chance and 1 is perfect for every metric.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from tqdm import tqdm

from analysis.common.choices import RANK_BY  # one definition of analyze's choices
from analysis.options import SummaryOptions
from analysis.stats import bootstrap as bs
from analysis.stats import stats
from data_schema.errors import check_choice
from data_schema.options import options_or_keywords

__all__ = ["RANK_BY", "summary_table", "binary_label"]



def binary_label(items: pd.DataFrame, target: str) -> tuple[np.ndarray | None, str | None]:
    """The label ROC AUC is computed against: ``majority_good`` for GVF, ``model_good`` for
    an aggregated ``p_good``, else a 0/1 target.

    Returns ``(label (n,) bool or None, reason)``.

    Parameters
    ----------
    items : pandas.DataFrame
        One row per item, with ``target`` (and ``majority_good`` / ``model_good`` for the
        ``gvf`` / ``p_good`` targets).
    target : str
        The target column.

    Returns
    -------
    label : (n,) bool numpy.ndarray or None
        The binary label, or None when the target is not binary.
    reason : str or None
        Why there is no label, else None.
    """
    if target == "gvf":
        return items["majority_good"].to_numpy(bool), None
    if target == "p_good":  # a crowd-kit posterior: its 0.5 threshold
        return items["model_good"].to_numpy(bool), None
    y = items[target].to_numpy(np.float64)
    finite = y[np.isfinite(y)]
    if finite.size and np.isin(finite, (0.0, 1.0)).all():
        return y == 1.0, None
    return None, f"target {target!r} is not binary"


def _join(*parts) -> str | None:
    s = "; ".join(p for p in parts if p)
    return s or None


def summary_table(items: pd.DataFrame, metrics: list[str], directions: dict[str, bool],
                  options: SummaryOptions | None = None, *, clusters: np.ndarray | None = None,
                  **keywords) -> pd.DataFrame:
    """One row per metric of ``items`` (one row per item) against the ``target`` column.

    Parameters
    ----------
    items : pandas.DataFrame
        One row per item: the metric columns and ``target``.
    metrics : list of str
        The metric columns.
    directions : dict of str to bool
        True where higher is better.
    options : analysis.options.SummaryOptions, optional
        The target column (GVF by default), bootstrap replicates and seed, the statistic that
        ranks (``rank_by``, one of :data:`RANK_BY`) and the progress bar.
    clusters : numpy.ndarray, optional
        (n_items,) int track index for the bootstrap (``None`` or ``n_boot == 0``: no
        bootstrap, CI columns empty).
    **keywords
        Deprecated spelling, kept for earlier callers: the fields of
        :class:`~analysis.options.SummaryOptions` as keywords. Not together with ``options``.

    Returns
    -------
    pandas.DataFrame
        One row per metric (docs/FORMATS.md §6, ``summary.csv``).

    Raises
    ------
    InputError
        ``rank_by`` is not one of :data:`RANK_BY`.
    """
    o = options_or_keywords(SummaryOptions, options, keywords, who="summary_table")
    target, n_boot, seed = o.target, o.n_boot, o.seed
    check_choice("rank_by", o.rank_by, RANK_BY)
    y_all = items[target].to_numpy(np.float64)
    label_all, label_why = binary_label(items, target)
    do_boot = clusters is not None and n_boot > 0
    counts = _draw_counts(clusters, n_boot, seed=seed) if do_boot else None
    rows, reps, y_rank_cache = [], {}, {}
    for m in tqdm(metrics, desc="metrics", unit="metric", disable=not o.progress):
        hb = directions[m]
        x_all = items[m].to_numpy(np.float64)
        ok = np.isfinite(x_all) & np.isfinite(y_all)
        x, y = (x_all, y_all) if ok.all() else (x_all[ok], y_all[ok])
        label = None if label_all is None else label_all[ok]
        ry = _y_ranks(y, all_rows=bool(ok.all()), cache=y_rank_cache)
        row, why, skip_boot = _point_row(
            m, x, y, ry, hb=hb, label=label, label_why=label_why, seed=seed
        )
        row["n"] = int(ok.sum())
        if counts is not None and not skip_boot:
            xo = x if hb else -x  # oriented: higher = better
            reps[m] = _bootstrap_cis(row, why, xo, y, label, clusters[ok], counts)
        elif do_boot and counts is None:
            why.append("CIs: no tracks to resample")
        row["reason"] = _join(*why)
        rows.append(row)
    table = pd.DataFrame(rows, columns=_COLUMNS[:-5] + ["reason", "note"])
    out = _mark_best(table, reps, rank_by=o.rank_by)
    out.attrs["srcc_replicates"] = {
        m: r["srcc"] for m, r in reps.items()
    }  # analysis.stats.noninferiority
    return out


def _draw_counts(clusters: np.ndarray, n_boot: int, *, seed: int) -> np.ndarray | None:
    """Bootstrap draw counts per track, or ``None`` when there are no tracks."""
    n_clusters = int(clusters.max()) + 1 if len(clusters) else 0
    return bs.draw_cluster_counts(n_clusters, n_boot, seed=seed) if n_clusters else None


def _y_ranks(y: np.ndarray, *, all_rows: bool, cache: dict) -> np.ndarray:
    """Average ranks of the target; computed once when every row is finite."""
    if not all_rows:
        return stats.rank_within(y)
    if "all" not in cache:
        cache["all"] = stats.rank_within(y)
    return cache["all"]


def _point_row(m, x, y, ry, *, hb, label, label_why, seed) -> tuple[dict, list, bool]:
    """Point estimates of one metric: the row (without n/reason), its reasons, skip-bootstrap."""
    xo = x if hb else -x  # oriented: higher = better
    p, p_why = stats.pearson(x, y)
    rx = stats.rank_within(x)  # ranks computed once per column, reused below
    s, s_why = stats.pearson(rx, ry)  # Spearman = Pearson of average ranks
    k, k_why = stats.kendall(x, y)
    lg, lg_why, lg_note = stats.logistic_plcc(x, y, seed=seed)
    if label is None:
        auc, auc_why = float("nan"), label_why
    else:
        r_xo = rx if hb else (x.shape[0] + 1.0) - rx  # ranks of -x
        auc, auc_why = stats.roc_auc(label, xo, ranks=r_xo)
    row = {
        "metric": m,
        "higher_better": hb,
        "n": 0,
        "plcc": abs(p),
        "srcc": abs(s),
        "roc_auc": auc,
        "krcc": abs(k),
        "plcc_logistic": lg,
        "plcc_signed": p,
        "srcc_signed": s,
        "krcc_signed": k,
    }
    why = [
        f"plcc, srcc, krcc: {p_why or s_why or k_why}" if (p_why or s_why or k_why) else None,
        f"roc_auc: {auc_why}" if auc_why else None,
        f"plcc_logistic: {lg_why}" if lg_why and lg_why != (p_why or s_why) else None,
    ]
    for name in RANK_BY:
        row[f"{name}_ci_lo"] = row[f"{name}_ci_hi"] = np.nan
    row["note"] = lg_note
    return row, why, bool(p_why and s_why)


def _bootstrap_cis(row: dict, why: list, xo, y, label, clusters, counts) -> dict:
    """Fill the CI columns of ``row`` from cluster-bootstrap replicates; return the replicates."""
    r = bs.replicate_stats(xo, y, label, clusters, counts)
    r = {"plcc": np.abs(r["plcc"]), "srcc": np.abs(r["srcc"]), "roc_auc": r["roc_auc"]}
    for name in RANK_BY:
        if np.isnan(row[name]):
            continue
        lo, hi, ci_why = bs.percentile_ci(r[name])
        row[f"{name}_ci_lo"], row[f"{name}_ci_hi"] = lo, hi
        if ci_why:
            why.append(f"{name} CI: {ci_why}")
    return r


_COLUMNS = [
    "metric",
    "higher_better",
    "n",
    "plcc",
    "srcc",
    "roc_auc",
    "krcc",
    "plcc_logistic",
    "plcc_signed",
    "srcc_signed",
    "krcc_signed",
    "plcc_ci_lo",
    "plcc_ci_hi",
    "srcc_ci_lo",
    "srcc_ci_hi",
    "roc_auc_ci_lo",
    "roc_auc_ci_hi",
    "best",
    "diff_ci_lo",
    "diff_ci_hi",
    "p_vs_best",
    "significant_vs_best",
]


def _mark_best(table: pd.DataFrame, reps: dict, *, rank_by: str) -> pd.DataFrame:
    table["best"] = False
    for c in ("diff_ci_lo", "diff_ci_hi", "p_vs_best"):
        table[c] = np.nan
    table["significant_vs_best"] = pd.array([pd.NA] * len(table), dtype="boolean")
    vals = table[rank_by].to_numpy(np.float64)
    if len(table) == 0 or not np.isfinite(vals).any():
        return table[_COLUMNS + ["reason", "note"]]
    ib = int(np.nanargmax(vals))
    table.loc[ib, "best"] = True
    best = table.loc[ib, "metric"]
    if best in reps:
        for i, m in enumerate(table["metric"]):
            if m == best or m not in reps:
                continue
            lo, hi, pv = bs.paired_difference(reps[best][rank_by], reps[m][rank_by])
            table.loc[i, ["diff_ci_lo", "diff_ci_hi", "p_vs_best"]] = [lo, hi, pv]
            if np.isfinite(lo):
                table.loc[i, "significant_vs_best"] = bool(lo > 0 or hi < 0)
    return table[_COLUMNS + ["reason", "note"]]
