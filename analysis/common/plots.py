"""Report figures (matplotlib, no pyplot state: each function returns a new ``Figure``).

Layer: analysis (report figures).

- :func:`tent_plot` — paper Fig. 3: x = render offset ``y_offset_m``; the human GVF panel
  first (with dashed lines at mean +/- the spread expected from vote sampling alone), then
  one panel per metric; mean +/- 1 std per offset; the y axis of a
  lower-is-better metric is inverted and marked with a down arrow, so "better" is up in
  every panel.
- :func:`speed_accuracy_plot` — pairs/s (log x) against SRCC with the target; Pareto front;
  point labels placed by :func:`place_labels` so that none overlap.
- :func:`roc_plot` — ROC curves of the best metrics against ``majority_good``.
- :func:`target_histogram` — the distribution of GVF (or the target).
"""

from __future__ import annotations

import io
import math
import textwrap
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from matplotlib.ticker import FuncFormatter
from sklearn.metrics import roc_curve

from analysis.common.text import offset_text
from data_schema.perturbation import AXES, AXIS_UNITS, PERTURBATION_COLUMNS

__all__ = [
    "VIEW_AXIS_LABELS",
    "method_colours",
    "direction_label",
    "offset_ticks",
    "panel_grid",
    "tent_plot",
    "speed_accuracy_plot",
    "roc_plot",
    "agreement_plot",
    "target_histogram",
    "pareto_front",
    "place_labels",
    "save_figure",
    "legend_below",
]


#: The x-axis label of each view column, e.g. ``'y (m)'`` for ``y_offset_m``.
#: a point label's measured box grown by this factor when placed (:func:`place_labels`)
TEXT_SLACK = 1.1
VIEW_AXIS_LABELS = {c: f"{a} ({AXIS_UNITS[a]})" for a, c in zip(AXES, PERTURBATION_COLUMNS, strict=True)}


def method_colours(methods) -> dict[str, str]:
    """One colour per method, the same in every figure (the leaderboard's and the pairwise
    study's): the methods sorted by name take ``C0``, ``C1``, ... in turn, so a method keeps
    its colour whatever the order a figure lists them in.

    Parameters
    ----------
    methods : iterable of str
        Method names.

    Returns
    -------
    dict
        Method -> matplotlib colour (``'C0'``, ``'C1'``, ...).

    >>> method_colours(["sharp", "blurry"])
    {'blurry': 'C0', 'sharp': 'C1'}
    """
    return {m: f"C{i % 10}" for i, m in enumerate(sorted(dict.fromkeys(map(str, methods))))}


def direction_label(metric: str, higher_better: bool | None) -> str:
    """An axis label naming the metric and its direction.

    Parameters
    ----------
    metric : str
        The metric's name.
    higher_better : bool or None
        Its direction (``None``: unknown, no arrow).

    Returns
    -------
    str

    >>> direction_label("lpips", False), direction_label("psnr", True)
    ('lpips (lower is better \u2193)', 'psnr (higher is better \u2191)')
    """
    if higher_better is None:
        return metric
    return f"{metric} (higher is better \u2191)" if higher_better else f"{metric} (lower is better \u2193)"


def offset_ticks(ax) -> None:
    """Tick labels of the x axis written as every table writes offsets
    (:func:`analysis.common.text.offset_text`: ``-1``, ``0``, ``+1``).

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The axes, changed in place.
    """
    ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: offset_text(round(v, 6))))


def panel_grid(n: int, *, width: float, height: float) -> tuple[Figure, np.ndarray]:
    """A figure of ``n`` panels, at most four a row, each ``width`` x ``height`` inches:
    ``(fig, axes (n,))``; the unused cells of the last row are removed.

    Parameters
    ----------
    n : int
        Panels.
    width, height : float, inches
        Size of one panel.

    Returns
    -------
    fig : matplotlib.figure.Figure
    axes : (n,) object array of matplotlib.axes.Axes

    >>> fig, axes = panel_grid(5, width=3.0, height=2.0)
    >>> len(axes), len(fig.axes), fig.get_size_inches().tolist()
    (5, 5, [12.0, 4.0])
    """
    ncols = min(4, n)
    nrows = math.ceil(n / ncols)
    fig = Figure(figsize=(width * ncols, height * nrows), layout="constrained")
    axes = fig.subplots(nrows, ncols, squeeze=False).ravel()
    for ax in axes[n:]:
        fig.delaxes(ax)
    return fig, axes[:n]


