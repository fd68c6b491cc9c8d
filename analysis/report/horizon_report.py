"""The trust horizon's files, figures and report section (docs/FORMATS.md §15).

Layer: ``analysis`` (writes what :mod:`analysis.horizon` computed into the report folder that
:mod:`analysis.report.report` builds; matplotlib figures without pyplot state).

Files: ``horizon.csv`` (:data:`nvrq.horizon.HORIZON_COLUMNS`), ``horizon.json`` (schema
``nvrq.horizon`` version :data:`SCHEMA_VERSION`: the threshold, its source, the options, the
grid and the rows), ``horizon_timeline.csv`` (when the items have times),
``horizon_thresholds.csv`` (ratings: the human threshold of every metric),
``horizon_view_thresholds.csv`` (the thresholds per view, when the horizon used them), and the figures
``horizon_<method>.png/.svg`` (share of good objects against offset per class, the crossing
marked and its interval shaded) and ``horizon_timeline.png/.svg`` (a heat strip of the horizon
over time). The section: one sentence per method (:func:`method_sentence`).

>>> t = pd.DataFrame({"method": "sharp", "label_class": ["automobile", "automobile"],
...                   "axis": "y", "direction": ["left", "right"], "horizon": [2.0, 1.0],
...                   "crossing": [2.4, 1.5], "ci_lo": [1.5, math.nan], "ci_hi": [2.5, math.nan],
...                   "reason": ["", ""]})
>>> method_sentence("sharp", t)
'sharp: automobile stays good to 2 m left (crossing 2.4 [1.5, 2.5]) and 1 m right (crossing 1.5).'
"""

from __future__ import annotations

import base64
import json
import math

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from analysis.common import plots
from analysis.common.text import interval_text
from data_schema.tables import write_table
from nvrq.horizon import DIRECTIONS, HORIZON_COLUMNS, TIMELINE_COLUMNS, unit_of

__all__ = ["SCHEMA_VERSION", "write_horizon", "horizon_json", "method_sentence", "share_figure",
           "timeline_figure", "threshold_text", "context"]

#: The version of horizon.json's schema (docs/FORMATS.md §15).
SCHEMA_VERSION = 1


def _num(v):
    """A JSON value: NaN and infinities as null, NumPy scalars as Python numbers."""
    if isinstance(v, (float, np.floating)):
        return float(v) if math.isfinite(v) else None
    return v.item() if isinstance(v, np.generic) else v


def horizon_json(result) -> dict:
    """horizon.json's content (docs/FORMATS.md §15) for a :class:`analysis.horizon.HorizonResult`.

    Parameters
    ----------
    result : analysis.horizon.HorizonResult

    Returns
    -------
    dict
        ``schema``, ``version``, ``metric``, ``threshold`` (value, source, higher_better,
        ci_lo, ci_hi), ``share``, ``good_prob`` (null without votes), ``min_clusters``,
        ``n_boot``, ``seed``, ``window_s``, ``grid`` (axis -> signed offsets), ``units``,
        ``horizons`` (the horizon.csv rows, each with its ``threshold_kind`` of
        :data:`analysis.horizon.THRESHOLD_KINDS`), ``thresholds`` (horizon_thresholds.csv rows)
        and ``view_thresholds`` (horizon_view_thresholds.csv rows; empty for one threshold).
    """
    th, o = result.threshold, result.options
    grid = {a: sorted({_num(v) for v in g["offset"]}) for a, g in result.curves.groupby("axis", sort=False)}
    rows = lambda df: [{k: _num(v) for k, v in r.items()} for r in df.to_dict("records")]  # noqa: E731
    kind, views = result.kind, result.views
    return {
        "schema": "nvrq.horizon", "version": SCHEMA_VERSION, "metric": th.metric,
        "threshold": {"value": _num(th.value), "source": th.source, "higher_better": th.good_above,
                      "ci_lo": _num(th.ci_lo), "ci_hi": _num(th.ci_hi)},
        "share": o.share, "good_prob": o.good_prob if result.fits is not None else None,
        "min_clusters": o.min_clusters, "n_boot": o.n_boot, "seed": o.seed, "window_s": o.window_s,
        "grid": grid, "units": {a: unit_of(a) for a in grid},
        "horizons": [{**r, "threshold_kind": kind} for r in rows(result.table[HORIZON_COLUMNS])],
        "thresholds": [] if result.fits is None else rows(result.fits),
        "view_thresholds": [] if views is None else rows(views),
    }


