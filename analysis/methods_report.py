"""The leaderboard section of the report (``analyze ... --compare-methods``, docs/FORMATS.md
§11): its tables as text, its sentences and its figures (:mod:`analysis.methods` computes
them).

- :func:`leaderboard_display`: the leaderboard as strings (mean with its interval, and
  "better than the next" with the Holm-corrected paired p-value);
- :func:`paired_display`: the paired comparisons of the ranking metric, one row per pair of
  methods and view;
- :func:`methods_tent_plot`: one panel per metric, one line per method (mean and 95% interval
  per offset; "better" is up in every panel, as in :func:`analysis.plots.tent_plot`);
- :func:`method_class_heatmap`: the ranking metric's mean per method and object class.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from analysis import plots
from analysis.methods import ALPHA, MethodsResult
from analysis.plots import VIEW_AXIS_LABELS
from analysis.text import fmt, interval_text
from data_schema.perturbation import PERTURBATION_COLUMNS

__all__ = ["context", "leaderboard_display", "paired_display", "leaderboard_text", "methods_tent_plot",
           "method_class_heatmap", "method_figures"]

def _p(p) -> str:
    if p is None or not np.isfinite(p):
        return ""
    return f"p={p:.3g}" if p < 0.001 else f"p={p:.3f}"


def leaderboard_display(res: MethodsResult) -> pd.DataFrame:
    """The leaderboard as strings: rank, method, n, mean [95% CI], median, vs the next."""
    rows = []
    for r in res.leaderboard.itertuples():
        mean = interval_text(r.mean, r.ci_lo, r.ci_hi)
        vs = ""
        if isinstance(r.next, str):
            p = _p(r.p_holm_vs_next)
            if r.better_than_next is None or (isinstance(r.better_than_next, float)
                                              and math.isnan(r.better_than_next)):
                vs = f"vs {r.next}: undefined"
            elif r.better_than_next:
                vs = f"better than {r.next} ({p}, Holm)"
            else:
                vs = f"not significantly better than {r.next} ({p}, Holm)"
        rows.append({"rank": str(r.rank), "method": r.method, "n": str(r.n),
                     res.rank_metric: mean, "median": fmt(r.median), "vs next": vs})
    return pd.DataFrame(rows, columns=["rank", "method", "n", res.rank_metric, "median", "vs next"])


def paired_display(res: MethodsResult, metric: str | None = None) -> pd.DataFrame:
    """Paired comparisons of ``metric`` (default: the ranking metric) as strings."""
    metric = metric or res.rank_metric
    t = res.paired[res.paired["metric"] == metric]
    rows = []
    for r in t.itertuples():
        names = {"a": r.method_a, "b": r.method_b}
        view = "all" if r.axis == "all" else f"{VIEW_AXIS_LABELS.get(r.axis, r.axis)} = {r.offset:g}"
        diff = interval_text(r.mean_diff, r.ci_lo, r.ci_hi, digits=4)
        verdict = ("" if r.better is None else
                   f"{names[r.better]} better" if r.better in names else
                   "neither (no significant difference)")
        rows.append({"a vs b": f"{r.method_a} vs {r.method_b}", "view": view, "n": str(r.n),
                     "mean a - b": diff, "p (Holm)": _p(r.p_holm),
                     "a wins": fmt(r.win_rate, 2), "ties": fmt(r.tie_rate, 2), "result": verdict,
                     "left out (a only / b only)": f"{r.n_only_a} / {r.n_only_b}"})
    return pd.DataFrame(rows)


def leaderboard_text(res: MethodsResult) -> str:
    """How to read the leaderboard (one paragraph)."""
    hb = res.directions[res.rank_metric]
    n_cmp = int(np.isfinite(res.paired["p"].to_numpy(np.float64)).sum())
    text = (f"Methods ranked by their mean {res.rank_metric} over all their objects "
            f"({'higher' if hb else 'lower'} is better). ")
    if res.n_boot:
        text += (f"Brackets: 95% intervals of a cluster bootstrap over tracks (clip_id, track_id), "
                 f"{res.n_boot} replicates. \"Better than the next\": the paired comparison on the "
                 f"objects both methods scored (same clip, camera, track, timestamp and view), "
                 f"two-sided bootstrap p-value Holm-corrected over all {n_cmp} comparisons of "
                 f"methods_paired.csv, below {ALPHA}. A view where the interval of the difference "
                 f"includes 0 is reported as a tie (\"neither\"), never as a win.")
    else:
        text += "No bootstrap (--bootstrap 0): no intervals and no significance."
    return text


def methods_tent_plot(table: pd.DataFrame, metrics: list[str], directions: dict[str, bool],
                      methods: list[str], *, axis: str = "y_offset_m") -> Figure:
    """One panel per metric: per method, the mean (line) and its 95% interval (band) along
    ``axis`` (rows of methods.csv with ``breakdown == axis``). ``len(fig.axes) == len(metrics)``."""
    fig, axes = plots.panel_grid(len(metrics), width=3.4, height=2.9)
    t = table[table["breakdown"] == axis]
    for ax, metric in zip(axes, metrics, strict=False):
        for k, m in enumerate(methods):
            s = t[(t["metric"] == metric) & (t["method"] == m)]
            x = s["group"].astype(float).to_numpy()
            order = np.argsort(x)
            x = x[order]
            mean = s["mean"].to_numpy(float)[order]
            ax.plot(x, mean, "o-", color=f"C{k % 10}", markersize=3, label=m)
            lo, hi = s["ci_lo"].to_numpy(float)[order], s["ci_hi"].to_numpy(float)[order]
            if np.isfinite(lo).any():
                ax.fill_between(x, lo, hi, color=f"C{k % 10}", alpha=0.2, linewidth=0)
        title = metric
        if directions.get(metric) is False:
            ax.invert_yaxis()
            title += " \u2193 (lower is better)"
        ax.set_title(title, fontsize=9)
        ax.set_xlabel(VIEW_AXIS_LABELS.get(axis, axis), fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7, title="method", title_fontsize=7)
    return fig


def method_class_heatmap(table: pd.DataFrame, metric: str, methods: list[str], *,
                         higher_better: bool) -> Figure | None:
    """Mean ``metric`` per method (rows, leaderboard order) and object class (columns), each
    cell annotated with its value and n; the colour scale runs from worse to better."""
    t = table[(table["breakdown"] == "label_class") & (table["metric"] == metric)]
    if t.empty:
        return None
    classes = sorted(t["group"].unique())
    mean = t.pivot(index="method", columns="group", values="mean").reindex(index=methods, columns=classes)
    n = t.pivot(index="method", columns="group", values="n").reindex(index=methods, columns=classes)
    fig = Figure(figsize=(1.3 + 1.2 * len(classes), 0.9 + 0.5 * len(methods)), layout="constrained")
    ax = fig.subplots()
    v = mean.to_numpy(float)
    im = ax.imshow(v, cmap="viridis" if higher_better else "viridis_r", aspect="auto")
    for i in range(v.shape[0]):  # one label per cell (methods x classes)
        for j in range(v.shape[1]):
            if np.isfinite(v[i, j]):
                light = im.norm(v[i, j]) > 0.6 if higher_better else im.norm(v[i, j]) < 0.4
                ax.text(j, i, f"{v[i, j]:.3g}\nn={int(n.iat[i, j])}", ha="center", va="center",
                        fontsize=7, color="black" if light else "white")
    ax.set_xticks(range(len(classes)), classes, fontsize=8, rotation=30, ha="right")
    ax.set_yticks(range(len(methods)), methods, fontsize=8)
    cb = fig.colorbar(im, ax=ax)
    cb.set_label(f"mean {metric}" + ("" if higher_better else " (lower is better)"), fontsize=8)
    ax.set_title(f"{metric} by method and class", fontsize=9)
    return fig


def method_figures(res: MethodsResult) -> list[tuple[str, str, object]]:
    """``(name, title, figure)`` of the leaderboard: a tent plot per view axis, the heatmap."""
    out = []
    for axis in dict.fromkeys(res.table["breakdown"]):
        if axis in PERTURBATION_COLUMNS:
            name = "methods_tent" if axis == "y_offset_m" else f"methods_tent_{axis}"
            out.append((name, f"Methods along {VIEW_AXIS_LABELS[axis]}: mean and 95% interval per method",
                        methods_tent_plot(res.table, res.metrics, res.directions, res.methods, axis=axis)))
    heat = method_class_heatmap(res.table, res.rank_metric, res.methods,
                                higher_better=res.directions[res.rank_metric])
    if heat is not None:
        out.append(("methods_by_class", f"{res.rank_metric} by method and class", heat))
    return out


def context(res: MethodsResult | None, table) -> dict:
    """The report templates' leaderboard section; ``table`` renders a DataFrame (HTML or
    Markdown). Empty strings without ``--compare-methods`` (``res`` None)."""
    if res is None:
        return {"leaderboard_table": "", "leaderboard_text": "", "leaderboard_paired": "",
                "leaderboard_notes": [], "rank_metric": ""}
    return {"leaderboard_table": table(leaderboard_display(res)),
            "leaderboard_text": leaderboard_text(res),
            "leaderboard_paired": table(paired_display(res)),
            "leaderboard_notes": res.notes, "rank_metric": res.rank_metric}