def legend_below(fig: Figure, ax, *, fontsize: float = 7, width: int = 60, **kw):
    """The legend of ``ax``'s labelled artists, drawn below the axes, outside them and inside
    the figure (the constrained layout makes room for it): it can cover no data and is never
    cut off at the figure's edge. A label longer than ``width`` characters is wrapped.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        A figure with the constrained layout.
    ax : matplotlib.axes.Axes
        The axes whose handles and labels are listed.
    fontsize : float, optional
        Text size in points.
    width : int, optional
        Characters per legend line at most.
    **kw
        More :meth:`matplotlib.figure.Figure.legend` keywords (``title``, ``ncols``).

    Returns
    -------
    matplotlib.legend.Legend or None
        ``None`` when ``ax`` has no labelled artist.
    """
    handles, labels = ax.get_legend_handles_labels()
    if not handles:
        return None
    labels = ["\n".join(textwrap.wrap(t, width)) or t for t in labels]
    return fig.legend(handles, labels, loc="outside lower center", fontsize=fontsize, frameon=False, **kw)


def tent_plot(
    by_offset: pd.DataFrame,
    columns: list[str],
    directions: dict[str, bool],
    *,
    target_label: str = "GVF",
    floor: pd.DataFrame | None = None,
) -> Figure:
    """One panel per entry of ``columns`` (target first, then metrics): mean +/- 1 std per offset;
    with ``floor``, the viewpoint floor (what a perfect render of the same views scores) dashed in
    each metric panel it has.

    by_offset: long table ``y_offset_m, column, n, mean, std`` (see
    :func:`analysis.tables.breakdowns.offset_table`). ``len(fig.axes) == len(columns)``.

    Parameters
    ----------
    by_offset : pandas.DataFrame
        Long table ``y_offset_m, column, n, mean, std``.
    columns : list of str
        Target first, then metrics.
    directions : dict
        Column -> whether higher is better.
    target_label : str, optional
        The target's axis label.
    floor : pandas.DataFrame, optional
        Long table ``y_offset_m, column, mean`` of the viewpoint floor
        (:func:`analysis.common.viewpoint_floor.floor_by_offset`).

    Returns
    -------
    matplotlib.figure.Figure
    """
    from analysis.common.viewpoint_floor import FLOOR_COLOUR

    fig, axes = panel_grid(len(columns), width=3.2, height=2.8)
    if "label_class" in by_offset.columns:
        by_offset = by_offset[by_offset["label_class"] == "all"]
    for i, (ax, col) in enumerate(zip(axes, columns, strict=False)):
        t = by_offset[by_offset["column"] == col].sort_values("y_offset_m")
        x = t["y_offset_m"].to_numpy(float)
        m = t["mean"].to_numpy(float)
        s = np.nan_to_num(t["std"].to_numpy(float))
        color = "black" if i == 0 else f"C{(i - 1) % 10}"
        lo, hi = m - s, m + s
        if i == 0 and np.nanmin(m, initial=0) >= 0 and np.nanmax(m, initial=1) <= 1:
            lo, hi = np.clip(lo, 0, 1), np.clip(hi, 0, 1)  # a share (GVF): the band stays in [0, 1]
        ax.fill_between(x, lo, hi, color=color, alpha=0.2, linewidth=0)
        ax.plot(x, m, "o-", color=color, markersize=3)
        f = floor[floor["column"] == col].sort_values("y_offset_m") if floor is not None and i > 0 else None
        if f is not None and len(f):
            ax.plot(f["y_offset_m"].to_numpy(float), f["mean"].to_numpy(float), "s--", color=FLOOR_COLOUR,
                    linewidth=1.0, markersize=3, label="viewpoint floor (perfect render)")
            ax.legend(fontsize=6, loc="lower center")
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
        if 1 < len(np.unique(x)) <= 11:  # ticks where the data are (yaw at -10, -5, 0, +5, +10)
            ax.set_xticks(np.unique(x))
            offset_ticks(ax)
        ax.set_xlabel("y offset (m)", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
    return fig


def pareto_front(speed: np.ndarray, accuracy: np.ndarray) -> np.ndarray:
    """Indices of the points not dominated in (higher speed, higher accuracy), by speed desc.

    Parameters
    ----------
    speed : (N,) float64
        Pairs per second.
    accuracy : (N,) float64
        E.g. |SRCC|.

    Returns
    -------
    (P,) int64
        Indices of the front, by falling speed.

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
    """Scatter of pairs/s (log x) against |SRCC| for metrics with timings; ``None`` if none.

    Parameters
    ----------
    summary : pandas.DataFrame
        The analysis summary (``metric, srcc``).
    timing : pandas.DataFrame
        The timing table (``metric, pairs_per_s``).
    target_label : str, optional
        The target's name in the axis label.

    Returns
    -------
    matplotlib.figure.Figure or None
    """
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
    front = pareto_front(sp, acc)
    fs = sp[front][::-1]
    fa = acc[front][::-1]
    ax.step(fs, fa, where="pre", color="C3", linestyle="--", label="Pareto front")
    ax.set_xscale("log")
    _log_ticks(ax.xaxis, sp)
    ax.margins(y=0.12)  # room for labels above and below the outermost points
    ax.set_xlabel("speed (pairs/s, log scale)")
    ax.set_ylabel(f"|SRCC| with {target_label}")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3, which="both")
    place_labels(ax, np.column_stack([sp, acc]), variant_labels(t), fontsize=7)
    return fig


def place_labels(ax, points: np.ndarray, texts: list[str], *, fontsize: float = 7,
                 marker_px: float = 5.0, max_rings: int = 16) -> list:
    """Label each point of ``points`` (N, 2) (data coordinates of ``ax``) so that no two
    labels overlap, and none covers a point or the legend or leaves the axes.

    A deterministic repel in display space: the figure is drawn once (its layout is then
    kept), each label is measured with the renderer, and the labels are placed one by one,
    points in order of falling y then rising x, at the first free candidate spot: right of
    the point, then left of it, then one, two, ... label heights above and below
    (``max_rings`` rings). A spot is free when the label overlaps no placed label, no marker
    (``marker_px``: marker radius in pixels), no legend and stays in the axes; among free
    spots the first whose leader line crosses no other label wins. A label placed away from
    its point gets a thin leader line from its nearest edge. Offsets are kept in points, so
    they scale with the saving dpi. When no spot is free the label takes the candidate that
    overlaps least.

    Returns the label :class:`~matplotlib.text.Text` objects, in the order of ``points``
    (leader lines are separate annotations without text).

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The axes the points are drawn in.
    points : (N, 2) float64
        Data coordinates.
    texts : list of str
        One label per point.
    fontsize : float, optional
        Label size, points.
    marker_px : float, optional
        Marker radius, pixels.
    max_rings : int, optional
        Candidate rings above and below a point.

    Returns
    -------
    list of matplotlib.text.Text
        In the order of ``points``.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.transforms import offset_copy

    fig = ax.get_figure()
    canvas = FigureCanvasAgg(fig)
    canvas.draw()  # the constrained layout fixes the axes before anything is measured
    fig.set_layout_engine("none")  # keep that layout: the labels are placed in it
    renderer = canvas.get_renderer()
    xy = ax.transData.transform(np.asarray(points, dtype=np.float64))  # (N, 2) pixels
    area = ax.get_window_extent(renderer)
    sizes = []
    for text in texts:
        probe = ax.annotate(text, (0, 0), xycoords="axes pixels", fontsize=fontsize)
        box = probe.get_window_extent(renderer)
        # room for the text at another dpi: hinted text is up to 8% wider or taller at the
        # saving dpi than at the drawing one (measured 21.0 -> 22.7 px)
        sizes.append((box.width * TEXT_SLACK + 1.0, box.height * TEXT_SLACK))
        probe.remove()
    pad = marker_px + 1.0
    avoid = [np.array([x - pad, y - pad, x + pad, y + pad]) for x, y in xy]  # the markers
    legend = ax.get_legend()
    if legend is not None:
        b = legend.get_window_extent(renderer)
        avoid.append(np.array([b.x0, b.y0, b.x1, b.y1]))
    boxes: dict[int, np.ndarray] = {}
    lines: dict[int, np.ndarray] = {}  # (x0, y0, x1, y1) pixels, point to label edge
    offsets = np.zeros((len(texts), 2))
    for i in np.lexsort((xy[:, 0], -xy[:, 1])):
        w, h = sizes[i]
        best, best_cost = None, (np.inf, np.inf)
        for dx, dy in _candidates(w, h, pad, max_rings):
            box = np.array([xy[i, 0] + dx, xy[i, 1] + dy, xy[i, 0] + dx + w, xy[i, 1] + dy + h])
            line = _leader(xy[i], box, w, h, dx, dy, pad)
            overlap = (sum(_overlap(box, o, 1.0) for o in boxes.values())
                       + sum(_overlap(box, o, 0.0) for o in avoid) + _outside(box, area, 1.0))
            crossings = sum(_crosses(ln, box) for ln in lines.values())
            if line is not None:
                crossings += sum(_crosses(line, o) for o in boxes.values())
            cost = (overlap, crossings)
            if cost < best_cost:
                best, best_cost = (dx, dy, box, line), cost
            if cost == (0.0, 0):
                break
        offsets[i] = best[:2]
        boxes[i] = best[2]
        if best[3] is not None:
            lines[i] = best[3]
    out = []
    to_pt = 72.0 / fig.dpi
    style = {"arrowstyle": "-", "color": "0.5", "lw": 0.6, "shrinkA": 0, "shrinkB": marker_px}
    for i, ((x, y), (dx, dy), text) in enumerate(zip(points, offsets, texts, strict=True)):
        (ax_, ha), (ay_, va) = _anchor(dx, dy, *sizes[i])
        at = offset_copy(ax.transData, fig=fig, x=ax_ * to_pt, y=ay_ * to_pt, units="points")
        out.append(ax.text(x, y, text, transform=at, ha=ha, va=va, fontsize=fontsize))
        if i in lines:
            ex, ey = lines[i][2:] - xy[i]
            ax.annotate("", (x, y), xytext=(ex * to_pt, ey * to_pt), textcoords="offset points",
                        arrowprops=style)
    return out


def _anchor(dx: float, dy: float, w: float, h: float) -> tuple[tuple[float, str], tuple[float, str]]:
    """``((x offset, ha), (y offset, va))`` of a label whose reserved box has its lower-left
    corner at ``(dx, dy)`` from its point: the text is anchored at the box's side nearest the
    point (right edge for a label left of it, top edge for one below it, middle for one
    beside it), so text drawn larger than measured (another dpi) grows away from its point."""
    x = (dx + w, "right") if dx < 0 else (dx, "left")
    if dy + h <= 0:
        y = (dy + h, "top")
    elif dy >= 0:
        y = (dy, "bottom")
    else:
        y = (dy + h / 2, "center")
    return x, y


def _candidates(w: float, h: float, pad: float, rings: int):
    """Offsets (pixels, lower-left corner of the label from its point), nearest first."""
    for k in range(rings + 1):
        for dy in ((-h / 2,) if k == 0 else (-h / 2 + k * (h + 2), -h / 2 - k * (h + 2))):
            yield pad, dy
            yield -pad - w, dy


def _leader(p: np.ndarray, box: np.ndarray, w, h, dx, dy, pad) -> np.ndarray | None:
    """The leader line (x0, y0, x1, y1) from point ``p`` to the nearest point of ``box``, or
    ``None`` when the label sits beside its point (ring 0)."""
    if abs(dy + h / 2) <= h / 2 and (dx == pad or dx == -pad - w):
        return None
    return np.array([p[0], p[1], np.clip(p[0], box[0], box[2]), np.clip(p[1], box[1], box[3])])


def _crosses(line: np.ndarray, box: np.ndarray) -> int:
    """1 when the segment ``line`` (x0, y0, x1, y1) passes through the inside of ``box``
    (Liang-Barsky clipping; touching the edge does not count), else 0."""
    x0, y0, x1, y1 = line
    t0, t1 = 0.0, 1.0
    for p, q in ((-(x1 - x0), x0 - box[0]), (x1 - x0, box[2] - x0),
                 (-(y1 - y0), y0 - box[1]), (y1 - y0, box[3] - y0)):
        if p == 0:
            if q <= 0:
                return 0
            continue
        t = q / p
        if p < 0:
            t0 = max(t0, t)
        else:
            t1 = min(t1, t)
    return int(t1 - t0 > 1e-6)


def _overlap(a: np.ndarray, b: np.ndarray, pad: float) -> float:
    """Overlap area of boxes ``[x0, y0, x1, y1]`` with ``a`` grown by ``pad`` on each side."""
    wx = min(a[2] + pad, b[2]) - max(a[0] - pad, b[0])
    wy = min(a[3] + pad, b[3]) - max(a[1] - pad, b[1])
    return float(wx * wy) if wx > 0 and wy > 0 else 0.0


def _outside(box: np.ndarray, area, pad: float) -> float:
    """Area of ``box`` outside the axes ``area`` shrunk by ``pad``."""
    w, h = box[2] - box[0], box[3] - box[1]
    ix = max(0.0, min(box[2], area.x1 - pad) - max(box[0], area.x0 + pad))
    iy = max(0.0, min(box[3], area.y1 - pad) - max(box[1], area.y0 + pad))
    return float(w * h - ix * iy)


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

    Parameters
    ----------
    items : pandas.DataFrame
        One row per item with the metric columns.
    summary : pandas.DataFrame
        The analysis summary (``metric, roc_auc, higher_better``).
    label : (n_items,) bool
        Binary target.
    top : int, optional
        Metrics drawn.

    Returns
    -------
    matplotlib.figure.Figure or None
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
    fig = Figure(figsize=(4.5, 5.0), layout="constrained")
    ax = fig.subplots()
    ax.set_box_aspect(1)  # a ROC plot is square: both axes are rates on [0, 1]
    curves = []  # [(fpr, tpr, [labels])]: metrics that rank the items alike share one curve
    for _, r in s.iterrows():  # one curve per metric
        x = items[r["metric"]].to_numpy(float)
        ok = np.isfinite(x)
        score = x[ok] if r["higher_better"] else -x[ok]
        fpr, tpr, _ = roc_curve(label[ok], score)
        text = f"{r['metric']} (AUC {r['roc_auc']:.3f})"
        same = [c for c in curves if c[0].shape == fpr.shape and np.array_equal(c[0], fpr)
                and np.array_equal(c[1], tpr)]
        (same[0][2].append(text) if same else curves.append((fpr, tpr, [text])))
    for i, (fpr, tpr, texts) in enumerate(curves):
        label_ = texts[0] if len(texts) == 1 else " = ".join(texts) + " (identical curves)"
        ax.plot(fpr, tpr, color=f"C{i}", label=label_)
    ax.plot([0, 1], [0, 1], color="0.6", linestyle=":")
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 1)
    ax.set_xlabel("false positive rate")
    ax.set_ylabel("true positive rate")
    legend_below(fig, ax)
    return fig