def _n(v: float) -> str:
    return f"{round(float(v), 2):g}"


def _part(r) -> str:
    """One direction's text: ``'2 m left (crossing 2.3 [1.9, 2.6])'``, or why there is no
    number; a bracket follows the number it is the interval of (the crossing, or the whole grid
    when nothing fails)."""
    unit = unit_of(r["axis"])
    if r["reason"].startswith("fails at"):
        return f"not even at the recorded view ({r['direction']})"
    ci = f" [{_n(r['ci_lo'])}, {_n(r['ci_hi'])}]" if math.isfinite(r["ci_lo"]) else ""
    if r["reason"].startswith("beyond the grid"):
        return f"at least {_n(r['horizon'])} {unit} {r['direction']} (all of the grid{ci})"
    if math.isfinite(r["crossing"]):
        return f"{_n(r['horizon'])} {unit} {r['direction']} (crossing {_n(r['crossing'])}{ci})"
    return f"{_n(r['horizon'])} {unit} {r['direction']}"


def method_sentence(method: str, table: pd.DataFrame) -> str:
    """The report's sentence for ``method``: per class, the horizon in each direction.

    Parameters
    ----------
    method : str
        A method of ``table``.
    table : pandas.DataFrame
        horizon.csv rows (:data:`nvrq.horizon.HORIZON_COLUMNS`).

    Returns
    -------
    str
        e.g. ``'sharp: automobile stays good to 2 m left (crossing 2.3 [1.9, 2.6]) and 1 m
        right; person to 1 m left and 1 m right.'`` (brackets: the 95% interval of the crossing).
    """
    t = table[table["method"] == method]
    parts = []
    for i, (cls, g) in enumerate(t.groupby("label_class", sort=True)):
        rows = g.to_dict("records")
        fails = [r["direction"] for r in rows if r["reason"].startswith("fails at")]
        good = " and ".join(_part(r) for r in rows if not r["reason"].startswith("fails at"))
        if not good:
            parts.append(f"{cls} is not good even at the recorded view")
            continue
        text = f"{cls} stays good to {good}" if i == 0 else f"{cls} to {good}"
        if fails:
            text += f" (on the {' and '.join(fails)} side: not good even at the recorded view)"
        parts.append(text)
    return f"{method}: " + "; ".join(parts) + "."


def share_figure(curves: pd.DataFrame, table: pd.DataFrame, method: str, share: float) -> Figure:
    """One panel per axis: the share of good objects against the signed offset, a line per
    class, the required ``share`` dashed, each crossing marked and its interval shaded.

    Parameters
    ----------
    curves : pandas.DataFrame
        :func:`nvrq.horizon.share_curves` rows.
    table : pandas.DataFrame
        horizon.csv rows.
    method : str
        The method drawn.
    share : float
        The required share.

    Returns
    -------
    matplotlib.figure.Figure
    """
    c, t = curves[curves["method"] == method], table[table["method"] == method]
    axes_ = list(dict.fromkeys(c["axis"]))
    fig, grid = plots.panel_grid(len(axes_), width=4.2, height=3.0)
    colours = dict(zip(sorted(c["label_class"].unique()), [f"C{i}" for i in range(10)] * 10, strict=False))
    for ax, axis in zip(grid.ravel(), axes_, strict=False):
        for cls, g in c[c["axis"] == axis].groupby("label_class", sort=True):
            g = g.drop_duplicates("offset").sort_values("offset")
            ax.plot(g["offset"], g["share_good"], "o-", ms=3, color=colours[cls], label=cls)
        for r in t[t["axis"] == axis].to_dict("records"):
            sign = 1.0 if r["direction"] == DIRECTIONS[axis][0] else -1.0
            if math.isfinite(r["crossing"]):
                ax.axvline(sign * r["crossing"], color=colours[r["label_class"]], lw=0.8, ls=":")
            if math.isfinite(r["ci_lo"]):
                ax.axvspan(sign * r["ci_lo"], sign * r["ci_hi"], color=colours[r["label_class"]], alpha=0.12)
        ax.axhline(share, color="0.3", ls="--", lw=0.8)
        ax.set_ylim(-0.02, 1.02)
        ax.set_xlabel(f"{axis} ({unit_of(axis)}; {' < 0 < '.join(DIRECTIONS[axis][::-1])})", fontsize=8)
        ax.set_ylabel("share of good objects", fontsize=8)
    for ax in grid.ravel()[len(axes_):]:
        ax.set_visible(False)
    plots.legend_below(fig, grid.ravel()[0], ncols=min(4, c["label_class"].nunique()))  # one legend: the classes
    fig.suptitle(f"{method}: share of good objects (dashed: {share:g})", fontsize=9)
    return fig


