"""Report figures (matplotlib, no pyplot state: each function returns a new ``Figure``).

- :func:`tent_plot` — paper Fig. 3: x = render offset ``y_offset_m``; the human GVF panel
  first (with dashed lines at mean +/- the spread expected from vote sampling alone), then
  one panel per metric; mean +/- 1 std per offset; the y axis of a
  lower-is-better metric is inverted and marked with a down arrow, so "better" is up in
  every panel.
- :func:`speed_accuracy_plot` — pairs/s (log x) against SRCC with the target; Pareto front.
- :func:`roc_plot` — ROC curves of the best metrics against ``majority_good``.
- :func:`target_histogram` — the distribution of GVF (or the target).
"""

from __future__ import annotations

import io
import math
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from sklearn.metrics import roc_curve

__all__ = [
    "tent_plot",
    "speed_accuracy_plot",
    "roc_plot",
    "target_histogram",
    "pareto_front",
    "save_figure",
]


def tent_plot(
    by_offset: pd.DataFrame,
    columns: list[str],
    directions: dict[str, bool],
    *,
    target_label: str = "GVF",
) -> Figure:
    """One panel per entry of ``columns`` (target first, then metrics): mean +/- 1 std per offset.

    by_offset: long table ``y_offset_m, column, n, mean, std`` (see
    :func:`analysis.breakdowns.offset_table`). ``len(fig.axes) == len(columns)``.
    """
    n = len(columns)
    ncols = min(4, n)
    nrows = math.ceil(n / ncols)
    fig = Figure(figsize=(3.2 * ncols, 2.8 * nrows), layout="constrained")
    axes = fig.subplots(nrows, ncols, squeeze=False).ravel()
    for ax in axes[n:]:
        fig.delaxes(ax)
    if "label_class" in by_offset.columns:
        by_offset = by_offset[by_offset["label_class"] == "all"]
    for i, (ax, col) in enumerate(zip(axes, columns, strict=False)):
        t = by_offset[by_offset["column"] == col].sort_values("y_offset_m")
        x = t["y_offset_m"].to_numpy(float)
        m = t["mean"].to_numpy(float)
        s = np.nan_to_num(t["std"].to_numpy(float))
        color = "black" if i == 0 else f"C{(i - 1) % 10}"
        ax.fill_between(x, m - s, m + s, color=color, alpha=0.2, linewidth=0)
        ax.plot(x, m, "o-", color=color, markersize=3)
        if i == 0 and "sampling_std" in t.columns and t["sampling_std"].notna().any():
            ss = t["sampling_std"].to_numpy(float)
            ax.plot(x, m + ss, "--", color="0.4", linewidth=0.8, label="sampling alone")
            ax.plot(x, m - ss, "--", color="0.4", linewidth=0.8)
            ax.legend(fontsize=6, loc="lower center")
        lower = i > 0 and directions.get(col) is False
        title = target_label if i == 0 else col
        if lower:
            ax.invert_yaxis()
            ax.annotate(
                "",
                xy=(0.04, 0.08),
                xytext=(0.04, 0.32),
                xycoords="axes fraction",
                arrowprops={"arrowstyle": "->", "color": "0.3"},
            )
            title += " \u2193 (lower is better)"
        ax.set_title(title, fontsize=9)
        ax.set_xlabel("y offset (m)", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
    return fig


def pareto_front(speed: np.ndarray, accuracy: np.ndarray) -> np.ndarray:
    """Indices of the points not dominated in (higher speed, higher accuracy), by speed desc.

    >>> pareto_front(np.array([1.0, 10.0, 100.0, 5.0]), np.array([0.9, 0.8, 0.5, 0.7])).tolist()
    [2, 1, 0]
    """
    order = np.argsort(-speed, kind="stable")
    best = -np.inf
    keep = []
    for i in order:  # one entry per metric, not per row
        if accuracy[i] > best:
            keep.append(int(i))
            best = accuracy[i]
    return np.array(keep, dtype=np.intp)


def speed_accuracy_plot(summary: pd.DataFrame, timing: pd.DataFrame, *, target_label: str = "GVF"):
    """Scatter of pairs/s (log x) against |SRCC| for metrics with timings; ``None`` if none."""
    if summary.empty:
        return None
    t = summary.merge(timing, on="metric", how="inner")
    t = t[np.isfinite(t["pairs_per_s"]) & (t["pairs_per_s"] > 0) & np.isfinite(t["srcc"])]
    if t.empty:
        return None
    fig = Figure(figsize=(5.5, 4), layout="constrained")
    ax = fig.subplots()
    sp, acc = t["pairs_per_s"].to_numpy(float), t["srcc"].to_numpy(float)
    ax.scatter(sp, acc, color="C0", zorder=3)
    placed: dict[tuple[float, float], int] = {}  # metrics at one point get stacked labels
    for s, a, name in zip(sp, acc, variant_labels(t), strict=True):
        key = (round(float(np.log10(s)), 2), round(float(a), 3))
        n = placed[key] = placed.get(key, -1) + 1
        ax.annotate(name, (s, a), textcoords="offset points", xytext=(4, 3 - 9 * n), fontsize=7)
    front = pareto_front(sp, acc)
    fs = sp[front][::-1]
    fa = acc[front][::-1]
    ax.step(fs, fa, where="pre", color="C3", linestyle="--", label="Pareto front")
    ax.set_xscale("log")
    _log_ticks(ax.xaxis, sp)
    ax.set_xlabel("speed (pairs/s, log scale)")
    ax.set_ylabel(f"|SRCC| with {target_label}")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3, which="both")
    return fig