def target_histogram(items: pd.DataFrame, target: str, *, label: str = "GVF") -> Figure:
    """Histogram of the per-item target (GVF: bins of width 0.1 on [0, 1]).

    Parameters
    ----------
    items : pandas.DataFrame
        One row per item.
    target : str
        The target column.
    label : str, optional
        Its axis label.

    Returns
    -------
    matplotlib.figure.Figure
    """
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
    """Write ``name.png`` and ``name.svg`` into ``directory``; returns the PNG bytes.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure.
    directory : str or Path
        An existing folder.
    name : str
        File stem.

    Returns
    -------
    bytes
        The PNG.
    """
    d = Path(directory)
    buf = io.BytesIO()
    with warnings.catch_warnings():
        # matplotlib warns when placing a loc="best" legend takes over a second of wall clock;
        # the demos' legends take 3 ms at most, so the warning only means the process stalled
        # (a loaded machine), and the placement it computes is the same either way
        warnings.filterwarnings("ignore", message='Creating legend with loc="best" can be slow',
                                category=UserWarning)
        fig.savefig(buf, format="png", dpi=120, metadata={"Software": None})
        fig.savefig(d / f"{name}.svg", format="svg", metadata={"Date": None})
    png = buf.getvalue()
    (d / f"{name}.png").write_bytes(png)
    return png