#: The heat strip's colours of a cell without a horizon: no objects of that row in that
#: window, and objects that already fail at the recorded view.
NO_DATA_COLOUR, FAILS_COLOUR = "0.85", "#b2182b"


def timeline_figure(timeline: pd.DataFrame) -> Figure | None:
    """A heat strip: one row per method, class, camera and direction, one column per window,
    the colour the horizon; a window without objects of a row and one whose objects fail at
    the recorded view each have their own colour and legend entry (below the strip); None
    without rows.

    Parameters
    ----------
    timeline : pandas.DataFrame
        horizon_timeline.csv rows.

    Returns
    -------
    matplotlib.figure.Figure or None
    """
    if timeline is None or timeline.empty:
        return None
    from matplotlib.colors import to_rgba
    from matplotlib.patches import Patch

    t = timeline.assign(row=timeline["method"] + " · " + timeline["class"] + " · " + timeline["camera"].astype(str)
                        + " · " + timeline["axis"] + " " + timeline["direction"],
                        t=(timeline["t0_us"] - timeline.groupby("clip_id")["t0_us"].transform("min")) / 1e6,
                        seen=1.0)
    wide = t.pivot_table(index="row", columns=["clip_id", "t"], values="horizon", aggfunc="first", dropna=False)
    seen = t.pivot_table(index="row", columns=["clip_id", "t"], values="seen", aggfunc="first").reindex_like(wide)
    h = wide.to_numpy(np.float64)
    present = np.isfinite(seen.to_numpy(np.float64))
    fig = Figure(figsize=(max(5.0, 0.5 * wide.shape[1] + 4), max(2.4, 0.25 * wide.shape[0] + 1.6)),
                 layout="constrained")
    ax = fig.add_subplot()
    im = ax.imshow(np.ma.masked_invalid(h), aspect="auto", cmap=plots_cmap(), interpolation="nearest")
    empty = np.zeros((*h.shape, 4))
    empty[~present] = to_rgba(NO_DATA_COLOUR)
    empty[present & ~np.isfinite(h)] = to_rgba(FAILS_COLOUR)
    ax.imshow(empty, aspect="auto", interpolation="nearest")
    ax.set_yticks(range(wide.shape[0]), wide.index, fontsize=6)
    ax.set_xticks(range(wide.shape[1]), [f"{c}\n{s:g}s" if len(set(wide.columns.get_level_values(0))) > 1
                                         else f"{s:g}s" for c, s in wide.columns], fontsize=6)
    ax.set_xlabel("window start", fontsize=8)
    bar = fig.colorbar(im, ax=ax)
    bar.set_label("horizon (m or deg)", fontsize=7)
    bar.ax.tick_params(labelsize=6)
    fig.legend([Patch(color=FAILS_COLOUR), Patch(color=NO_DATA_COLOUR)],
               ["not good even at the recorded view", "no objects in this window"],
               loc="outside lower center", ncols=2, fontsize=7, frameon=False)
    return fig


def plots_cmap():
    """The heat strip's colour map: viridis; an empty cell is drawn over (:func:`timeline_figure`)."""
    from matplotlib import colormaps

    return colormaps["viridis"].with_extremes(bad=NO_DATA_COLOUR)


def threshold_text(result) -> str:
    """The report's sentence on the threshold: one value, or one per view (its source first).

    Parameters
    ----------
    result : analysis.horizon.HorizonResult

    Returns
    -------
    str
        e.g. ``'Threshold: nvrq_ca >= 0.128 [0.09, 0.17] (people: ...).'`` or ``'Thresholds per
        view (people, per view: ...): nvrq_ca >= 0.95 at the recorded view, 0.31 at y +1, ...'``.
    """
    from analysis.stats.horizon_views import view_label

    th = result.threshold
    sign = ">=" if th.good_above else "<="
    if result.views is None:
        ci = f" [{th.ci_lo:.4g}, {th.ci_hi:.4g}]" if math.isfinite(th.ci_lo) else ""
        return f"Threshold: {th.metric} {sign} {th.value:.4g}{ci} ({th.source})."
    v = result.views
    parts = []
    for r in v.to_dict("records"):
        ci = (f" [{r['ci_lo']:.3g}, {r['ci_hi']:.3g}]" if math.isfinite(r.get("ci_lo", math.nan)) else "")
        parts.append(f"{r['threshold']:.3g}{ci} at {view_label(r['axis'], r['offset'])}")
    sources = "; ".join(dict.fromkeys(v["source"].astype(str)))
    return f"Thresholds per view ({sources}): {th.metric} {sign} " + ", ".join(parts) + "."