def variant_labels(timing: pd.DataFrame) -> list[str]:
    """Point labels: the metric, plus ``[runtime precision]`` where the timing records one,
    so each runtime/precision variant of an encoder reads as its own point.

    >>> variant_labels(pd.DataFrame({"metric": ["psnr", "nvrq:e"], "runtime": ["", "openvino"],
    ...                              "precision": ["", "int8"]}))
    ['psnr', 'nvrq:e [openvino int8]']
    """
    out = []
    for _, r in timing.iterrows():
        parts = [str(r[c]) for c in ("runtime", "precision")
                 if c in timing.columns and isinstance(r[c], str) and r[c]]
        out.append(f"{r['metric']} [{' '.join(parts)}]" if parts else str(r["metric"]))
    return out


def _log_ticks(axis, values: np.ndarray) -> None:
    """Readable log-axis ticks: labels at 1-2-5 x 10^k only when the data span less than two
    decades, else at powers of ten; minor ticks unlabelled (they overlapped before)."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    span = np.log10(values.max() / values.min()) if len(values) and values.min() > 0 else 0.0
    subs = (1.0, 2.0, 5.0) if span < 2 else (1.0,)
    axis.set_major_locator(LogLocator(base=10, subs=subs, numticks=12))
    axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    axis.set_minor_formatter(NullFormatter())


def roc_plot(items: pd.DataFrame, summary: pd.DataFrame, label: np.ndarray, *, top: int = 3):
    """ROC curves of the ``top`` metrics by ROC AUC; ``None`` if no AUC is defined.

    label: (n_items,) bool; scores are negated for lower-is-better metrics.
    """
    if summary.empty:
        return None
    s = (
        summary[np.isfinite(summary["roc_auc"].astype(float))]
        .sort_values("roc_auc", ascending=False)
        .head(top)
    )
    if s.empty:
        return None
    fig = Figure(figsize=(4.5, 4.2), layout="constrained")
    ax = fig.subplots()
    for _, r in s.iterrows():  # one curve per metric
        x = items[r["metric"]].to_numpy(float)
        ok = np.isfinite(x)
        score = x[ok] if r["higher_better"] else -x[ok]
        fpr, tpr, _ = roc_curve(label[ok], score)
        ax.plot(fpr, tpr, label=f"{r['metric']} (AUC {r['roc_auc']:.3f})")
    ax.plot([0, 1], [0, 1], color="0.6", linestyle=":")
    ax.set_xlabel("false positive rate")
    ax.set_ylabel("true positive rate")
    ax.legend(fontsize=7, loc="lower right")
    return fig


def target_histogram(items: pd.DataFrame, target: str, *, label: str = "GVF") -> Figure:
    """Histogram of the per-item target (GVF: bins of width 0.1 on [0, 1])."""
    v = items[target].to_numpy(float)
    v = v[np.isfinite(v)]
    fig = Figure(figsize=(4.5, 3.2), layout="constrained")
    ax = fig.subplots()
    bins = np.linspace(0, 1, 11) if target == "gvf" else 30
    ax.hist(v, bins=bins, color="0.4", edgecolor="white")
    ax.set_xlabel(label)
    ax.set_ylabel("items")
    return fig


def save_figure(fig: Figure, directory, name: str) -> bytes:
    """Write ``name.png`` and ``name.svg`` into ``directory``; returns the PNG bytes."""
    d = Path(directory)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=120, metadata={"Software": None})
    png = buf.getvalue()
    (d / f"{name}.png").write_bytes(png)
    fig.savefig(d / f"{name}.svg", format="svg", metadata={"Date": None})
    return png
