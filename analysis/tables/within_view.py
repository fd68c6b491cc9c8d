"""Within-view agreement: what a metric says beyond the view, and the view-only baseline.

Layer: analysis (statistics of votes and metrics).

Off the recorded path, a metric's score falls with the change of view whatever the render.
A pooled correlation then mixes "the metric sees the render" with "the metric sees the
offset". This module separates them:

- **within-view** statistics (:func:`within_view_columns`): PLCC, SRCC and ROC AUC computed
  inside every view cell (one perturbation ``(dx, dy, dz, roll, pitch, yaw)``, i.e. one
  offset of a lateral study), then pooled over the cells. PLCC and SRCC are pooled as the
  n-weighted mean of Fisher ``z = arctanh(r)``, back-transformed with ``tanh``; AUC as the
  n-weighted mean. A cell enters when it holds at least :data:`MIN_CELL_PAIRS` items from at
  least :data:`MIN_CELL_TRACKS` tracks and the statistic is defined there (the rule of
  :func:`analysis.stats.stats.undefined_reason`); the other cells are skipped and counted. A cell's
  ``|r| = 1`` is clipped to :data:`R_CLIP` before ``arctanh`` (an exact ``r = 1`` has infinite
  z; this is the only change made to a value). Intervals are the 95% percentiles of the same
  seeded cluster bootstrap over tracks as the pooled values (the same draws, so differences
  are paired): in each replicate every eligible cell's statistic is recomputed on the drawn
  items and pooled with the drawn cell sizes as weights.
- the **view-only** baseline (:func:`view_only_rows`): the score ``view_only = -|distance of the
  view from the recorded pose|`` along each axis, ranked like a metric. It is constant inside
  a view cell, so its within-view values are undefined by construction.
- :func:`visibility_table`: pooled and within-view SRCC per ``gt_visible`` x ``novel_visible``
  bin, when the pairs carry the visibility columns.
- :func:`headline`: the sentence at the top of the report.

Worked example: two cells with r = 0.5 (n = 10) and r = 0 (n = 30) pool to
``tanh((10 * arctanh(0.5) + 30 * 0) / 40) = tanh(0.1373) = 0.1365``.

>>> round(pool_fisher(np.array([0.5, 0.0]), np.array([10.0, 30.0])), 4)
0.1365
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from analysis.stats import bootstrap as bs
from analysis.stats import stats
from data_schema.perturbation import AXES, perturbation_array

__all__ = ["MIN_CELL_PAIRS", "MIN_CELL_TRACKS", "R_CLIP", "VIS_BINS", "WITHIN_COLUMNS",
           "view_cells", "pool_fisher", "within_view_stats", "within_view_columns",
           "view_only_columns", "view_only_rows", "visibility_table", "headline", "extend_summary", "ViewInputs"]

#: A view cell enters the within-view statistics with at least this many items ...
MIN_CELL_PAIRS = 10
#: ... from at least this many tracks.
MIN_CELL_TRACKS = 5
#: ``|r|`` of one cell is clipped to this before Fisher's z (r = +-1 has infinite z).
R_CLIP = 1.0 - 1e-9
#: Bin edges of ``gt_visible`` and ``novel_visible`` for :func:`visibility_table`.
VIS_BINS = (0.0, 0.5, 0.8, 1.0)

_STATS = ("plcc", "srcc", "roc_auc")
#: Columns added to the summary table (docs/FORMATS.md §6).
WITHIN_COLUMNS = (
    [f"within_{s}" for s in _STATS]
    + [f"within_{s}_ci_{e}" for s in _STATS for e in ("lo", "hi")]
    + ["within_cells", "within_cells_skipped"]
)


def view_cells(items: pd.DataFrame) -> tuple[np.ndarray, int]:
    """Each item's view cell: ``(codes (N,) int, number of cells)``, one cell per distinct
    perturbation (absent perturbation columns read as 0).

    >>> view_cells(pd.DataFrame({"y_offset_m": [1.0, 0.0, 1.0]}))[0].tolist()
    [1, 0, 1]
    """
    P = perturbation_array(items)
    if len(P) == 0:
        return np.zeros(0, dtype=np.int64), 0
    _, codes = np.unique(P, axis=0, return_inverse=True)
    codes = codes.reshape(-1)
    return codes, int(codes.max()) + 1


def pool_fisher(r: np.ndarray, n: np.ndarray) -> float:
    """n-weighted mean of Fisher z of the correlations r (k,), back-transformed (NaN if k = 0)."""
    ok = np.isfinite(r) & (n > 0)
    if not ok.any():
        return float("nan")
    z = np.arctanh(np.clip(r[ok], -R_CLIP, R_CLIP))
    return float(np.tanh((n[ok] * z).sum() / n[ok].sum()))


def _pool_mean(v: np.ndarray, n: np.ndarray) -> float:
    ok = np.isfinite(v) & (n > 0)
    return float((n[ok] * v[ok]).sum() / n[ok].sum()) if ok.any() else float("nan")


def _eligible(cells, clusters, n_cells):
    """Per cell: item indices, and whether it holds enough items from enough tracks."""
    order = np.argsort(cells, kind="stable")
    bounds = np.searchsorted(cells[order], np.arange(n_cells + 1))
    out = []
    for c in range(n_cells):
        idx = order[bounds[c]:bounds[c + 1]]
        big = idx.shape[0] >= MIN_CELL_PAIRS and np.unique(clusters[idx]).shape[0] >= MIN_CELL_TRACKS
        out.append((idx, big))
    return out


def within_view_stats(xo, y, label, cells, clusters, *, counts=None) -> dict:
    """Within-view PLCC, SRCC (signed) and ROC AUC of ``xo`` against ``y``, with replicates.

    Parameters
    ----------
    xo : (n,) float64
        Metric values, finite, oriented so that higher is better.
    y : (n,) float64
        Target values, finite.
    label : (n,) bool or None
        The AUC's binary label (None: no AUC).
    cells : (n,) int
        View cell of each item (:func:`view_cells`).
    clusters : (n,) int
        Track of each item, a column of ``counts``.
    counts : (B, K) int32 or None
        Bootstrap draws (:func:`analysis.stats.bootstrap.draw_cluster_counts`); None: no replicates.

    Returns
    -------
    dict
        ``plcc``, ``srcc``, ``roc_auc`` (floats, NaN when no cell is usable), ``cells`` (cells
        used by the SRCC), ``skipped`` (cells skipped for the SRCC) and ``replicates``:
        name -> (B,) float64 (absent without ``counts``).
    """
    n_cells = int(cells.max()) + 1 if cells.shape[0] else 0
    per = {s: ([], []) for s in _STATS}  # statistic -> (values, n) of the used cells
    used_idx = {s: [] for s in _STATS}
    for idx, big in _eligible(cells, clusters, n_cells):
        if not big:
            continue
        xc, yc = xo[idx], y[idx]
        vals = {"plcc": stats.pearson(xc, yc)[0], "srcc": stats.spearman(xc, yc)[0]}
        if label is not None:
            vals["roc_auc"] = stats.roc_auc(label[idx], xc)[0]
        for s, v in vals.items():
            if np.isfinite(v):
                per[s][0].append(v)
                per[s][1].append(float(idx.shape[0]))
                used_idx[s].append(idx)
    out = {}
    for s in _STATS:
        v, n = np.array(per[s][0]), np.array(per[s][1])
        out[s] = _pool_mean(v, n) if s == "roc_auc" else pool_fisher(v, n)
    out["cells"] = len(per["srcc"][0])
    out["skipped"] = n_cells - out["cells"]
    if counts is not None:
        out["replicates"] = _replicates(xo, y, label, clusters, counts, used_idx)
    return out


def _replicates(xo, y, label, clusters, counts, used_idx) -> dict:
    """Per statistic, (B,) pooled replicates over the cells the point estimate used."""
    B = counts.shape[0]
    reps = {}
    for s in _STATS:
        idxs = used_idx[s]
        if not idxs:
            reps[s] = np.full(B, np.nan)
            continue
        num, den = np.zeros(B), np.zeros(B)
        for idx in idxs:
            lab = None if label is None else label[idx]
            r = bs.replicate_stats(xo[idx], y[idx], lab, clusters[idx], counts)[s]
            w = counts[:, clusters[idx]].sum(axis=1).astype(np.float64)
            ok = np.isfinite(r)
            v = r if s == "roc_auc" else np.arctanh(np.clip(r, -R_CLIP, R_CLIP))
            num[ok] += (w * v)[ok]
            den[ok] += w[ok]
        with np.errstate(invalid="ignore", divide="ignore"):
            m = num / den
        reps[s] = m if s == "roc_auc" else np.tanh(m)
        reps[s][den == 0] = np.nan
    return reps


def within_view_columns(summary: pd.DataFrame, items: pd.DataFrame, directions: dict, *,
                        target: str, label, clusters, n_boot: int, seed: int) -> pd.DataFrame:
    """``summary`` with the :data:`WITHIN_COLUMNS` of each of its metrics.

    ``within_plcc`` and ``within_srcc`` are absolute values (as ``plcc``/``srcc``); the CIs use
    the seeded cluster bootstrap of :func:`analysis.tables.summary.summary_table` (same seed, same
    draws). ``label`` is the (n_items,) AUC label or None.
    """
    out = summary.copy()
    for c in WITHIN_COLUMNS:
        out[c] = np.nan
    if len(out) == 0:
        return out
    cells, _ = view_cells(items)
    y_all = items[target].to_numpy(np.float64)
    counts = None
    if n_boot > 0 and clusters is not None and len(clusters):
        counts = bs.draw_cluster_counts(int(clusters.max()) + 1, n_boot, seed=seed)
    for i, m in enumerate(out["metric"]):
        if m not in items.columns:
            continue
        x_all = items[m].to_numpy(np.float64)
        ok = np.isfinite(x_all) & np.isfinite(y_all)
        xo = x_all[ok] if directions.get(m, True) else -x_all[ok]
        lab = None if label is None else np.asarray(label)[ok]
        cl = clusters[ok] if clusters is not None else np.arange(int(ok.sum()))
        r = within_view_stats(xo, y_all[ok], lab, cells[ok], cl, counts=counts)
        for s in _STATS:
            val = r[s] if s == "roc_auc" else abs(r[s])
            out.loc[out.index[i], f"within_{s}"] = val
            if "replicates" in r:
                rep = r["replicates"][s] if s == "roc_auc" else np.abs(r["replicates"][s])
                lo, hi, _ = bs.percentile_ci(rep)
                out.loc[out.index[i], [f"within_{s}_ci_lo", f"within_{s}_ci_hi"]] = [lo, hi]
        out.loc[out.index[i], ["within_cells", "within_cells_skipped"]] = [r["cells"], r["skipped"]]
    return out


def view_only_columns(items: pd.DataFrame) -> dict[str, np.ndarray]:
    """The view-only scores, one per axis that some item moves along: name -> (N,) float64.

    ``view_only = -|component|`` along the axis (metres or degrees); the name is
    ``view_only`` when the items move along one axis only, else ``view_only:AXIS``.

    >>> view_only_columns(pd.DataFrame({"y_offset_m": [0.0, -2.0, 1.0]}))["view_only"].tolist()
    [-0.0, -2.0, -1.0]
    """
    P = perturbation_array(items)
    moved = [k for k, a in enumerate(AXES) if len(P) and (P[:, k] != 0).any()]
    if not moved:
        return {}
    if len(moved) == 1:
        return {"view_only": -np.abs(P[:, moved[0]])}
    return {f"view_only:{AXES[k]}": -np.abs(P[:, k]) for k in moved}


def view_only_rows(items: pd.DataFrame, summarize) -> tuple[pd.DataFrame, dict]:
    """The view-only baseline rows of the summary, and their SRCC bootstrap replicates.

    ``summarize(frame, metrics, directions)`` is the caller's summary function (the same
    options and clusters as the metrics' table), so the rows are computed exactly like a
    metric's and their replicates are paired with the metrics'.
    """
    cols = view_only_columns(items)
    if not cols:
        return pd.DataFrame(), {}
    frame = items.assign(**cols)
    rows = summarize(frame, list(cols), {c: True for c in cols})
    rows["best"] = False
    rows["diff_ci_lo"] = rows["diff_ci_hi"] = rows["p_vs_best"] = np.nan
    rows["significant_vs_best"] = pd.array([pd.NA] * len(rows), dtype="boolean")
    # a score with one value per view is a step: the logistic's fit on it is ill-posed (its
    # stopping point moved in the last digit from run to run), so the rows give none
    if "plcc_logistic" in rows:
        rows["plcc_logistic"] = np.nan
    rows["note"] = ("baseline: -|distance of the view from the recorded pose| (no logistic fit: "
                    "one value per view)")
    return rows, dict(rows.attrs.get("srcc_replicates", {}))


def _bin_labels():
    e = VIS_BINS
    return [f"[{e[i]:g}, {e[i + 1]:g}" + (")" if i < len(e) - 2 else "]") for i in range(len(e) - 1)]


def visibility_table(items: pd.DataFrame, metrics: list[str], directions: dict, *,
                     target: str, clusters) -> tuple[pd.DataFrame | None, str | None]:
    """Per ``gt_visible`` x ``novel_visible`` bin (:data:`VIS_BINS`) and metric: ``n``, pooled
    ``srcc`` and ``within_srcc`` (absolute values, no interval).

    Returns ``(table or None, reason it is skipped or None)``.
    """
    need = [c for c in ("gt_visible", "novel_visible") if c not in items.columns]
    if need:
        return None, ("visibility breakdown skipped: the pairs have no "
                      + " or ".join(need) + " column (nvrq pairs computes them)")
    labels = _bin_labels()
    g = pd.cut(items["gt_visible"].astype(float), VIS_BINS, labels=labels, include_lowest=True,
               right=False)
    nv = pd.cut(items["novel_visible"].astype(float), VIS_BINS, labels=labels, include_lowest=True,
                right=False)
    # the last bin is closed on the right: right=False leaves exactly 1.0 out
    top = labels[-1]
    g = g.astype(object).where(items["gt_visible"].astype(float) < 1.0, top)
    nv = nv.astype(object).where(items["novel_visible"].astype(float) < 1.0, top)
    cells, _ = view_cells(items)
    y_all = items[target].to_numpy(np.float64)
    cl_all = clusters if clusters is not None else np.arange(len(items))
    rows = []
    for gb in labels:
        for nb in labels:
            sel = ((g == gb) & (nv == nb)).to_numpy(bool)
            for m in metrics:
                x = items[m].to_numpy(np.float64)
                ok = sel & np.isfinite(x) & np.isfinite(y_all)
                xo = x[ok] if directions.get(m, True) else -x[ok]
                s, _ = stats.spearman(xo, y_all[ok]) if ok.sum() else (float("nan"), None)
                w = within_view_stats(xo, y_all[ok], None, cells[ok], cl_all[ok]) if ok.sum() else {
                    "srcc": float("nan")}
                rows.append({"gt_visible": gb, "novel_visible": nb, "metric": m, "n": int(ok.sum()),
                             "srcc": abs(s), "within_srcc": abs(w["srcc"])})
    return pd.DataFrame(rows, columns=["gt_visible", "novel_visible", "metric", "n", "srcc",
                                       "within_srcc"]), None


def headline(summary: pd.DataFrame, view_rows: pd.DataFrame, reps: dict, view_reps: dict, *,
             rank_by: str = "srcc") -> str | None:
    """One sentence: the metrics whose pooled agreement does not beat the view-only baseline
    beyond its interval, and the metric that leads within views (None without a baseline).

    With bootstrap replicates, "beats" means the 95% paired interval of metric minus the
    strongest view-only row lies above 0; without them, the point estimate is larger.
    """
    if view_rows is None or len(view_rows) == 0 or len(summary) == 0:
        return None
    stat = rank_by if rank_by in ("plcc", "srcc", "roc_auc") else "srcc"
    vr = view_rows.reset_index(drop=True)
    vals = vr[stat].to_numpy(np.float64)
    if not np.isfinite(vals).any():
        return None
    j = int(np.nanargmax(vals))
    vname, vval = vr.loc[j, "metric"], vals[j]
    paired = stat == "srcc" and vname in view_reps
    not_beat = []
    for _, r in summary.iterrows():
        m = r["metric"]
        if not np.isfinite(r[stat]):
            continue
        if paired and m in reps:
            lo, _, _ = bs.paired_difference(np.asarray(reps[m]), np.asarray(view_reps[vname]))
            beats = np.isfinite(lo) and lo > 0
        else:
            beats = r[stat] > vval
        if not beats:
            not_beat.append(m)
    how = "beyond the 95% paired bootstrap interval" if paired else "(point estimates; no bootstrap)"
    s = f"View-only baseline {vname}: {stat.upper()} {vval:.3f}. "
    s += (f"Pooled {stat.upper()} does not beat it {how} for: {', '.join(not_beat)}. " if not_beat
          else f"Every metric's pooled {stat.upper()} beats it {how}. ")
    ws = summary["within_srcc"].to_numpy(np.float64) if "within_srcc" in summary else np.array([])
    if ws.size and np.isfinite(ws).any():
        k = int(np.nanargmax(ws))
        r = summary.iloc[k]
        ci = ""
        if np.isfinite(r.get("within_srcc_ci_lo", np.nan)):
            ci = f" [{r['within_srcc_ci_lo']:.3f}, {r['within_srcc_ci_hi']:.3f}]"
        s += (f"Within views, {r['metric']} leads (within-view SRCC {r['within_srcc']:.3f}{ci}, "
              f"{int(r['within_cells'])} view cells; cells under {MIN_CELL_PAIRS} items or "
              f"{MIN_CELL_TRACKS} tracks skipped: {int(r['within_cells_skipped'])}).")
    else:
        s += (f"No metric has a within-view SRCC (every view cell is under {MIN_CELL_PAIRS} items "
              f"or {MIN_CELL_TRACKS} tracks, or constant).")
    return s


@dataclass(frozen=True)
class ViewInputs:
    """What :func:`extend_summary` computes against: the ``target`` column, the AUC ``label``
    ((n_items,) bool or None), the track ``clusters`` ((n_items,) int) and the bootstrap
    (``n_boot`` replicates, ``seed``; the summary's own, so the draws are the same)."""

    target: str
    label: np.ndarray | None
    clusters: np.ndarray | None
    n_boot: int = 0
    seed: int = 0


def extend_summary(summary: pd.DataFrame, items: pd.DataFrame, directions: dict,
                   inputs: ViewInputs, *, rank_by: str, summarize):
    """The summary with the within-view columns and the view-only rows appended (last), the
    headline sentence, the visibility table and a note when it is skipped.

    ``summarize(frame, metrics, directions)`` computes rows like ``summary``'s (the caller's
    options and clusters). Returns ``(summary, headline or None, visibility or None, note or
    None)``.
    """
    target, clusters = inputs.target, inputs.clusters
    kw = dict(target=target, label=inputs.label, clusters=clusters, n_boot=inputs.n_boot,
              seed=inputs.seed)
    out = within_view_columns(summary, items, directions, **kw)
    reps = dict(summary.attrs.get("srcc_replicates", {}))
    view_rows, view_reps = view_only_rows(items, summarize)
    if len(view_rows):
        view_rows = within_view_columns(view_rows, items.assign(**view_only_columns(items)),
                                        {c: True for c in view_rows["metric"]}, **kw)
    text = headline(out, view_rows, reps, view_reps, rank_by=rank_by)
    metrics = [m for m in out["metric"] if m in items.columns]
    vis, vis_note = visibility_table(items, metrics, directions, target=target, clusters=clusters)
    if len(view_rows):
        attrs = dict(out.attrs)
        out = pd.concat([out, view_rows[out.columns.intersection(view_rows.columns)]],
                        ignore_index=True)[list(out.columns)]
        out.attrs.update(attrs)
    return out, text, vis, vis_note