def agreement_plot(summary: pd.DataFrame, *, target_label: str = "GVF"):
    """Table 1 as a figure: pooled and within-view |SRCC| per row of the summary (metrics and
    view-only baselines), with their bootstrap intervals; ``None`` without within-view values.

    Parameters
    ----------
    summary : pandas.DataFrame
        The analysis summary with ``metric, srcc, within_srcc`` (and their ``_ci_lo/_hi``).
    target_label : str, optional
        What the metrics are compared with, for the axis label.

    Returns
    -------
    matplotlib.figure.Figure or None
    """
    if summary.empty or "within_srcc" not in summary.columns:
        return None
    s = summary[np.isfinite(summary["srcc"].astype(float))]
    if s.empty:
        return None
    y = np.arange(len(s))
    fig = Figure(figsize=(6.0, 0.9 + 0.35 * len(s)), layout="constrained")
    ax = fig.subplots()
    for k, (col, off, name) in enumerate((("srcc", -0.18, "pooled"), ("within_srcc", 0.18, "within views"))):
        v = s[col].to_numpy(float)
        lo = s.get(f"{col}_ci_lo", pd.Series(np.nan, index=s.index)).to_numpy(float)
        hi = s.get(f"{col}_ci_hi", pd.Series(np.nan, index=s.index)).to_numpy(float)
        ax.barh(y + off, np.nan_to_num(v), height=0.34, color=f"C{k}", label=name)
        ok = np.isfinite(lo) & np.isfinite(hi) & np.isfinite(v)
        ax.errorbar(v[ok], y[ok] + off, xerr=[v[ok] - lo[ok], hi[ok] - v[ok]], fmt="none",
                    ecolor="0.2", capsize=2, linewidth=0.8)
    ax.set_yticks(y, s["metric"].tolist(), fontsize=7)
    ax.invert_yaxis()
    ax.set_xlim(0, 1)
    ax.set_xlabel(f"|SRCC| with {target_label} (within views: empty for the view-only rows)")
    legend_below(fig, ax, ncols=2)
    return fig
