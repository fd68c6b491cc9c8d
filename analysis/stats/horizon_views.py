"""Per-view thresholds of the trust horizon (docs/FORMATS.md §15): from people, from a table,
or over the viewpoint floor.

Layer: ``analysis`` (votes, tables and items in; a per-view table of
:data:`nvrq.horizon.VIEW_COLUMNS` out, which :class:`nvrq.horizon.Threshold` carries).

- **People** (:func:`people_views`): one logistic ``P(good | m, view v) = sigmoid(a_v + b m)``
  with an intercept per view cell and a slope shared by all views
  (:func:`analysis.stats.horizon_fit.view_thresholds`), its threshold per view
  ``(logit(good_prob) - a_v) / b`` clipped to the rated values
  (:func:`analysis.stats.horizon_fit.clip_to_range`), each with the 95% percentile interval of the
  two-way bootstrap over raters and tracks of :func:`analysis.stats.horizon_fit.vote_threshold`.
- **A table** (:func:`read_view_table`): ``offset, threshold`` and optionally ``axis``
  (default ``y``) and ``metric``; it must hold a finite threshold for every view of the grid.
- **The viewpoint floor** (:func:`viewpoint_floor`, :func:`floor_views`): the floor of a view is
  the median of the metric over the pairs of a render with no artefact there (method
  ``perfect``, synthetic scenes) or of two GT views of the same object (method ``floor``, real
  logs). A given threshold ``T`` then applies to the metric's excess over the floor: an object
  at view ``v`` is good when ``m - floor_v >= T`` (``<= T`` where lower is better), i.e. its
  view's threshold is ``floor_v + T``. An axis without a floor at each of its views keeps ``T``.

>>> floor = pd.DataFrame({"axis": ["none", "y", "y"], "offset": [0.0, 1.0, -1.0],
...                       "floor": [0.99, 0.5, 0.45], "method": "perfect"})
>>> floor_views(floor, -0.1, grid=[("none", 0.0), ("y", 1.0), ("y", -1.0)])["threshold"].round(3).tolist()
[0.89, 0.4, 0.35]
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from analysis.common.choices import MIN_CLASS_VOTES, VIEW_FITS
from data_schema.errors import InputError
from data_schema.perturbation import AXES, axes, axis_values, perturbation_array
from data_schema.text import plural
from nvrq.horizon import ALL_CLASSES, VIEW_COLUMNS, class_rows, view_keys

__all__ = ["FLOOR_METHODS", "MIN_CLASS_VOTES", "PEOPLE_VIEW_COLUMNS", "VIEW_FITS", "grid_of", "people_views",
           "read_view_table", "viewpoint_floor", "floor_views", "view_label"]

#: The methods whose pairs give the viewpoint floor, in order of preference.
FLOOR_METHODS = ("perfect", "floor")
#: horizon_view_thresholds.csv: one row per view of the grid (ratings).
PEOPLE_VIEW_COLUMNS = ["metric", "label_class", "axis", "offset", "threshold", "ci_lo", "ci_hi", "good_prob",
                       "slope", "n_votes", "source", "reason"]


def view_label(axis: str, offset: float) -> str:
    """A view as a reader writes it: ``'the recorded view'``, ``'y +2'``.

    >>> view_label("y", -3.0), view_label("none", 0.0)
    ('y -3', 'the recorded view')

    Parameters
    ----------
    axis : str
    offset : float

    Returns
    -------
    str
    """
    return "the recorded view" if axis == "none" else f"{axis} {offset:+g}"


def grid_of(items: pd.DataFrame) -> list[tuple[str, float]]:
    """The views of ``items`` along single axes, as sorted ``(axis, offset)`` keys.

    Parameters
    ----------
    items : pandas.DataFrame
        N rows with perturbation columns.

    Returns
    -------
    list of tuple
        ``('none', 0.0)`` for the recorded view, ``(axis, signed offset)`` otherwise.
    """
    P = perturbation_array(items)
    names = axes(P)
    keys = view_keys(names, axis_values(P))[np.isin(names, (*AXES, "none"))]
    return sorted(set(keys.tolist()), key=lambda k: (k[0] != "none", k[0], k[1]))


def people_views(metric: str, votes: pd.DataFrame, *, good_prob: float, n_boot: int, seed: int,
                 fit: str = "monotone", increasing: bool = True, by_class: bool = False) -> pd.DataFrame:
    """Per-view thresholds of ``metric`` from the votes (module docstring), for every class
    together and, with ``by_class``, for each class at the views where it has its own votes.

    Parameters
    ----------
    metric : str
        The metric's column (named in the table).
    votes : pandas.DataFrame
        One row per vote: ``x`` (the metric at its item, finite), ``vote`` (1 good, 0 bad),
        ``rater`` and ``track`` (integer codes 0..R-1 and 0..T-1), its item's perturbation
        columns (which give the view) and, with ``by_class``, ``label_class``.
    good_prob : float
        The P(good) of the threshold, in (0, 1).
    n_boot, seed : int
        Bootstrap replicates (0: no interval) and their seed.
    fit : {'monotone', 'logistic'}, optional
        :func:`analysis.stats.horizon_fit.monotone_view_thresholds` or
        :func:`analysis.stats.horizon_fit.view_thresholds`.
    increasing : bool, optional
        Higher is better (the monotone fit's direction; the logistic finds it from its slope).
    by_class : bool, optional
        Where the votes hold two classes or more, also fit each class (``votes['label_class']``)
        alone, and keep its threshold at each view where it has at least
        :data:`analysis.common.choices.MIN_CLASS_VOTES` votes, good and bad among them (at
        the same severity, objects of different sizes score differently: one threshold per view
        for every class misjudges some of them).

    Returns
    -------
    pandas.DataFrame
        :data:`PEOPLE_VIEW_COLUMNS`, one row per view cell of the votes with ``label_class``
        :data:`nvrq.horizon.ALL_CLASSES`, then the class rows (views along several axes at
        once are left out); ``slope`` is the logistic's (NaN for the monotone fit).
    """
    rows = _people_views(metric, votes, good_prob, n_boot, seed, fit, increasing)
    if not by_class or votes["label_class"].nunique() < 2:  # one class: its rows would be these
        return rows
    # the (class, view) cells with enough votes, good and bad among them
    P = perturbation_array(votes)
    single = np.isin(axes(P), (*AXES, "none"))
    view = view_keys(axes(P)[single], axis_values(P)[single])
    cells = pd.DataFrame({"cls": votes["label_class"].astype(str).to_numpy()[single],
                          "axis": view.get_level_values(0), "offset": view.get_level_values(1),
                          "vote": votes["vote"].to_numpy(np.float64)[single]})
    stats = cells.groupby(["cls", "axis", "offset"])["vote"].agg(["size", "min", "max"])
    ok = stats[(stats["size"] >= MIN_CLASS_VOTES) & (stats["min"] < stats["max"])].index
    out = [rows]
    for cls in sorted(set(ok.get_level_values("cls"))):
        own = _people_views(metric, votes[votes["label_class"].astype(str) == cls], good_prob, n_boot, seed, fit,
                            increasing)
        mine = pd.MultiIndex.from_arrays([np.full(len(own), cls, object), own["axis"].to_numpy(object),
                                          own["offset"].to_numpy(np.float64)])
        keep = mine.isin(ok)
        out.append(own[keep].assign(label_class=cls, source=own["source"].str.replace(
            "people, per view:", f"people, per view for class {cls}:", regex=False)))
    return pd.concat(out, ignore_index=True)[PEOPLE_VIEW_COLUMNS]


def _people_views(metric, votes, good_prob, n_boot, seed, fit, increasing) -> pd.DataFrame:
    """:func:`people_views` of every class together."""
    P = perturbation_array(votes)
    names = axes(P)
    single = np.isin(names, (*AXES, "none"))
    v = votes[single]
    x, y = v["x"].to_numpy(np.float64), v["vote"].to_numpy(np.float64)
    codes, views = pd.factorize(view_keys(names[single], axis_values(P)[single]), sort=True)
    one = _fit(fit, increasing, x, y, codes, good_prob)
    est = one(None)
    up = increasing if fit == "monotone" else bool(est["b"] > 0)
    lo, hi = (float(x.min()), float(x.max())) if len(x) else (math.nan, math.nan)
    rater, track = v["rater"].to_numpy(np.int64), v["track"].to_numpy(np.int64)
    reps, why = _replicates(one, x, rater, track, est, n_boot=n_boot, seed=seed)
    R = len(np.unique(rater))
    how = ("a monotone (isotonic) fit of the votes on the metric inside each view" if fit == "monotone"
           else "a logistic with an intercept per view and a shared slope")
    source = (f"people, per view: P(good) = {good_prob:g} on {how}, fitted to {plural(len(x), 'vote')} of "
              f"{plural(R, 'rater')}")
    rows = [_view_row(est, k, reps, why, (lo, hi, up, good_prob)) for k in range(len(views))]
    return pd.DataFrame([{"metric": metric, "label_class": ALL_CLASSES, "axis": a, "offset": o, **r, "good_prob": good_prob,
                          "slope": est.get("b", math.nan), "source": source}
                         for (a, o), r in zip(views, rows, strict=True)], columns=PEOPLE_VIEW_COLUMNS)


def _fit(fit: str, increasing: bool, x, y, codes, good_prob):
    """A function of the weights ``w`` ((B, n) or None) giving the chosen per-view fit's dict."""
    from analysis.stats.horizon_fit import monotone_view_thresholds, view_thresholds

    if fit not in VIEW_FITS:
        raise InputError(param="fit", expected=" or ".join(VIEW_FITS), got=fit)
    if fit == "logistic":
        return lambda w: view_thresholds(x, y, codes, good_prob=good_prob, w=w)
    return lambda w: monotone_view_thresholds(x, y, codes, good_prob=good_prob, increasing=increasing, w=w)


def _replicates(one, x, rater, track, est, *, n_boot, seed):
    """``(reps (B, V) or None, why none)``: the per-view thresholds of the two-way bootstrap over
    raters and tracks (:func:`analysis.stats.horizon_fit.vote_threshold`'s), clipped to the rated values."""
    from analysis.stats.bootstrap import too_few_raters
    from analysis.stats.horizon_fit import _chunks, _counts

    R, T = len(np.unique(rater)), len(np.unique(track))
    if n_boot <= 0:
        return None, ""
    if too_few_raters(R):
        return None, too_few_raters(R)
    if T < 2:
        return None, f"no interval from {plural(T, 'track')}: a bootstrap over tracks needs at least 2"
    if not math.isfinite(est.get("b", 0.0)):
        return None, "no interval: " + (est.get("reason") or "the fit is undefined")
    rng = np.random.default_rng(seed)
    cr, ct = _counts(int(rater.max()) + 1, n_boot, rng), _counts(int(track.max()) + 1, n_boot, rng)
    V = len(est["n"])
    reps = np.concatenate([one(cr[s][:, rater] * ct[s][:, track])["value"] for s in _chunks(n_boot, len(x) * V)])
    return np.where(np.isnan(reps), np.nan, np.clip(reps, x.min(), x.max())), ""


def _view_row(est: dict, k: int, reps, why: str, scale: tuple) -> dict:
    """View ``k``'s ``threshold, ci_lo, ci_hi, n_votes, reason``; ``scale``: the rated values'
    ``(lo, hi)``, whether higher is better, and the P(good) of the threshold."""
    from analysis.stats.bootstrap import interval_around
    from analysis.stats.horizon_fit import clip_to_range

    lo, hi, up, good_prob = scale
    n, raw = int(est["n"][k]), float(est["value"][k])
    value, note = clip_to_range(raw, lo, hi)
    if math.isinf(raw):
        judged = "good" if (raw < 0) == up else "bad"
        note = (f"every rated value at this view is judged {judged} (P(good) "
                f"{'at or above' if judged == 'good' else 'below'} {good_prob:g}): the threshold is "
                f"the {'lowest' if value == lo else 'highest'} rated value, {value:.4g}")
    notes = [note] if note else []
    ci = (math.nan, math.nan)
    if reps is not None and math.isfinite(value):
        *ci, miss = interval_around(value, reps[:, k])
        notes += [miss] if miss else []
    elif why:
        notes.append(why)
    return {"threshold": value, "ci_lo": ci[0], "ci_hi": ci[1], "n_votes": n, "reason": "; ".join(notes)}


def read_view_table(path, grid, *, metric: str) -> pd.DataFrame:
    """A per-view threshold table given by the user (``--threshold-table``), checked against the grid.

    Parameters
    ----------
    path : str or Path
        A CSV with ``offset`` and ``threshold`` and optionally ``axis`` (a name of
        :data:`data_schema.perturbation.AXES`; default ``y``; offset 0 is the recorded view
        whatever its axis), ``metric`` (then it must name the horizon's metric) and
        ``label_class`` (a row naming a class judges that class only; ``all`` or empty: every
        class). A study's ``horizon_view_thresholds.csv`` is such a table.
    grid : sequence of tuple
        The views the horizon judges (:func:`grid_of`).
    metric : str
        The horizon's metric column.

    Returns
    -------
    pandas.DataFrame
        :data:`nvrq.horizon.VIEW_COLUMNS` (and ``label_class`` when the table has it), one row
        per view (and class) of the table.

    Raises
    ------
    InputError
        A missing column, a view twice (for one class), another metric, or a view of the grid
        without a finite threshold for every class.
    """
    from data_schema.tables import read_table

    t = read_table(path, required=("offset", "threshold"), what="per-view threshold table")
    axis = t["axis"].astype(str) if "axis" in t.columns else pd.Series("y", index=t.index)
    bad = ~axis.isin([*AXES, "none"])
    if bad.any():
        raise InputError(path, "axis", f"one of {', '.join(AXES)} (or none for the recorded view)",
                         axis[bad].iloc[0])
    for col in ("offset", "threshold"):
        vals = pd.to_numeric(t[col], errors="coerce")
        if (vals.isna() & t[col].notna()).any() or (col == "offset" and vals.isna().any()):
            raise InputError(path, col, "numbers", t[col][vals.isna()].iloc[0])
        t[col] = vals
    if "metric" in t.columns:
        other = sorted(set(t["metric"].astype(str)) - {metric})
        if other:
            raise InputError(path, "metric", f"the horizon's metric {metric}", other[0])
    off = t["offset"].astype(float)
    keys = view_keys(np.where(off.round(2) == 0, "none", axis).astype(object), off.to_numpy())
    table = pd.DataFrame({"axis": keys.get_level_values(0), "offset": keys.get_level_values(1),
                          "threshold": t["threshold"].to_numpy(np.float64),
                          "source": f"given, per view ({Path(path).name})"})
    cols = list(VIEW_COLUMNS)
    by_class = "label_class" in t.columns
    if by_class:
        table["label_class"] = t["label_class"].fillna(ALL_CLASSES).astype(str).replace("", ALL_CLASSES).to_numpy()
        cols.append("label_class")
        mine = class_rows(table)
        table.loc[mine, "source"] = [f"given, per view for class {c} ({Path(path).name})"
                                     for c in table.loc[mine, "label_class"]]
    dup = table.duplicated([*cols[3:], "axis", "offset"])
    if dup.any():
        r = table[dup].iloc[0]
        raise InputError(path, "offset", "one threshold per view" + (" and class" if by_class else ""),
                         f"{view_label(r['axis'], r['offset'])} twice")
    common = table[~class_rows(table)]
    have = {k for k, v in zip(zip(common["axis"], common["offset"], strict=True), common["threshold"], strict=True)
            if math.isfinite(v)}
    missing = [view_label(*k) for k in grid if k not in have]
    if missing:
        raise InputError(path, "threshold", "a finite threshold for every view of the grid"
                         + (" (label_class all)" if by_class else ""), f"none for {', '.join(missing)}")
    return table[cols]


def viewpoint_floor(items: pd.DataFrame, metric: str) -> pd.DataFrame:
    """The viewpoint floor of ``metric``: per view, the median over the pairs of the first
    method of :data:`FLOOR_METHODS` that ``items`` has.

    Parameters
    ----------
    items : pandas.DataFrame
        Per-pair rows with ``method``, the metric and the perturbation columns.
    metric : str
        The metric column.

    Returns
    -------
    pandas.DataFrame
        ``axis, offset, floor, n, method``, one row per view with a finite median (empty
        without a floor method).
    """
    cols = ["axis", "offset", "floor", "n", "method"]
    if "method" not in items.columns:
        return pd.DataFrame(columns=cols)
    methods = items["method"].astype(str)
    for name in FLOOR_METHODS:
        s = items[(methods == name).to_numpy() & np.isfinite(pd.to_numeric(items[metric], errors="coerce"))]
        if len(s):
            P = perturbation_array(s)
            names = axes(P)
            keys = view_keys(names, axis_values(P))
            g = pd.Series(s[metric].to_numpy(np.float64), index=keys)[np.isin(names, (*AXES, "none"))]
            med = g.groupby(level=[0, 1]).agg(["median", "size"])
            return pd.DataFrame({"axis": med.index.get_level_values(0), "offset": med.index.get_level_values(1),
                                 "floor": med["median"].to_numpy(), "n": med["size"].to_numpy(),
                                 "method": name})[cols]
    return pd.DataFrame(columns=cols)


def floor_views(floor: pd.DataFrame, threshold: float, grid) -> pd.DataFrame:
    """Per-view thresholds of a given ``threshold`` on the excess over the viewpoint floor.

    Parameters
    ----------
    floor : pandas.DataFrame
        ``axis, offset, floor`` (and ``method``) per view (:func:`viewpoint_floor`, or a table
        made by hand).
    threshold : float
        The threshold on the excess ``metric - floor`` (metric units; e.g. ``-0.1``: at most 0.1
        below what a render with no artefact scores at the same view).
    grid : sequence of tuple
        The views the horizon judges (:func:`grid_of`).

    Returns
    -------
    pandas.DataFrame
        :data:`nvrq.horizon.VIEW_COLUMNS` plus ``floor`` and ``floor_method``, one row per view
        of ``grid``. When every view of the grid has a floor, each view's threshold is
        ``floor + threshold``; otherwise every view keeps ``threshold`` (``floor`` NaN), and
        ``source`` names the views without one.
    """
    f = floor.assign(offset=lambda d: d["offset"].astype(float))
    table = {(a, o): v for a, o, v in zip(f["axis"], f["offset"], f["floor"], strict=True) if math.isfinite(v)}
    method = str(f["method"].iloc[0]) if "method" in f.columns and len(f) else "perfect"
    missing = [view_label(*k) for k in grid if k not in table]
    if missing:
        source = (f"given (a fixed threshold; no viewpoint floor at {', '.join(missing[:3])}"
                  + (f" and {plural(len(missing) - 3, 'other view')})" if len(missing) > 3 else ")"))
    else:
        source = (f"given, over the viewpoint floor (median of method {method} per view): "
                  f"metric - floor against {threshold:g}")
    fl = [math.nan if missing else table[k] for k in grid]
    return pd.DataFrame({"axis": [k[0] for k in grid], "offset": [k[1] for k in grid],
                         "threshold": [threshold + (0.0 if missing else v) for v in fl],
                         "source": source, "floor": fl, "floor_method": method},
                        columns=[*VIEW_COLUMNS, "floor", "floor_method"])