def write_horizon(result, d) -> list[dict]:
    """Write the horizon's files into the report folder ``d``; returns the figures as the
    report lists them (``title``, ``b64``, ``file``).

    Parameters
    ----------
    result : analysis.horizon.HorizonResult
    d : pathlib.Path
        The report folder being built.

    Returns
    -------
    list of dict
    """
    write_table(result.table, d / "horizon.csv", columns=HORIZON_COLUMNS)
    (d / "horizon.json").write_text(json.dumps(horizon_json(result), indent=1), encoding="utf-8")
    if result.timeline is not None:
        write_table(result.timeline, d / "horizon_timeline.csv", columns=TIMELINE_COLUMNS)
    if result.fits is not None:
        write_table(result.fits, d / "horizon_thresholds.csv")
    if result.views is not None:
        write_table(result.views, d / "horizon_view_thresholds.csv")
    figs = [(f"horizon_{m}", f"Trust horizon of {m}: share of good objects against offset",
             share_figure(result.curves, result.table, m, result.options.share))
            for m in sorted(result.table["method"].unique())]
    figs.append(("horizon_timeline", "Trust horizon over time (heat strip)", timeline_figure(result.timeline)))
    out = []
    for name, title, fig in figs:
        if fig is not None:
            png = plots.save_figure(fig, d, name)
            out.append({"title": title, "b64": base64.b64encode(png).decode("ascii"), "file": f"{name}.png"})
    return out


def _table_display(table: pd.DataFrame) -> pd.DataFrame:
    """horizon.csv for the page: the crossing and its interval in one cell (the bracket beside
    the number it belongs to), the threshold columns left to the sentence above the table."""
    t = table.drop(columns=["metric", "threshold", "threshold_source"])
    # nothing fails: the interval belongs to the largest grid offset, the horizon itself
    est = t["crossing"].where(t["crossing"].notna() | ~t["reason"].str.startswith("beyond the grid"), t["horizon"])
    cross = [interval_text(c, lo, hi) for c, lo, hi in zip(est, t["ci_lo"], t["ci_hi"], strict=True)]
    t = t.drop(columns=["crossing", "ci_lo", "ci_hi"])
    t.insert(t.columns.get_loc("horizon") + 1, "crossing [95% interval]", cross)
    return t


def context(result, figures: list[dict], table) -> dict:
    """The report template's variables of the "Trust horizon" section (empty without a result).

    Parameters
    ----------
    result : analysis.horizon.HorizonResult or None
    figures : list of dict
        :func:`write_horizon`'s figures.
    table : callable
        Renders a DataFrame for the page (:func:`analysis.report.report.render_pages`).

    Returns
    -------
    dict
        ``horizon_sentences``, ``horizon_text``, ``horizon_table``, ``horizon_fits``,
        ``horizon_figures``, ``horizon_notes``.
    """
    if result is None:
        return {"horizon_sentences": [], "horizon_figures": []}
    o = result.options
    text = (threshold_text(result) + " "
            f"A horizon is the largest grid offset up to which at least {o.share:g} of the objects are "
            "good at every grid offset; brackets: the 95% interval of the interpolated crossing over "
            f"a cluster bootstrap of tracks ({o.n_boot} replicates; none below {o.min_clusters} tracks). "
            "Every row: horizon.csv, horizon.json"
            + ("; the thresholds per view: horizon_view_thresholds.csv" if result.views is not None else "")
            + "; per window of "
            f"{o.window_s:g} s: horizon_timeline.csv.")
    shown = _table_display(result.table)
    return {"horizon_sentences": [method_sentence(m, result.table) for m in sorted(result.table["method"].unique())],
            "horizon_text": text, "horizon_table": table(shown), "horizon_figures": figures,
            "horizon_fits": table(result.fits) if result.fits is not None else "",
            "horizon_notes": result.notes}
