"""``analyze --horizon``: the trust horizon of an analysis (docs/FORMATS.md §15).

Layer: ``analysis`` (it joins the analysis' items, the votes and the options, and calls the
pure computation of :mod:`nvrq.horizon`; :mod:`analysis.horizon_report` writes the files).

- Ratings: the threshold of each metric where P(good | metric) = ``good_prob``
  (:func:`analysis.horizon_fit.vote_threshold` on the kept raters' test votes), and the
  horizon of the rated items on the horizon's metric (its fitted threshold, or ``threshold``).
- Pairs: the horizon of every pair on the metric at ``threshold`` (no votes, so the threshold
  is given); with ``camera`` and ``timestamp_us`` also the timeline.

:func:`pairs_items` reads the pairs when the analysis' items lack the time columns, and
:func:`horizon_only_analysis` builds the analysis of an ``analyze --pairs --horizon`` run
that has neither ``--target`` nor ``--compare-methods``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from analysis import axes, breakdowns
from analysis.choices import MIN_CLUSTERS
from data_schema.errors import InputError
from data_schema.text import plural
from nvrq.horizon import (
    DEFAULT_SHARE,
    Threshold,
    horizon_timeline,
    resolve_metric,
    share_curves,
    trust_horizon,
)

__all__ = ["HorizonOptions", "HorizonResult", "for_ratings", "for_pairs",
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
    """

    metric: str | None = None
    threshold: float | None = None
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
    """

    threshold: Threshold
    table: pd.DataFrame
    curves: pd.DataFrame
    timeline: pd.DataFrame | None
    fits: pd.DataFrame | None
    options: HorizonOptions
    notes: list[str] = field(default_factory=list)


def _directions(metric: str, directions: dict) -> bool:
    return bool(directions.get(metric, True))


def _metric(opts: HorizonOptions, metrics: list[str]) -> str:
    return resolve_metric(opts.metric, metrics, param="metric")


def _vote_fits(votes: pd.DataFrame, items: pd.DataFrame, metrics, directions, opts) -> pd.DataFrame:
    """horizon_thresholds.csv: per metric, the threshold of :func:`vote_threshold`."""
    from analysis.horizon_fit import vote_threshold

    pos = pd.Index(items["item_id"].astype(str)).get_indexer(votes["item_id"].astype(str))
    v, it = votes[pos >= 0], items.iloc[pos[pos >= 0]].reset_index(drop=True)
    rater = pd.factorize(v["rater_id"].astype(str))[0]
    track = pd.factorize(pd.MultiIndex.from_arrays([it["clip_id"].astype(str), it["track_id"].astype(str)]))[0]
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


def _result(items: pd.DataFrame, th: Threshold, opts: HorizonOptions, fits, where) -> HorizonResult:
    _check_views(items, where)
    notes = []
    kw = {"threshold": th, "share": opts.share}
    table = trust_horizon(items, n_boot=opts.n_boot, seed=opts.seed, min_clusters=opts.min_clusters, **kw)
    timeline = None
    if "timestamp_us" in items.columns:
        timeline = horizon_timeline(items, window_s=opts.window_s, n_boot=opts.n_boot, seed=opts.seed,
                                    min_clusters=opts.min_clusters, **kw)
    else:
        notes.append("no timeline: the items have no timestamp_us")
    return HorizonResult(th, table, share_curves(items, **kw), timeline, fits, opts, notes)


def for_ratings(analysis, votes: pd.DataFrame, opts: HorizonOptions, *, where=None) -> HorizonResult:
    """The horizon of a ratings analysis (module docstring).

    Parameters
    ----------
    analysis : analysis.pipeline.Analysis
        The ratings analysis (its items, metrics, directions and rater table).
    votes : pandas.DataFrame
        The ratings (one row per vote, :func:`analysis.inputs.read_ratings`).
    opts : HorizonOptions
    where : str or Path, optional
        The ratings file, named in errors.

    Returns
    -------
    HorizonResult
        Threshold given or fitted to the votes, with the vote fits kept.
    """
    metric = _metric(opts, analysis.metrics)
    excluded = set(analysis.raters.loc[analysis.raters["excluded"].astype(bool), "rater_id"].astype(str))
    test = votes[(votes["kind"] == "test") & ~votes["rater_id"].astype(str).isin(excluded)]
    fits = _vote_fits(test, analysis.items, analysis.metrics, analysis.directions, opts)
    higher = _directions(metric, analysis.directions)
    th = (Threshold(metric, float(opts.threshold), higher, "given (a fixed threshold)")
          if opts.threshold is not None else _human_threshold(fits, metric, higher, opts))
    return _result(analysis.items, th, opts, fits, where)


def for_pairs(analysis, items: pd.DataFrame, opts: HorizonOptions, *, where=None) -> HorizonResult:
    """The horizon of an ``analyze --pairs`` analysis at the given threshold.

    Parameters
    ----------
    analysis : analysis.pipeline.Analysis
        The analysis (its metrics and directions).
    items : pandas.DataFrame
        Its per-pair items with ``camera`` and ``timestamp_us`` (:func:`pairs_items`).
    opts : HorizonOptions
        With ``threshold`` set (no votes here to fit one to).
    where : str or Path, optional
        The pairs input, named in errors.

    Returns
    -------
    HorizonResult
        At the given threshold, without vote fits.
    """
    metric = _metric(opts, analysis.metrics)
    th = Threshold(metric, float(opts.threshold), _directions(metric, analysis.directions),
                   "given (a fixed threshold)")
    return _result(items, th, opts, None, where)


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
    from analysis.inputs import classify_columns, drop_empty_columns
    from analysis.pipeline import Analysis
    from analysis.summary import summary_table
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
