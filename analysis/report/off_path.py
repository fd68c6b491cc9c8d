"""The report's "Off-path metrics": the numbers the field reports, per method and lateral offset,
beside NVRQ (analysis layer; ``analyze ... --compare-methods [--nta NTA.csv] [--sets SETS.csv]``,
docs/FORMATS.md §11).

- per-object metrics of the leaderboard (:mod:`analysis.methods`, its ``y_offset_m`` breakdown):
  NTA-IoU (``nta_iou``, from ``--nta``), NVRQ-CA and PSNR, each with its 95% cluster-bootstrap
  interval and its counts of objects and tracks;
- set metrics of ``nvrq score-sets`` (``--sets``): FD and KID per set (``frames`` and
  ``objects``), KID with ``± std`` over its subsets, with ``n_render``. A value the sets table
  leaves empty (FD on fewer images than the feature dimension) is a cell with its reason, and
  KID without a spread (its subsets are the whole sets) shows the reason, not ``± 0``.

:func:`off_path_display` is the table, :func:`off_path_figure` each metric against ``|offset|``
per method (one panel per metric, the direction in its label).
"""

from __future__ import annotations

import re

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from analysis.common.plots import direction_label, method_colours
from analysis.common.text import fmt, interval_text, offset_text
from analysis.common.viewpoint_floor import FLOOR_COLOUR, floor_label, is_reference
from data_schema.text import plural

__all__ = ["OFF_PATH_PREFIXES", "off_path_rows", "off_path_display", "off_path_figure"]

#: per-object metrics shown, by name or prefix (NVRQ-CA of every encoder; LPIPS when scored)
OFF_PATH_PREFIXES = ("nta_iou", "nvrq_ca", "psnr", "lpips")


def _object_rows(res) -> pd.DataFrame:
    t = res.table
    keep = [m for m in res.metrics if any(m == p or m.startswith(p + ":") for p in OFF_PATH_PREFIXES)]
    t = t[(t["breakdown"] == "y_offset_m") & t["metric"].isin(keep)]
    return pd.DataFrame({"method": t["method"], "offset": pd.to_numeric(t["group"]), "metric": t["metric"],
                         "higher_better": t["metric"].map(res.directions), "mean": t["mean"],
                         "lo": t["ci_lo"], "hi": t["ci_hi"], "n": t["n"], "n_tracks": t["n_tracks"],
                         "spread": np.nan, "reason": ""})


def _reason_of(sets: pd.DataFrame, prefix: str) -> pd.Series:
    """The part of each set's ``reason`` about ``prefix`` (``FD`` or ``KID``), else ``''``."""
    if "reason" not in sets.columns:
        return pd.Series("", index=sets.index)
    return sets["reason"].fillna("").astype(str).map(
        lambda text: "; ".join(p for p in text.split("; ") if p.startswith(prefix + " ")))


def _set_rows(sets: pd.DataFrame | None) -> pd.DataFrame:
    if sets is None or not len(sets):
        return pd.DataFrame()
    lateral = sets[[c for c in ("x_offset_m", "z_offset_m", "roll_deg", "pitch_deg", "yaw_deg")
                    if c in sets.columns]].fillna(0).eq(0).all(axis=1)
    s = sets[lateral]
    rows = []
    for col in [c for c in s.columns if c.startswith(("fd:", "kid:"))]:
        is_kid = col.startswith("kid:")
        std = col.replace("kid:", "kid_std:")
        spread = s[std] if is_kid and std in s.columns else pd.Series(np.nan, index=s.index)
        whole = pd.Series(False, index=s.index)
        if is_kid and {"kid_subset_size", "n_gt"} <= set(s.columns):  # a table of an older version wrote 0
            whole = (s["kid_subset_size"] == s["n_render"]) & (s["kid_subset_size"] == s["n_gt"])
            spread = spread.where(~whole, np.nan)
        rows.append(pd.DataFrame({"method": s["method"].fillna("").astype(str), "offset": s["y_offset_m"],
                                  "metric": col + " (" + s["kind"].astype(str) + ")", "higher_better": False,
                                  "mean": s[col], "lo": np.nan, "hi": np.nan, "n": s["n_render"],
                                  "n_tracks": np.nan, "spread": spread,
                                  "reason": _reason_of(s, "KID" if is_kid else "FD")}))
        last = rows[-1]
        empty = last["mean"].isna() & (last["reason"] == "")
        last.loc[empty, "reason"] = "no value in the sets table"
        if is_kid:
            bare = last["spread"].isna() & last["mean"].notna() & (last["reason"] == "")
            last.loc[bare & whole, "reason"] = "KID has no spread: every subset is the whole of both sets"
            last.loc[bare & ~whole, "reason"] = "no spread in the sets table"
    return pd.concat(rows, ignore_index=True) if rows else pd.DataFrame()


def off_path_rows(res, sets: pd.DataFrame | None = None) -> pd.DataFrame:
    """Long table of every off-path metric per method and offset.

    Parameters
    ----------
    res : analysis.methods.MethodsResult
        The leaderboard (its ``y_offset_m`` breakdown of methods.csv).
    sets : pandas.DataFrame, optional
        The ``nvrq score-sets`` table.

    Returns
    -------
    pandas.DataFrame
        ``method, offset, metric, higher_better, mean, lo, hi, n, n_tracks, spread, reason``
        (``spread``: KID's standard deviation over subsets; ``reason``: why a set metric or its
        spread is empty, e.g. FD on fewer images than the feature dimension), sorted by offset,
        metric and method. A row without a value is kept when it has a reason.
    """
    out = pd.concat([_object_rows(res), _set_rows(sets)], ignore_index=True)
    if out.empty:
        return out
    out["reason"] = out["reason"].fillna("").astype(str)
    out = out[out["metric"].notna() & (out["mean"].notna() | (out["reason"] != ""))]
    return out.sort_values(["offset", "metric", "method"], kind="stable").reset_index(drop=True)


