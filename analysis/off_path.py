"""The report's "Off-path metrics": the numbers the field reports, per method and lateral offset,
beside NVRQ (analysis layer; ``analyze ... --compare-methods [--nta NTA.csv] [--sets SETS.csv]``,
docs/FORMATS.md §11).

- per-object metrics of the leaderboard (:mod:`analysis.methods`, its ``y_offset_m`` breakdown):
  NTA-IoU (``nta_iou``, from ``--nta``), NVRQ-CA and PSNR, each with its 95% cluster-bootstrap
  interval and its counts of objects and tracks;
- set metrics of ``nvrq score-sets`` (``--sets``): FD and KID per set (``frames`` and
  ``objects``), KID with ``± std`` over its subsets, with ``n_render``.

:func:`off_path_display` is the table, :func:`off_path_figure` each metric against ``|offset|``
per method (one panel per metric, the direction in its label).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from analysis.plots import direction_label, method_colours
from analysis.text import fmt, interval_text, offset_text
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
                         "spread": np.nan})


def _set_rows(sets: pd.DataFrame | None) -> pd.DataFrame:
    if sets is None or not len(sets):
        return pd.DataFrame()
    lateral = sets[[c for c in ("x_offset_m", "z_offset_m", "roll_deg", "pitch_deg", "yaw_deg")
                    if c in sets.columns]].fillna(0).eq(0).all(axis=1)
    s = sets[lateral]
    rows = []
    for col in [c for c in s.columns if c.startswith(("fd:", "kid:"))]:
        spread = s[col.replace("kid:", "kid_std:")] if col.startswith("kid:") else np.nan
        rows.append(pd.DataFrame({"method": s["method"].fillna("").astype(str), "offset": s["y_offset_m"],
                                  "metric": col + " (" + s["kind"].astype(str) + ")", "higher_better": False,
                                  "mean": s[col], "lo": np.nan, "hi": np.nan, "n": s["n_render"],
                                  "n_tracks": np.nan, "spread": spread}))
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
        ``method, offset, metric, higher_better, mean, lo, hi, n, n_tracks, spread`` (``spread``:
        KID's standard deviation over subsets), sorted by offset, metric and method.
    """
    out = pd.concat([_object_rows(res), _set_rows(sets)], ignore_index=True)
    if out.empty:
        return out
    out = out[out["metric"].notna() & out["mean"].notna()]
    return out.sort_values(["offset", "metric", "method"], kind="stable").reset_index(drop=True)


def _cell(r) -> str:
    if np.isfinite(r["spread"]) if isinstance(r["spread"], float) else False:
        text = f"{fmt(r['mean'], 4)} ± {fmt(r['spread'], 4)}"
    else:
        text = interval_text(r["mean"], r["lo"], r["hi"], 3)
    n = f"n={int(r['n'])}"
    if isinstance(r["n_tracks"], float) and np.isfinite(r["n_tracks"]):
        n += f", {int(r['n_tracks'])} tr."
    return f"{text} ({n})"


def off_path_display(res, sets: pd.DataFrame | None = None) -> pd.DataFrame:
    """The "Off-path metrics" table: one row per offset and method, one column per metric
    (named with its direction), cells ``mean [95% interval] (n, tracks)`` or, for KID,
    ``mean ± std over subsets (n renders)``. Empty without any of the metrics.

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
    wide.columns.name = None
    return wide.fillna("")


def off_path_figure(res, sets: pd.DataFrame | None = None) -> Figure | None:
    """Each off-path metric against ``|offset|`` per method (one panel per metric; the mean of
    the two signs of an offset weighted by their n). None without any of the metrics.

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
            label = (method or "(one method)") + (f" ({plural(int(tracks), 'track')})" if np.isfinite(tracks) else "")
            ax.plot(agg.index, agg.to_numpy(), "o-", color=colours[method], label=label)
        ax.set_xlabel("|lateral offset| (m)", fontsize=8)
        ax.set_ylabel(direction_label(metric, bool(m["higher_better"].iloc[0])), fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7)
    return fig
