"""``analyze --horizon``: the trust horizon of an analysis (docs/FORMATS.md §15).

Layer: ``analysis`` (it joins the analysis' items, the votes and the options, and calls the
pure computation of :mod:`nvrq.horizon`; :mod:`analysis.report.horizon_report` writes the files).

- Ratings: the threshold of each metric where P(good | metric) = ``good_prob``
  (:func:`analysis.stats.horizon_fit.vote_threshold` on the kept raters' test votes), and the
  horizon of the rated items on the horizon's metric. By default each view gets its own
  threshold from a monotone fit of the votes inside the view, or from one logistic with an
  intercept per view and a shared slope (``view_fit``, :func:`analysis.stats.horizon_views.people_views`);
  ``pooled`` uses the one pooled threshold,
  and ``threshold`` or ``threshold_table`` a given one.
- Pairs: the horizon of every pair on the metric at a given threshold (no votes): a per-view
  ``threshold_table``, or ``threshold`` applied to the excess over the viewpoint floor where
  the pairs have one (:func:`analysis.stats.horizon_views.floor_views`) and to the metric itself
  otherwise; with ``camera`` and ``timestamp_us`` also the timeline.

:func:`pairs_items` reads the pairs when the analysis' items lack the time columns, and
:func:`horizon_only_analysis` builds the analysis of an ``analyze --pairs --horizon`` run
that has neither ``--target`` nor ``--compare-methods``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from analysis.common.choices import MIN_CLUSTERS
from analysis.tables import axes, breakdowns
from data_schema.errors import InputError
from data_schema.text import plural
from data_schema.vocab import ItemKind
from nvrq.horizon import (
    DEFAULT_SHARE,
    Threshold,
    horizon_timeline,
    resolve_metric,
    share_curves,
    trust_horizon,
)

__all__ = ["HorizonOptions", "HorizonResult", "THRESHOLD_KINDS", "for_ratings", "for_pairs",
           "horizon_only_analysis", "pairs_items", "FIT_COLUMNS"]

#: horizon_thresholds.csv: one row per metric of a ratings analysis.
FIT_COLUMNS = ["metric", "threshold", "ci_lo", "ci_hi", "good_prob", "slope", "n_votes", "n_raters",
               "n_tracks", "reason"]


@dataclass(frozen=True)
class HorizonOptions:
    """The options of ``--horizon`` (checked by ``analyze``'s option types, once, at the boundary).

    Parameters
    ----------
    metric : str, optional
        The horizon's metric (``--metric``; default NVRQ-CA of the first encoder).
    threshold : float, optional
        A given threshold (``--threshold``); required without votes.
    share : float
        The share of good objects each grid offset needs, in (0, 1].
    good_prob : float
        P(good) at the human threshold, in (0, 1).
    window_s : float
        The timeline's window, seconds (> 0).
    min_clusters, n_boot, seed : int
        The fewest tracks for an interval; bootstrap replicates and seed.
    threshold_table : str or Path, optional
        A per-view threshold table (``--threshold-table``, :func:`analysis.stats.horizon_views.read_view_table`).
    pooled : bool
        With votes: one threshold for every view (the pooled logistic) instead of one per view.
    view_fit : {'monotone', 'logistic'}
        With votes: the per-view fit (:func:`analysis.stats.horizon_views.people_views`).
    by_class : bool
        With votes and a threshold per view: each class also gets its own threshold at the views
        where it has enough votes (:func:`analysis.stats.horizon_views.people_views`).
    floor : bool
        With a given ``threshold``: apply it to the excess over the viewpoint floor where the
        items have one (:func:`analysis.stats.horizon_views.floor_views`); False: to the metric itself.
    """

    metric: str | None = None
    threshold: float | None = None
    threshold_table: str | None = None
    pooled: bool = False
    view_fit: str = "monotone"
    by_class: bool = True
    floor: bool = True
    share: float = DEFAULT_SHARE
    good_prob: float = 0.5
    window_s: float = 2.0
    min_clusters: int = MIN_CLUSTERS
    n_boot: int = 1000
    seed: int = 0


@dataclass
class HorizonResult:
    """Everything the horizon's files and report section show.

    Attributes
    ----------
    threshold : nvrq.horizon.Threshold
        The metric threshold the horizon is measured against.
    table : pandas.DataFrame
        The horizon table (horizon.csv).
    curves : pandas.DataFrame
        The share curves (:func:`nvrq.horizon.share_curves`).
    timeline : pandas.DataFrame or None
        The timeline (horizon_timeline.csv), or None.
    fits : pandas.DataFrame or None
        The threshold fits (horizon_thresholds.csv, ratings only), or None.
    options : HorizonOptions
        The options used.
    notes : list of str
        Notes for the report.
    kind : str
        Which threshold judged the objects (:data:`THRESHOLD_KINDS`).
    views : pandas.DataFrame or None
        The per-view thresholds (horizon_view_thresholds.csv), or None for one threshold.
    """

    threshold: Threshold
    table: pd.DataFrame
    curves: pd.DataFrame
    timeline: pd.DataFrame | None
    fits: pd.DataFrame | None
    options: HorizonOptions
    notes: list[str] = field(default_factory=list)
    kind: str = "given"
    views: pd.DataFrame | None = None


#: horizon.json's ``threshold_kind`` of each row: where its threshold came from.
THRESHOLD_KINDS = {
    "people_view": "people: a threshold per view (a monotone fit per view, or a logistic with an "
                   "intercept per view and a shared slope), of the row's class where it has enough votes there",
    "people_pooled": "people: one logistic for every view",
    "given": "given: one threshold for every view",
    "given_view": "given: a per-view threshold table",
    "floor": "given: one threshold on the excess over the viewpoint floor",
}


def _directions(metric: str, directions: dict) -> bool:
    return bool(directions.get(metric, True))


def _metric(opts: HorizonOptions, metrics: list[str]) -> str:
    return resolve_metric(opts.metric, metrics, param="metric")


def _joined(votes: pd.DataFrame, items: pd.DataFrame):
    """``(votes, their items, rater codes, track codes)`` for the votes of known items."""
    pos = pd.Index(items["item_id"].astype(str)).get_indexer(votes["item_id"].astype(str))
    v, it = votes[pos >= 0], items.iloc[pos[pos >= 0]].reset_index(drop=True)
    rater = pd.factorize(v["rater_id"].astype(str))[0]
    track = pd.factorize(pd.MultiIndex.from_arrays([it["clip_id"].astype(str), it["track_id"].astype(str)]))[0]
    return v, it, rater, track


def _vote_fits(votes: pd.DataFrame, items: pd.DataFrame, metrics, directions, opts) -> pd.DataFrame:
    """horizon_thresholds.csv: per metric, the threshold of :func:`vote_threshold`."""
    from analysis.stats.horizon_fit import vote_threshold

    v, it, rater, track = _joined(votes, items)
    y = v["vote"].to_numpy(np.float64)
    rows = []
    for m in metrics:
        x = it[m].to_numpy(np.float64)
        ok = np.isfinite(x)
        r = vote_threshold(x[ok], y[ok], pd.factorize(rater[ok])[0], pd.factorize(track[ok])[0],
                           good_prob=opts.good_prob, n_boot=opts.n_boot, seed=opts.seed)
        rows.append({"metric": m, "threshold": r["value"], "ci_lo": r["ci_lo"], "ci_hi": r["ci_hi"],
                     "good_prob": opts.good_prob, "slope": r["b"], "n_votes": r["n_votes"],
                     "n_raters": r["n_raters"], "n_tracks": r["n_tracks"], "reason": r["reason"]})
    return pd.DataFrame(rows, columns=FIT_COLUMNS)


def _human_threshold(fits: pd.DataFrame, metric: str, higher: bool, opts) -> Threshold:
    row = fits.set_index("metric").loc[metric]
    if not math.isfinite(row["threshold"]):
        raise InputError(param="metric", field=metric, expected="a metric whose votes give a "
                         "threshold (or a given `threshold`)", got=row["reason"])
    source = (f"people: P(good) = {opts.good_prob:g} on a logistic fit to {plural(row['n_votes'], 'vote')} of "
              f"{plural(row['n_raters'], 'rater')} (95% bootstrap over raters and tracks)")
    return Threshold(metric, float(row["threshold"]), higher, source, float(row["ci_lo"]), float(row["ci_hi"]))


def _check_views(items: pd.DataFrame, where) -> None:
    """Refuse items with fewer than two offsets along every axis (no horizon to find)."""
    from data_schema.perturbation import AXES

    names, values = axes.item_axes(items)
    zero = int((names == "none").any())
    counts = [len(np.unique(np.round(values[names == a], 2))) + zero for a in AXES if (names == a).any()]
    if max(counts, default=zero) < 2:
        raise InputError(where, "view columns (y_offset_m, ...)", "at least two offsets along an axis "
                         "(the recorded view and one more) to find a horizon", "one offset per axis")


def _given(items: pd.DataFrame, metric: str, higher: bool, opts: HorizonOptions):
    """``(threshold, kind, views)`` of a given threshold: a per-view table, one value over the
    viewpoint floor where the items have one, or one value."""
    from analysis.stats import horizon_views as hv

    if opts.threshold_table is not None:
        views = hv.read_view_table(opts.threshold_table, hv.grid_of(items), metric=metric)
        return Threshold(metric, math.nan, higher, views["source"].iloc[0], views=views), "given_view", views
    fixed = Threshold(metric, float(opts.threshold), higher, "given (a fixed threshold)")
    floor = hv.viewpoint_floor(items, metric) if opts.floor else None
    if floor is None or floor.empty:
        return fixed, "given", None
    views = hv.floor_views(floor, float(opts.threshold), hv.grid_of(items))
    if views["floor"].isna().all():
        return Threshold(metric, fixed.value, higher, views["source"].iloc[0]), "given", None
    return Threshold(metric, fixed.value, higher, views["source"].iloc[0], views=views), "floor", views


def _people_views(votes, items, metric, higher, fits, opts) -> tuple[Threshold, pd.DataFrame]:
    """The per-view threshold of ``metric`` from the votes (analysis.stats.horizon_views.people_views)."""
    from analysis.stats.horizon_views import people_views
    from data_schema.perturbation import PERTURBATION_COLUMNS

    v, it, rater, track = _joined(votes, items)
    x = it[metric].to_numpy(np.float64)
    ok = np.isfinite(x)
    table = it.loc[ok, [c for c in PERTURBATION_COLUMNS if c in it.columns]].assign(
        x=x[ok], vote=v["vote"].to_numpy(np.float64)[ok], rater=pd.factorize(rater[ok])[0],
        track=pd.factorize(track[ok])[0], label_class=it["label_class"].astype(str).to_numpy()[ok])
    views = people_views(metric, table, good_prob=opts.good_prob, n_boot=opts.n_boot, seed=opts.seed,
                         fit=opts.view_fit, increasing=higher, by_class=opts.by_class)
    row = fits.set_index("metric").loc[metric]
    if not np.isfinite(views["threshold"]).any():
        raise InputError(param="metric", field=metric, expected="a metric whose votes give a threshold per "
                         "view (or a given `threshold`)", got=views["reason"].iloc[0] or "no threshold")
    th = Threshold(metric, float(row["threshold"]), higher, views["source"].iloc[0], float(row["ci_lo"]),
                   float(row["ci_hi"]), views=views)
    return th, views


def _result(items: pd.DataFrame, th: Threshold, opts: HorizonOptions, fits, where, kind: str = "given",
            views: pd.DataFrame | None = None) -> HorizonResult:
    _check_views(items, where)
    notes = []
    if kind == "floor":
        method = views["floor_method"].iloc[0]
        notes.append(f"the threshold {opts.threshold:g} applies to {th.metric} minus the viewpoint floor (the "
                     f"median of method {method} at each view); with `floor` off it applies to {th.metric} itself")
    kw = {"threshold": th, "share": opts.share}
    table = trust_horizon(items, n_boot=opts.n_boot, seed=opts.seed, min_clusters=opts.min_clusters, **kw)
    timeline = None
    if "timestamp_us" in items.columns:
        timeline = horizon_timeline(items, window_s=opts.window_s, n_boot=opts.n_boot, seed=opts.seed,
                                    min_clusters=opts.min_clusters, **kw)
    else:
        notes.append("no timeline: the items have no timestamp_us")
    return HorizonResult(th, table, share_curves(items, **kw), timeline, fits, opts, notes, kind, views)


def for_ratings(analysis, votes: pd.DataFrame, opts: HorizonOptions, *, where=None) -> HorizonResult:
    """The horizon of a ratings analysis (module docstring).

    Parameters
    ----------
    analysis : analysis.pipeline.Analysis
        The ratings analysis (its items, metrics, directions and rater table).
    votes : pandas.DataFrame
        The ratings (one row per vote, :func:`analysis.tables.inputs.read_ratings`).
    opts : HorizonOptions
    where : str or Path, optional
        The ratings file, named in errors.

    Returns
    -------
    HorizonResult
        Threshold given, or fitted to the votes (per view by default, pooled with
        ``opts.pooled``), with the vote fits kept.
    """
    metric = _metric(opts, analysis.metrics)
    excluded = set(analysis.raters.loc[analysis.raters["excluded"].astype(bool), "rater_id"].astype(str))
    test = votes[(votes["kind"] == ItemKind.TEST) & ~votes["rater_id"].astype(str).isin(excluded)]
    fits = _vote_fits(test, analysis.items, analysis.metrics, analysis.directions, opts)
    higher = _directions(metric, analysis.directions)
    if opts.threshold is not None or opts.threshold_table is not None:
        th, kind, views = _given(analysis.items, metric, higher, opts)
        return _result(analysis.items, th, opts, fits, where, kind, views)
    if opts.pooled:
        return _result(analysis.items, _human_threshold(fits, metric, higher, opts), opts, fits, where,
                       "people_pooled")
    th, views = _people_views(test, analysis.items, metric, higher, fits, opts)
    return _result(analysis.items, th, opts, fits, where, "people_view", views)


def for_pairs(analysis, items: pd.DataFrame, opts: HorizonOptions, *, where=None) -> HorizonResult:
    """The horizon of an ``analyze --pairs`` analysis at the given threshold.

    Parameters
    ----------
    analysis : analysis.pipeline.Analysis
        The analysis (its metrics and directions).
    items : pandas.DataFrame
        Its per-pair items with ``camera`` and ``timestamp_us`` (:func:`pairs_items`).
    opts : HorizonOptions
        With ``threshold`` or ``threshold_table`` set (no votes here to fit one to).
    where : str or Path, optional
        The pairs input, named in errors.

    Returns
    -------
    HorizonResult
        At the given threshold (per view from the table, or over the viewpoint floor where the
        items have one and ``opts.floor``), without vote fits.
    """
    metric = _metric(opts, analysis.metrics)
    th, kind, views = _given(items, metric, _directions(metric, analysis.directions), opts)
    return _result(items, th, opts, None, where, kind, views)


def pairs_items(analysis, pairs_path, metrics_paths, *, progress: bool) -> pd.DataFrame:
    """The per-pair items with ``camera`` and ``timestamp_us``: the analysis' own when it has
    them (``--compare-methods`` reads them), else the pairs read again with them.

    Parameters
    ----------
    analysis : analysis.pipeline.Analysis
        The all-pairs analysis.
    pairs_path : str or pathlib.Path
        The pairs input, as :func:`analysis.all_pairs.read_all_pairs`.
    metrics_paths : sequence of str or pathlib.Path
        The metrics tables or datasets.
    progress : bool
        Show the read's progress bar.

    Returns
    -------
    pandas.DataFrame
        One row per pair, with ``camera`` and ``timestamp_us`` columns.
    """
    if {"camera", "timestamp_us"} <= set(analysis.items.columns):
        return analysis.items
    from analysis.all_pairs import read_all_pairs

    items, clusters, _ = read_all_pairs(pairs_path, metrics_paths=metrics_paths, progress=progress,
                                        keep=("camera", "timestamp_us"))
    return items


def horizon_only_analysis(pairs_path, metrics_paths, *, lower=(), higher=(), progress: bool = True):
    """The :class:`~analysis.pipeline.Analysis` of ``analyze --pairs --horizon`` without a target
    or a leaderboard: the items (with ``camera`` and ``timestamp_us``), metrics and per-view
    tables, nothing correlated.

    Parameters
    ----------
    pairs_path : str or Path
        As :func:`analysis.all_pairs.run_pairs_analysis`.
    metrics_paths, lower, higher : sequence
        The metrics tables and the directions of unknown metric columns.
    progress : bool, optional
        Show the read's progress bar.

    Returns
    -------
    analysis.pipeline.Analysis
        With ``target = None``, ``source = 'pairs'`` and empty summary and breakdowns.
    """
    from analysis.all_pairs import RATER_COLUMNS, read_all_pairs
    from analysis.pipeline import Analysis
    from analysis.tables.inputs import classify_columns, drop_empty_columns
    from analysis.tables.summary import summary_table
    from data_schema import datasets as ds

    items, clusters, unknown = read_all_pairs(pairs_path, metrics_paths=metrics_paths, progress=progress,
                                              keep=("camera", "timestamp_us"))
    notes = [f"all-pairs analysis: {len(items)} pairs, no votes; no target (the trust horizon only)"]
    numeric = [c for c in items.columns if pd.api.types.is_numeric_dtype(items[c])]
    items, empty = drop_empty_columns(items, keep=[c for c in items.columns if c not in numeric]
                                      + ["timestamp_us"], unit="pair")
    metrics, directions, attributes, proxies = classify_columns(
        items.drop(columns=["timestamp_us"], errors="ignore"), lower=set(lower), higher=set(higher),
        target=None, where=pairs_path)
    summary = summary_table(items, [], directions, target="y_offset_m", clusters=clusters, n_boot=0,
                            progress=False)
    by_offset, by_axis = axes.view_tables(items, metrics)
    counts = {"votes": 0, "test_votes": 0, "test_votes_kept": 0, "items": len(items),
              "tracks": int(clusters.max()) + 1 if len(clusters) else 0,
              "clips": int(items[ds.PARTITION].nunique()), "raters": 0, "raters_simulated": 0,
              "raters_excluded": 0, "gold_votes": 0, "repeat_votes": 0}
    return Analysis(ratings_path=str(pairs_path), target=None, items=items, metrics=metrics,
                    directions=directions, attributes=attributes, proxies=proxies, summary=summary,
                    categories=breakdowns.category_table(items, [], by=["label_class"], target="y_offset_m",
                                                         progress=False),
                    by_offset=by_offset, by_axis=by_axis, encoders=breakdowns.encoder_table(summary),
                    raters=pd.DataFrame(columns=RATER_COLUMNS), alpha={}, counts=counts,
                    notes=notes + empty, unknown_ids=unknown, source="pairs")