_FD_TOO_FEW = re.compile(r"^FD needs more than (\d+) images per side")


def _short(reason: str) -> str:
    """The reason as a table cell says it (the sets table keeps the full sentence)."""
    m = _FD_TOO_FEW.match(reason)
    if m:
        return f"no FD: n \u2264 {m.group(1)}, the feature dimension"
    if reason.startswith("KID has no spread"):
        return "no spread: the subsets are the whole sets"
    return reason


def _finite(x) -> bool:
    return isinstance(x, float | np.floating) and bool(np.isfinite(x))


def _cell(r) -> str:
    n = f"n={int(r['n'])}"
    if _finite(r["n_tracks"]):
        n += f", {int(r['n_tracks'])} tr."
    if not _finite(r["mean"]):  # no value: the reason instead (never a dropped column)
        return f"— ({_short(r['reason'])}; {n})"
    if _finite(r["spread"]):
        text = f"{fmt(r['mean'], 4)} ± {fmt(r['spread'], 4)}"
    elif r["metric"].startswith("kid:"):  # KID without a spread: say why, not "± 0"
        return f"{fmt(r['mean'], 4)} ({n}; {_short(r['reason']) or 'no spread'})"
    else:
        text = interval_text(r["mean"], r["lo"], r["hi"], 3)
    return f"{text} ({n})"


def off_path_display(res, sets: pd.DataFrame | None = None) -> pd.DataFrame:
    """The "Off-path metrics" table: one row per offset and method, one column per metric
    (named with its direction), cells ``mean [95% interval] (n, tracks)`` or, for KID,
    ``mean ± std over subsets (n renders)``. Empty without any of the metrics. The methods
    ``perfect`` and ``floor`` are listed as the viewpoint floor (:data:`analysis.common.viewpoint_floor.FLOOR_LABELS`).

    Parameters
    ----------
    res : MethodsResult
        The ``--compare-methods`` result.
    sets : pandas.DataFrame or None
        The ``nvrq score-sets`` table (``analyze --sets``), or None.

    Returns
    -------
    pandas.DataFrame
        The display table of strings; empty without any off-path metric.
    """
    rows = off_path_rows(res, sets)
    if rows.empty:
        return pd.DataFrame()
    rows = rows.assign(cell=rows.apply(_cell, axis=1),
                       column=[direction_label(m, bool(h)) for m, h in zip(rows["metric"], rows["higher_better"],
                                                                         strict=True)])
    wide = rows.pivot_table(index=["offset", "method"], columns="column", values="cell", aggfunc="first",
                            sort=False).reset_index()
    wide.insert(0, "offset", wide.pop("offset").map(offset_text))
    wide["method"] = wide["method"].map(floor_label)  # perfect and floor: the viewpoint floor
    wide.columns.name = None
    return wide.fillna("")


def off_path_figure(res, sets: pd.DataFrame | None = None) -> Figure | None:
    """Each off-path metric against ``|offset|`` per method (one panel per metric; the mean of
    the two signs of an offset weighted by their n), the viewpoint floor (``perfect``, ``floor``)
    dashed. None without any of the metrics.

    Parameters
    ----------
    res : MethodsResult
        The ``--compare-methods`` result; its per-object off-path metrics are drawn.
    sets : pandas.DataFrame or None
        Set-level FD and KID per method and offset (``analyze --sets``); None adds none.

    Returns
    -------
    matplotlib.figure.Figure or None
        One panel per metric, x = |offset| in metres; None without any off-path metric.
    """
    rows = off_path_rows(res, sets)
    rows = rows[rows["mean"].notna()] if not rows.empty else rows  # a reason has no point to draw
    if rows.empty:
        return None
    rows = rows.assign(abs_offset=rows["offset"].abs(), w=rows["n"].astype(float))
    metrics = list(dict.fromkeys(rows["metric"]))
    colours = method_colours(rows["method"].unique())
    fig = Figure(figsize=(3.4 * len(metrics), 3.0), constrained_layout=True)
    axes = fig.subplots(1, len(metrics), squeeze=False)[0]
    for ax, metric in zip(axes, metrics, strict=True):
        m = rows[rows["metric"] == metric]
        for method, g in m.groupby("method", sort=True):
            agg = g.groupby("abs_offset").apply(lambda d: np.average(d["mean"], weights=d["w"]),
                                                include_groups=False)
            tracks = g["n_tracks"].max()  # per-object metrics: the tracks behind the largest view
            label = (floor_label(method) or "(one method)") + (
                f" ({plural(int(tracks), 'track')})" if np.isfinite(tracks) else "")
            if is_reference(method):  # the viewpoint floor: dashed grey
                ax.plot(agg.index, agg.to_numpy(), "s--", color=FLOOR_COLOUR, linewidth=1.0, markersize=3, label=label)
            else:
                ax.plot(agg.index, agg.to_numpy(), "o-", color=colours[method], label=label)
        ax.set_xlabel("|lateral offset| (m)", fontsize=8)
        ax.set_ylabel(direction_label(metric, bool(m["higher_better"].iloc[0])), fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7)
    return fig
