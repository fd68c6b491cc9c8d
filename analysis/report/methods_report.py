"""The leaderboard section of the report (``analyze ... --compare-methods``, docs/FORMATS.md
§11): its tables as text, its sentences and its figures (:mod:`analysis.methods` computes
them).

Layer: analysis (method leaderboard report).

- :func:`leaderboard_display`: the leaderboard as strings (mean with its interval, tracks, and
  "better than the next" with the Holm-corrected paired p-value and the smallest p-value its
  test can give);
- :func:`paired_display`: the paired comparisons of the ranking metric, one row per pair of
  methods and view;
- :func:`class_offset_display`: the paired difference per class and offset (with ``by`` =
  ``class,offset``), the table of "which method is better, on which objects, how far off";
- :func:`methods_tent_plot`: one panel per metric, one line per method (mean and 95% interval
  per offset; "better" is up in every panel, as in :func:`analysis.common.plots.tent_plot`);
- :func:`method_class_heatmap`: the ranking metric's mean per method and object class;
- :func:`class_offset_heatmap`: the paired difference per class and offset.

Every method keeps one colour (:func:`analysis.common.plots.method_colours`); every count of objects
comes with its count of tracks; views read as :func:`view_text`.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from analysis.common import plots
from analysis.common.plots import VIEW_AXIS_LABELS, direction_label, method_colours
from analysis.common.text import fmt, interval_text, offset_text
from analysis.common.viewpoint_floor import FLOOR_COLOUR, floor_label, is_reference
from analysis.methods import ALPHA, MethodsResult
from analysis.report.off_path import off_path_display, off_path_figure
from analysis.stats.signflip import EXACT_MAX_TRACKS
from data_schema.perturbation import AXES, AXIS_UNITS, PERTURBATION_COLUMNS

__all__ = ["context", "view_text", "p_text", "leaderboard_display", "paired_display",
           "class_offset_display", "leaderboard_text", "methods_tent_plot", "method_class_heatmap",
           "class_offset_heatmap", "method_figures", "headline_lines"]

_AXIS_OF = dict(zip(PERTURBATION_COLUMNS, AXES, strict=True))


def view_text(axis: str, offset) -> str:
    """A view of methods_paired.csv as text: ``'off-path'``, ``'on-path'`` or e.g. ``'y = +3 m'``.

    Parameters
    ----------
    axis : str
        A perturbation column name, ``'on-path'`` or ``'off-path'``.
    offset : float
        The value along it, metres or degrees.

    Returns
    -------
    str

    >>> view_text("y_offset_m", 3.0), view_text("yaw_deg", -5.0), view_text("off-path", float("nan"))
    ('y = +3 m', 'yaw = -5 deg', 'off-path')
    """
    if axis not in _AXIS_OF:
        return str(axis)
    a = _AXIS_OF[axis]
    return f"{a} = {offset_text(offset)} {AXIS_UNITS[a]}"


def _g(v: float) -> str:
    return f"{v:.2g}" if v < 0.01 else f"{v:.3f}"


def p_text(p, floor, test, *, raw=None) -> str:
    """A p-value as text, saying when it sits at the floor of its test. ``raw``: the p-value
    before Holm when ``p`` is Holm's (else ``p`` is raw). A Monte Carlo p at its floor
    ``1 / (B + 1)`` reads ``p < floor`` (the test could not resolve less), and Holm's version
    of it ``p ≤ ...`` (a bound scaled by Holm); an exact p at its floor ``2 / 2^n`` is that
    exact value, marked as the smallest n tracks allow.

    Parameters
    ----------
    p : float
        The p-value (Holm-adjusted when ``raw`` is given).
    floor : float
        The smallest p its test can give.
    test : str or None
        ``{'monte-carlo', 'exact'}``.
    raw : float, optional
        The p-value before Holm.

    Returns
    -------
    str
        ``''`` when ``p`` is NaN.

    >>> p_text(0.0004, 0.0004, "monte-carlo"), p_text(0.0128, 0.0004, "monte-carlo", raw=0.0004)
    ('p < 0.0004', 'p ≤ 0.013')
    >>> p_text(0.0625, 0.0625, "exact"), p_text(0.3, 0.002, "exact"), p_text(float("nan"), 0.1, None)
    ('p = 0.062 (the smallest possible)', 'p = 0.300', '')
    """
    if p is None or not np.isfinite(p):
        return ""
    r = p if raw is None else raw
    at_floor = floor is not None and np.isfinite(floor) and r <= floor * (1 + 1e-9)
    if test == "monte-carlo" and at_floor:
        return f"p < {_g(floor)}" if raw is None else f"p ≤ {_g(p)}"
    return f"p = {_g(p)}" + (" (the smallest possible)" if at_floor and raw is None else "")


def _vs_next(r, paired: pd.DataFrame) -> str:
    """"Better than the next" of leaderboard row ``r``: the verdict, the Holm p-value (``≤``
    when the test's own p sat at its Monte Carlo floor) and the smallest p its test allows."""
    if not isinstance(r.next, str):
        return ""
    if r.better_than_next is None or (isinstance(r.better_than_next, float) and np.isnan(r.better_than_next)):
        return f"vs {r.next}: undefined"
    row = paired[(paired["axis"] == r.view) & (paired["by"] == "") & (paired["metric"] == r.metric)
                 & paired["method_a"].isin([r.method, r.next]) & paired["method_b"].isin([r.method, r.next])]
    raw, test = (row["p"].iloc[0], row["p_test"].iloc[0]) if len(row) else (r.p_holm_vs_next, None)
    p = p_text(r.p_holm_vs_next, r.p_floor_vs_next, test, raw=raw)
    floor = f"; smallest possible p {_g(r.p_floor_vs_next)}" if np.isfinite(r.p_floor_vs_next) else ""
    verdict = "better than" if r.better_than_next else "not significantly better than"
    return f"{verdict} {r.next} ({p}, Holm{floor})"


def leaderboard_display(res: MethodsResult) -> pd.DataFrame:
    """The leaderboard as strings: rank, method, n (tracks), mean [95% CI], median, vs the next.

    Parameters
    ----------
    res : MethodsResult
        Its ``leaderboard`` gives the rows, its ``paired`` table the "vs next" p-values.

    Returns
    -------
    pandas.DataFrame
        One row per method in rank order; the mean's column is named after the ranking metric.
    """
    head = f"{res.rank_metric} ({res.rank_view})"
    rows = [{"rank": str(r.rank), "method": r.method, "n (tracks)": f"{r.n} ({r.n_tracks})",
             head: interval_text(r.mean, r.ci_lo, r.ci_hi), "median": fmt(r.median),
             "vs next": _vs_next(r, res.paired)}
            for r in res.leaderboard.itertuples()]
    return pd.DataFrame(rows, columns=["rank", "method", "n (tracks)", head, "median", "vs next"])


def _verdict(r) -> str:
    if not isinstance(r.better, str):
        return r.reason if isinstance(r.reason, str) else ""
    return f"{r.better} better" if r.better != "neither" else "neither (no significant difference)"


def paired_display(res: MethodsResult, metric: str | None = None) -> pd.DataFrame:
    """Paired comparisons of ``metric`` (default: the ranking metric) per view, as strings.

    Parameters
    ----------
    res : MethodsResult
        Its ``paired`` rows without a ``by`` breakdown are shown.
    metric : str, optional
        The metric compared; ``None`` takes ``res.rank_metric``.

    Returns
    -------
    pandas.DataFrame
        One row per pair of methods and view, every cell a string.
    """
    metric = metric or res.rank_metric
    t = res.paired[(res.paired["metric"] == metric) & (res.paired["by"] == "")]
    rows = []
    for r in t.itertuples():
        rows.append({"a vs b": f"{r.method_a} vs {r.method_b}", "view": view_text(r.axis, r.offset),
                     "n (tracks)": f"{r.n} ({r.n_tracks})",
                     "mean a - b": interval_text(r.mean_diff, r.ci_lo, r.ci_hi, digits=4),
                     "p (Holm)": p_text(r.p_holm, r.p_floor, r.p_test, raw=r.p),
                     f"{r.method_a} wins": fmt(r.win_rate, 2), "ties": fmt(r.tie_rate, 2),
                     "result": _verdict(r),
                     "left out (a only / b only)": f"{r.n_only_a} / {r.n_only_b}"})
    return pd.DataFrame(rows)


def _diff_text(v: float, scale: float) -> str:
    """A signed difference with 3 significant digits of ``scale`` (the largest |difference|).

    >>> _diff_text(5.75e-05, 0.16), _diff_text(0.0798, 0.16), _diff_text(-4.43, 6.0)
    ('+0.000', '+0.080', '-4.43')
    """
    d = max(0, 2 - int(np.floor(np.log10(scale)))) if np.isfinite(scale) and scale > 0 else 3
    return f"{v:+.{d}f}"


def _class_offset_rows(res: MethodsResult, metric: str) -> pd.DataFrame:
    """The paired rows of ``metric`` per class and view along the first axis (``by`` =
    ``label_class,view``), empty without them."""
    p = res.paired[(res.paired["metric"] == metric) & (res.paired["by"] == "label_class,view")]
    if p.empty:
        return p
    return p[p["axis"] == p["axis"].iloc[0]]


def class_offset_display(res: MethodsResult, metric: str | None = None) -> pd.DataFrame:
    """``metric``'s paired difference per class (rows) and offset (columns), each pair of
    methods in turn: ``mean_diff`` and the verdict (the better method, ``-`` for neither, or
    the count of tracks when too few for a test). Empty without ``by = class,offset``.

    Parameters
    ----------
    res : MethodsResult
        A comparison made with ``by = class,offset`` (any other gives an empty table).
    metric : str, optional
        Whose paired difference fills the cells; by default ``res.rank_metric``.

    Returns
    -------
    pandas.DataFrame
        Columns ``a - b``, ``class`` and one per offset; a row per pair of methods and class.
    """
    metric = metric or res.rank_metric
    t = _class_offset_rows(res, metric)
    if t.empty:
        return pd.DataFrame()
    offsets = sorted(t["offset"].unique())
    scale = float(np.nanmax(np.abs(t["mean_diff"].to_numpy(float))))
    rows = []
    for (a, b, cls), g in t.groupby(["method_a", "method_b", "group"], sort=False):
        row = {"a - b": f"{a} - {b}", "class": cls}
        for r in g.itertuples():
            mark = (r.better if r.better != "neither" else "-") if isinstance(r.better, str) \
                else f"{r.n_tracks} track{'s' if r.n_tracks != 1 else ''}"
            row[view_text(r.axis, r.offset)] = f"{_diff_text(r.mean_diff, scale)} ({mark})"
        rows.append(row)
    cols = ["a - b", "class", *[view_text(t["axis"].iloc[0], o) for o in offsets]]
    return pd.DataFrame(rows).reindex(columns=cols).fillna("")


def leaderboard_text(res: MethodsResult) -> str:
    """How to read the leaderboard (one paragraph).

    Parameters
    ----------
    res : MethodsResult
        Gives the ranking metric and view, its direction and the bootstrap settings.

    Returns
    -------
    str
        The paragraph, naming the intervals' and p-values' tests when ``res.n_boot`` > 0.
    """
    hb = res.directions[res.rank_metric]
    text = (f"Methods ranked by their mean {res.rank_metric} over their {res.rank_view} objects "
            f"({'the recorded view' if res.rank_view == 'on-path' else 'every view but the recorded one'}; "
            f"{'higher' if hb else 'lower'} is better). n (tracks): objects and the tracks they come from. ")
    if res.n_boot:
        text += (f"Brackets: 95% intervals of a cluster bootstrap over tracks (clip_id, track_id), "
                 f"{res.n_boot} replicates, given only where a group has at least {res.min_clusters} "
                 f"tracks. \"Better than the next\": the paired comparison on the objects both methods "
                 f"scored (same clip, camera, track, timestamp and view); its p-value is a two-sided "
                 f"sign-flip test over tracks (exact up to {EXACT_MAX_TRACKS} tracks, else Monte Carlo with "
                 f"{res.n_boot} sign patterns), Holm-corrected over the rows of methods_paired.csv "
                 f"without a by (a --by breakdown is a family of its own), below {ALPHA}, and its "
                 f"interval excludes 0. The smallest "
                 f"p-value n tracks allow is 2/2^n (1/({res.n_boot}+1) by Monte Carlo): "
                 f"\"p <\" marks a p-value at that floor.")
    else:
        text += "No bootstrap (--bootstrap 0): no intervals and no significance."
    return text


def headline_lines(res: MethodsResult) -> list[str]:
    """One line per headline number of the leaderboard page: what it is, over which objects,
    and what a pooled number pools.

    Parameters
    ----------
    res : MethodsResult
        The comparison (its ranking metric and view, its metrics, the score-sets table).

    Returns
    -------
    list of str
        Full sentences, the ranking metric's first.
    """
    pooled = ("every view but the recorded one pooled: each object at each non-zero offset counts once"
              if res.rank_view == "off-path" else "the recorded view only")
    lines = [f"{res.rank_metric} ({res.rank_view}) in the leaderboard: per method, the mean over its "
             f"objects of the {res.rank_view} views ({pooled}), with a bootstrap interval over tracks."]
    if "nta_iou" in res.metrics:
        lines.append("nta_iou: the IoU of the detector's box with the object's projected box on the "
                     "method's render (0 where it is missed); the off-path row of the paired comparisons "
                     "pools every box at every non-zero offset, the off-path table gives it per offset.")
    for m in (m for m in res.metrics if m.startswith("psnr")):
        lines.append(f"{m}: the PSNR of the render crop against the ground-truth crop, in dB, per object.")
    if res.sets is not None and len(res.sets):
        lines.append("fd and kid (off-path table): Frechet and kernel inception distances between the set "
                     "of renders and the set of ground-truth images of one method and offset, on whole "
                     "frames and on object crops; one number per set, not per object.")
    return lines


def _counts(t: pd.DataFrame, m: str) -> str:
    """``'n=80, 10 tracks'`` of method ``m``'s off-path rows (else any)."""
    s = t[(t["method"] == m) & (t["breakdown"] == "off-path")]
    s = s if len(s) else t[t["method"] == m]
    if s.empty:
        return ""
    return f"n={int(s['n'].iloc[0])}, {int(s['n_tracks'].iloc[0])} tracks"


def methods_tent_plot(table: pd.DataFrame, metrics: list[str], directions: dict[str, bool],
                      methods: list[str], *, axis: str = "y_offset_m") -> Figure:
    """One panel per metric: per method, the mean (line) and its 95% interval (band) along
    ``axis`` (rows of methods.csv with ``breakdown == axis``); the y axis names the metric and
    its direction, the legend each method's objects and tracks. ``len(fig.axes) == len(metrics)``.
    A reference method (``perfect``, ``floor``: :mod:`analysis.common.viewpoint_floor`) is the viewpoint
    floor: a dashed grey line without a band, named so in the legend.

    Parameters
    ----------
    table : pandas.DataFrame
        methods.csv rows.
    metrics : list of str
        One panel each.
    directions : dict
        Metric -> whether higher is better.
    methods : list of str
        Methods, leaderboard order.
    axis : str, optional
        The view axis column.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, axes = plots.panel_grid(len(metrics), width=3.6, height=3.0)
    t = table[table["breakdown"] == axis]
    colours = method_colours(methods)
    for ax, metric in zip(axes, metrics, strict=False):
        for m in methods:
            s = t[(t["metric"] == metric) & (t["method"] == m)]
            x = s["group"].astype(float).to_numpy()
            order = np.argsort(x)
            x = x[order]
            mean = s["mean"].to_numpy(float)[order]
            floor = is_reference(m)  # the viewpoint floor: a dashed line, no band
            ax.plot(x, mean, "s--" if floor else "o-", color=FLOOR_COLOUR if floor else colours[m], markersize=3,
                    linewidth=1.0 if floor else 1.5,
                    label=f"{floor_label(m)} ({_counts(table[table['metric'] == metric], m)})")
            lo, hi = s["ci_lo"].to_numpy(float)[order], s["ci_hi"].to_numpy(float)[order]
            if np.isfinite(lo).any() and not floor:
                ax.fill_between(x, lo, hi, color=colours[m], alpha=0.2, linewidth=0)
        if directions.get(metric) is False:
            ax.invert_yaxis()
        ax.set_title(metric, fontsize=9)
        ax.set_ylabel(direction_label(metric, directions.get(metric)), fontsize=8)
        ax.set_xlabel(VIEW_AXIS_LABELS.get(axis, axis), fontsize=8)
        plots.offset_ticks(ax)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=6, title="method (off-path objects)", title_fontsize=6)
    return fig


def method_class_heatmap(table: pd.DataFrame, metric: str, methods: list[str], *,
                         higher_better: bool) -> Figure | None:
    """Mean ``metric`` per method (rows, leaderboard order) and object class (columns), each
    cell annotated with its value, n and tracks; the colour scale runs from worse to better.

    Parameters
    ----------
    table : pandas.DataFrame
        methods.csv rows.
    metric : str
        The metric shown.
    methods : list of str
        Methods, leaderboard order.
    higher_better : bool
        The metric's direction.

    Returns
    -------
    matplotlib.figure.Figure or None
    """
    t = table[(table["breakdown"] == "label_class") & (table["metric"] == metric)]
    if t.empty:
        return None
    classes = sorted(t["group"].unique())
    piv = {c: t.pivot(index="method", columns="group", values=c).reindex(index=methods, columns=classes)
           for c in ("mean", "n", "n_tracks")}
    fig = Figure(figsize=(2.4 + 1.3 * len(classes), max(2.6, 1.2 + 0.55 * len(methods))), layout="constrained")
    ax = fig.subplots()
    v = piv["mean"].to_numpy(float)
    im = ax.imshow(v, cmap="viridis" if higher_better else "viridis_r", aspect="auto")
    for i in range(v.shape[0]):  # one label per cell (methods x classes)
        for j in range(v.shape[1]):
            if np.isfinite(v[i, j]):
                light = im.norm(v[i, j]) > 0.6 if higher_better else im.norm(v[i, j]) < 0.4
                ax.text(j, i, f"{v[i, j]:.3g}\nn={int(piv['n'].iat[i, j])}, "
                        f"{int(piv['n_tracks'].iat[i, j])} tracks", ha="center", va="center",
                        fontsize=6, color="black" if light else "white")
    ax.set_xticks(range(len(classes)), classes, fontsize=8, rotation=30, ha="right")
    ax.set_yticks(range(len(methods)), methods, fontsize=8)
    cb = fig.colorbar(im, ax=ax)
    cb.set_label(direction_label("mean " + metric, higher_better).replace(" (", "\n("), fontsize=7)
    ax.set_title(f"{metric} by method and class", fontsize=9)
    return fig


def class_offset_heatmap(res: MethodsResult, metric: str | None = None) -> Figure | None:
    """The paired difference of ``metric`` per class (rows) and offset (columns), one panel per
    pair of methods next in the leaderboard, coloured towards the better method (diverging,
    centred on 0); each cell gives the difference, the verdict and n with its tracks. ``None``
    without ``by = class,offset`` rows.

    Parameters
    ----------
    res : MethodsResult
        Its ``label_class,view`` paired rows are drawn, its leaderboard order pairs the methods.
    metric : str, optional
        The metric whose difference is coloured (``None``: the ranking metric).

    Returns
    -------
    matplotlib.figure.Figure or None
        A panel per neighbouring pair of methods; ``None`` without the rows.
    """
    metric = metric or res.rank_metric
    t = _class_offset_rows(res, metric)
    if t.empty:
        return None
    pairs = [(a, b) for a, b in zip(res.methods, res.methods[1:], strict=False)]
    classes = sorted(t["group"].unique())
    offsets = sorted(t["offset"].unique())
    sign = 1.0 if res.directions[metric] else -1.0
    fig = Figure(figsize=(max(4.5, 1.6 + 0.95 * len(offsets)), (1.7 + 0.55 * len(classes)) * len(pairs)),
                 layout="constrained")
    panels = fig.subplots(len(pairs), 1, squeeze=False).ravel()
    for ax, (a, b) in zip(panels, pairs, strict=True):
        s = t[((t["method_a"] == a) & (t["method_b"] == b)) | ((t["method_a"] == b) & (t["method_b"] == a))]
        flip = 1.0 if (s["method_a"] == a).all() else -1.0  # always "a - b" of the leaderboard order
        piv = {c: s.pivot(index="group", columns="offset", values=c).reindex(index=classes, columns=offsets)
               for c in ("mean_diff", "better", "n", "n_tracks")}
        v = piv["mean_diff"].to_numpy(float) * flip
        lim = np.nanmax(np.abs(v)) if np.isfinite(v).any() else 1.0
        im = ax.imshow(v * sign, cmap="RdBu", vmin=-lim, vmax=lim, aspect="auto")
        for i in range(v.shape[0]):
            for j in range(v.shape[1]):
                if not np.isfinite(v[i, j]):
                    continue
                better = piv["better"].iat[i, j]
                mark = better if isinstance(better, str) and better != "neither" else \
                    "-" if isinstance(better, str) else "no test"
                ax.text(j, i, f"{_diff_text(v[i, j], lim)} ({mark})\nn={int(piv['n'].iat[i, j])}, "
                        f"{int(piv['n_tracks'].iat[i, j])} tr.", ha="center", va="center", fontsize=6,
                        color="white" if abs(v[i, j]) > 0.6 * lim else "black")
        ax.set_xticks(range(len(offsets)), [offset_text(o) for o in offsets], fontsize=8)
        ax.set_yticks(range(len(classes)), classes, fontsize=8)
        ax.set_xlabel(VIEW_AXIS_LABELS.get(s["axis"].iloc[0], s["axis"].iloc[0]), fontsize=8)
        ax.set_title(f"{metric}: {a} - {b} (blue: {a} better)", fontsize=9)
        cb = fig.colorbar(im, ax=ax, orientation="horizontal", location="bottom", shrink=0.8, aspect=40)
        cb.set_label(f"\u2190 {b} better    {a} - {b}" + ("" if sign > 0 else " (negated: lower is better)")
                     + f"    {a} better \u2192", fontsize=7)
        cb.ax.tick_params(labelsize=7)
    return fig


def method_figures(res: MethodsResult) -> list[tuple[str, str, object]]:
    """``(name, title, figure)`` of the leaderboard: a tent plot per view axis, the heatmaps.

    Parameters
    ----------
    res : MethodsResult
        The comparison whose table, metrics and off-path sets are drawn.

    Returns
    -------
    list of (str, str, matplotlib.figure.Figure)
        ``(name, title, figure)``; a figure without data to draw is left out.
    """
    out = []
    for axis in dict.fromkeys(res.table["breakdown"]):
        if axis in PERTURBATION_COLUMNS:
            name = "methods_tent" if axis == "y_offset_m" else f"methods_tent_{axis}"
            out.append((name, f"Methods along {VIEW_AXIS_LABELS[axis]}: mean and 95% interval per method",
                        methods_tent_plot(res.table, res.metrics, res.directions,
                                          res.methods + list(getattr(res, "references", [])), axis=axis)))
    heat = method_class_heatmap(res.table, res.rank_metric, res.methods,
                                higher_better=res.directions[res.rank_metric])
    if heat is not None:
        out.append(("methods_by_class", f"{res.rank_metric} by method and class", heat))
    cross = class_offset_heatmap(res)
    if cross is not None:
        out.append(("methods_class_offset", f"{res.rank_metric}: paired difference by class and offset",
                    cross))
    off = off_path_figure(res, res.sets)
    if off is not None:
        out.append(("off_path", "Off-path metrics against |offset| per method", off))
    return out


def context(res: MethodsResult | None, table) -> dict:
    """The report templates' leaderboard section; ``table`` renders a DataFrame (HTML or
    Markdown). Empty strings without ``--compare-methods`` (``res`` None).

    Parameters
    ----------
    res : MethodsResult or None
        The method comparison (``None``: none made).
    table : callable
        ``table(DataFrame) -> str``, HTML or Markdown.

    Returns
    -------
    dict
        Template variables.
    """
    if res is None:
        return {"leaderboard_table": "", "leaderboard_text": "", "leaderboard_paired": "",
                "leaderboard_notes": [], "rank_metric": "", "leaderboard_cells": "", "off_path_table": "",
                "headline_lines": []}
    cells = class_offset_display(res)
    return {"leaderboard_table": table(leaderboard_display(res)),
            "leaderboard_text": leaderboard_text(res), "headline_lines": headline_lines(res),
            "leaderboard_paired": table(paired_display(res)),
            "leaderboard_cells": table(cells) if len(cells) else "",
            "leaderboard_notes": res.notes, "rank_metric": res.rank_metric,
            "off_path_table": table(off) if len(off := off_path_display(res, res.sets)) else ""}
