"""``analyze`` as one function: ratings (+ metric tables) in, every result table out.

:func:`run_analysis` is a short sequence of stages: read the inputs, screen the raters,
agreement, item labels (GVF and, with ``aggregate_method``, a crowd-kit posterior), join the
metrics, classify columns, the summary with the noise ceiling, breakdowns, and the
majority-against-model comparison. It writes
nothing; :mod:`analysis.report.report` writes the report directory.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import pandas as pd

from analysis.common.text import no_votes_left
from analysis.methods import MethodsResult, for_analysis
from analysis.options import AnalysisOptions, SummaryOptions, analysis_options
from analysis.stats.ceiling import noise_ceiling, vote_matrix
from analysis.stats.noninferiority import DEFAULT_MARGIN
from analysis.tables import axes, breakdowns, within_view
from analysis.tables.aggregate import aggregate
from analysis.tables.inputs import classify_columns, drop_empty_columns, read_metrics, read_ratings
from analysis.tables.labels import item_table, join_metrics
from analysis.tables.summary import summary_table
from annotate import screening
from annotate.results import alpha_nominal
from data_schema.errors import InputError, check_number
from data_schema.tables import TIMING_COLUMNS, read_table, timing_path
from data_schema.vocab import ItemKind

__all__ = ["Analysis", "run_analysis", "read_timing", "find_timing_files", "read_stability",
           "boot_size", "BOOT_CELL_LIMIT", "with_view_statistics"]

#: Above this many item-replicates (items x --bootstrap) the bootstrap is skipped, with a
#: note in the report (the point estimates are still exact; CIs would take too long).
BOOT_CELL_LIMIT = 500_000_000


@dataclass
class Analysis:
    """Everything the report shows. Tables are pandas DataFrames (see each module).

    Attributes
    ----------
    ratings_path : str
        The input ratings table (or pairs input).
    target : str
        The target column the metrics are compared with.
    items : pandas.DataFrame
        One row per item (or pair) with the target, metrics and labels.
    metrics : list of str
        The metric columns.
    directions : dict of str to bool
        Per metric, whether higher is better.
    attributes : list of str
        The attribute (label) columns the breakdowns use.
    proxies : list of str
        The proxy columns classified apart from the metrics.
    summary : pandas.DataFrame
        Per-metric agreement with the target.
    categories : pandas.DataFrame
        The per-category breakdown.
    by_offset : pandas.DataFrame
        The per-offset view table.
    encoders : pandas.DataFrame
        The per-encoder table.
    raters : pandas.DataFrame
        The rater screening table.
    alpha : dict
        Inter-rater agreement of all raters and of the kept raters.
    counts : dict
        Counts of votes, items, raters and tracks.
    timing : pandas.DataFrame or None
        Metric timing (:func:`read_timing`), or None.
    stability : pandas.DataFrame or None
        The stability table (:func:`read_stability`), or None.
    snr : pandas.DataFrame or None
        The SNR table (:func:`read_stability`), or None.
    by_axis : pandas.DataFrame or None
        The per-axis view table, or None.
    notes : list of str
        Notes for the report.
    unknown_ids : dict of str to int
        Per metrics path, the pair ids that are not rated items.
    n_boot : int
        Bootstrap replicates (0: none).
    seed : int
        The random seed.
    rank_by : str
        The statistic metrics are ranked by (e.g. ``"srcc"``).
    screen : bool
        Whether the screening rule excluded raters.
    ceiling : dict
        The noise ceiling of the votes (empty for a non-vote target).
    comparison : dict or None
        The model comparison, or None.
    source : str
        ``"ratings"``, or ``"pairs"`` for ``analyze --pairs``.
    margin : float
        The non-inferiority margin (:mod:`analysis.stats.noninferiority`).
    methods : MethodsResult or None
        The leaderboard with ``--compare-methods``, or None.
    horizon : analysis.horizon.HorizonResult or None
        The ``--horizon`` result, or None.
    floor : analysis.tables.real_floor.FloorResult or None
        The ``--real-floor`` result, or None.
    viewpoint_floor : pandas.DataFrame or None
        ``--floor-pairs`` / ``--floor-metrics``: the tent plot's viewpoint floor
        (:func:`analysis.common.viewpoint_floor.floor_by_offset`), or None.
    """

    ratings_path: str
    target: str
    items: pd.DataFrame
    metrics: list[str]
    directions: dict[str, bool]
    attributes: list[str]
    proxies: list[str]
    summary: pd.DataFrame
    categories: pd.DataFrame
    by_offset: pd.DataFrame
    encoders: pd.DataFrame
    raters: pd.DataFrame
    alpha: dict
    counts: dict
    timing: pd.DataFrame | None = None
    stability: pd.DataFrame | None = None
    snr: pd.DataFrame | None = None
    by_axis: pd.DataFrame | None = None
    notes: list[str] = field(default_factory=list)
    unknown_ids: dict[str, int] = field(default_factory=dict)
    n_boot: int = 0
    seed: int = 0
    rank_by: str = "srcc"
    screen: bool = True
    ceiling: dict = field(default_factory=dict)
    comparison: dict | None = None
    source: str = "ratings"  # or "pairs": analyze --pairs (no votes; see analysis.all_pairs)
    margin: float = DEFAULT_MARGIN  # non-inferiority margin (analysis.stats.noninferiority)
    methods: MethodsResult | None = None  # the leaderboard with compare_methods
    horizon: object | None = None  # analyze --horizon: an analysis.horizon.HorizonResult
    floor: object | None = None  # analyze --real-floor: an analysis.tables.real_floor.FloorResult
    viewpoint_floor: pd.DataFrame | None = None  # analyze --floor-pairs: the tents' floor
    view_text: str | None = None  # the view-only / within-view sentence (analysis.tables.within_view)
    visibility: pd.DataFrame | None = None  # per gt_visible x novel_visible bin (within_view)
    visibility_note: str | None = None  # why there is no visibility table


def with_view_statistics(a: Analysis, *, clusters: np.ndarray) -> Analysis:
    """``a`` with the within-view columns and the view-only rows in its summary, the headline
    sentence and the visibility table (:mod:`analysis.tables.within_view`).

    Parameters
    ----------
    a : Analysis
        A finished analysis (its summary ranks the metrics against ``a.target``).
    clusters : (n_items,) int numpy.ndarray
        Track index of each item, as the summary's bootstrap used.

    Returns
    -------
    Analysis
        A copy with ``summary``, ``items`` (plus the view-only columns), ``view_text`` and
        ``visibility`` or ``visibility_note`` filled.
    """
    if a.target is None or len(a.summary) == 0:
        return a
    from analysis.tables.summary import binary_label

    label, _ = binary_label(a.items, a.target)

    def summarize(frame, cols, dirs):
        return summary_table(frame, cols, dirs, SummaryOptions(
            target=a.target, n_boot=a.n_boot, seed=a.seed, rank_by=a.rank_by, progress=False),
            clusters=clusters)

    summary, text, vis, note = within_view.extend_summary(
        a.summary, a.items, a.directions,
        within_view.ViewInputs(a.target, label, clusters, n_boot=a.n_boot, seed=a.seed),
        rank_by=a.rank_by, summarize=summarize)
    _ceiling_columns(summary, a.ceiling)  # the view-only rows share the votes' ceiling
    items = a.items.assign(**within_view.view_only_columns(a.items))  # the rows' scores (ROC plot)
    return replace(a, summary=summary, items=items, view_text=text, visibility=vis,
                   visibility_note=note)


def read_timing(paths) -> pd.DataFrame | None:
    """Concatenate ``*.timing.csv`` files (``metric, seconds, pairs``): one row per metric with
    summed seconds and pairs and ``pairs_per_s``.

    Parameters
    ----------
    paths : sequence of str or pathlib.Path
        The timing tables.

    Returns
    -------
    pandas.DataFrame or None
        One row per metric (``seconds``, ``pairs``, ``pairs_per_s`` and any of ``runtime``,
        ``precision``, ``threads``, ``device``); None without any file.
    """
    frames = [
        read_table(p, required=TIMING_COLUMNS, what="timing table") for p in paths
    ]
    if not frames:
        return None
    t = pd.concat(frames, ignore_index=True)
    for c in ("seconds", "pairs"):
        v = pd.to_numeric(t[c], errors="coerce")
        if v.isna().any() or (v < 0).any():
            raise InputError(
                "timing table",
                f"column {c!r}",
                "non-negative numbers",
                t[c][v.isna() | (v < 0)].iloc[0],
            )
        t[c] = v
    info = [c for c in ("runtime", "precision", "threads", "device") if c in t.columns]  # optional
    first = t.groupby("metric", as_index=False)[info].first() if info else None
    t = t.groupby("metric", as_index=False)[["seconds", "pairs"]].sum()
    if first is not None:
        t = t.merge(first, on="metric", how="left")
    with np.errstate(divide="ignore", invalid="ignore"):
        t["pairs_per_s"] = np.where(t["seconds"] > 0, t["pairs"] / t["seconds"], np.nan)
    return t


def find_timing_files(timing_paths, metrics_paths) -> list:
    """The ``--timing`` files, then the ``METRICS.timing.csv`` that exist beside the metrics tables.

    Parameters
    ----------
    timing_paths : sequence of str or pathlib.Path
        The ``--timing`` files.
    metrics_paths : sequence of str or pathlib.Path
        The metrics tables.

    Returns
    -------
    list
        The timing file paths, ``--timing`` ones first.
    """
    return list(timing_paths) + [timing_path(p) for p in metrics_paths if timing_path(p).is_file()]


def read_stability(directory):
    """``DIR/stability.csv`` and ``DIR/snr.csv`` if present: ``(stability, snr)`` or Nones.

    Parameters
    ----------
    directory : str or pathlib.Path
        The folder holding ``stability.csv`` and/or ``snr.csv``.

    Returns
    -------
    stability : pandas.DataFrame or None
        The stability table, or None when absent.
    snr : pandas.DataFrame or None
        The SNR table, or None when absent.

    Raises
    ------
    InputError
        When the folder does not exist or holds neither file.
    """
    d = Path(directory)
    if not d.is_dir():
        raise InputError(d, None, "a directory with stability.csv / snr.csv", "no such directory")
    st = sn = None
    if (d / "stability.csv").is_file():
        st = read_table(
            d / "stability.csv",
            what="stability table",
            required=("metric", "nuisance_or_artefact", "kind", "strength", "mean_abs_change"),
        )
    if (d / "snr.csv").is_file():
        sn = read_table(d / "snr.csv", required=("metric", "snr"), what="SNR table")
    if st is None and sn is None:
        raise InputError(d, None, "stability.csv or snr.csv in the directory", "neither")
    return st, sn


def _read_inputs(ratings_path, metrics_paths, timing_paths):
    votes = read_ratings(ratings_path)
    tables = [(str(p), read_metrics(p)) for p in metrics_paths]
    return votes, tables, find_timing_files(timing_paths, metrics_paths)


def _screen_raters(votes, ratings_path, *, screen, exclude_raters):
    raters = screening.screen(
        screening.rater_table(votes), use_rule=screen, exclude=list(exclude_raters)
    )
    excluded = set(raters.loc[raters["excluded"], "rater_id"])
    kept = votes[~votes["rater_id"].isin(excluded)]
    if not (kept["kind"] == ItemKind.TEST).any():
        raise InputError(ratings_path, "kind", no_votes_left(screen), "none")
    return raters, kept


def _agreement(votes, kept):
    alpha = {}
    for name, v in (("all raters", votes), ("kept raters", kept)):
        t = v[v["kind"] == ItemKind.TEST]
        a, why = alpha_nominal(t["item_id"], t["vote"])
        alpha[name] = {"alpha": a, "reason": why, "votes": len(t)}
    return alpha


def _labels(kept, raters, *, method, seed):
    """Item labels (GVF and, with a model, ``p_good``) and the rater table with model skills."""
    items = item_table(kept)
    test = kept[kept["kind"] == ItemKind.TEST]
    model_items, skills = aggregate(test, method=method, seed=seed)
    items = items.merge(model_items, on="item_id", how="left")
    if len(skills.columns) > 1:
        raters = raters.merge(skills, on="rater_id", how="left")
    return items, raters


def _check_target(items, target):
    if target is None:
        return
    if target not in items.columns or target in ("n_votes", "n_good", "majority_good"):
        raise InputError(
            param="target", field=target, expected="a numeric per-item column of the ratings or metrics",
            got="no such column",
        )
    if not pd.api.types.is_numeric_dtype(items[target]):
        raise InputError(param="target", field=target, expected="a numeric column", got=items[target].dtype)


def _columns(items, unknown, notes, *, target, tgt, lower, higher, where):
    items, empty_notes = drop_empty_columns(items, keep=(tgt,))
    notes += empty_notes
    classified = classify_columns(
        items, lower=set(lower), higher=set(higher), target=target, where=where
    )
    for path, n_unknown in unknown.items():
        if n_unknown:
            notes.append(f"{path}: {n_unknown} pair ids are not rated items (ignored)")
    return items, classified


def boot_size(items, n_boot, notes, *, unit: str = "item") -> int:
    """``n_boot``, or 0 with a note when ``items`` x ``n_boot`` is above :data:`BOOT_CELL_LIMIT`
    (``unit``: what a row of ``items`` is, for the note).

    Parameters
    ----------
    items : sized
        The rows to resample (its ``len`` is used).
    n_boot : int
        Requested bootstrap replicates.
    notes : list of str
        Report notes; a note is appended when the bootstrap is skipped.
    unit : str
        What a row of ``items`` is, for the note.

    Returns
    -------
    int
        ``n_boot``, or 0 when the bootstrap is too large.
    """
    if n_boot * len(items) > BOOT_CELL_LIMIT:
        notes.append(
            f"bootstrap skipped: {len(items)} {unit}s x {n_boot} replicates is above "
            f"{BOOT_CELL_LIMIT:.0e} {unit}-replicates; fewer bootstrap replicates give CIs"
        )
        return 0
    return n_boot


def _counts(votes, kept, items, raters, clusters):
    return {
        "votes": len(votes),
        "test_votes": int((votes["kind"] == ItemKind.TEST).sum()),
        "test_votes_kept": int((kept["kind"] == ItemKind.TEST).sum()),
        "items": len(items),
        "tracks": int(clusters.max()) + 1,
        "clips": int(items["clip_id"].nunique()),
        "raters": len(raters),
        "raters_simulated": int(raters["simulated"].sum()),
        "raters_excluded": int(raters["excluded"].sum()),
        "gold_votes": int((votes["kind"] == ItemKind.GOLD).sum()),
        "repeat_votes": int((votes["kind"] == ItemKind.REPEAT).sum()),
    }


def _ceiling(kept, summary, tgt, *, seed):
    """The noise ceiling of the votes, also as summary columns (NaN for a non-vote target)."""
    if tgt in ("gvf", "p_good"):
        ceiling = noise_ceiling(vote_matrix(kept[kept["kind"] == ItemKind.TEST]), seed=seed)
    else:
        ceiling = {**noise_ceiling(np.empty((0, 0))), "reason": f"target {tgt!r} is not the votes"}
    _ceiling_columns(summary, ceiling)
    return ceiling


def _ceiling_columns(summary, ceiling) -> None:
    """The noise ceiling as summary columns: the same for every row (it is the votes')."""
    for k in ("reliability", "plcc_ceiling", "srcc_ceiling"):
        if k in ceiling:
            summary[f"noise_{k}" if k == "reliability" else k] = ceiling[k]


def _model_comparison(items, metrics, directions, summary, tgt, *, method, seed):
    """Majority against the model, side by side: label counts and |SRCC| / ROC AUC per metric.

    ``summary`` (against ``tgt``) serves as the model's column when ``tgt`` is ``p_good``: the
    point estimates do not depend on the bootstrap."""
    if method == "majority":
        return None
    differ = int((items["majority_good"] != items["model_good"]).sum())
    kw = {"n_boot": 0, "seed": seed, "progress": False}
    maj = summary_table(items, metrics, directions, SummaryOptions(target="gvf", **kw))
    mod = summary if tgt == "p_good" else summary_table(items, metrics, directions,
                                                          SummaryOptions(target="p_good", **kw))
    table = pd.DataFrame({
        "metric": maj["metric"], "srcc_majority": maj["srcc"], f"srcc_{method}": mod["srcc"],
        "roc_auc_majority": maj["roc_auc"], f"roc_auc_{method}": mod["roc_auc"],
    })
    return {"method": method, "labels_differ": differ, "items": len(items),
            "good_majority": int(items["majority_good"].sum()),
            "good_model": int(items["model_good"].sum()), "table": table}


def run_analysis(ratings_path, options: AnalysisOptions | None = None, **keywords) -> Analysis:
    """The whole analysis of a ratings table (see the module docstring).

    Parameters
    ----------
    ratings_path : str or Path
        ``ratings.csv`` (or ``.parquet``) from ``annotate export`` (docs/FORMATS.md §5).
    options : analysis.options.AnalysisOptions, optional
        Every option (metrics and timing tables, target, screening, aggregation, bootstrap,
        margin, and ``compare`` for the method leaderboard); default ``AnalysisOptions()``.
    **keywords
        Deprecated spelling, kept for earlier callers: the fields of
        :class:`~analysis.options.AnalysisOptions` as keywords, with ``compare_methods=True``
        and ``methods``, ``rank_metric``, ``min_clusters``, ``by``, ``rank_view`` for
        ``compare`` (:func:`analysis.options.analysis_options`). Not together with ``options``.

    Returns
    -------
    Analysis
        Every result table; ``methods`` is the leaderboard with ``compare_methods``, else None.

    Raises
    ------
    InputError
        On bad input (files, columns, parameters), naming it.
    """
    o = analysis_options(keywords, options=options, who="run_analysis")
    check_number("margin", o.margin, low=0)
    votes, tables, timing_files = _read_inputs(ratings_path, o.metrics_paths, o.timing_paths)
    # every input file is read before the statistics (a bad --timing or --stability ends at once)
    timing = read_timing(timing_files)
    stab, snr = read_stability(o.stability_dir) if o.stability_dir is not None else (None, None)
    raters, kept = _screen_raters(votes, ratings_path, screen=o.screen,
                                  exclude_raters=o.exclude_raters)
    alpha = _agreement(votes, kept)
    items, raters = _labels(kept, raters, method=o.aggregate_method, seed=o.seed)
    items, unknown, notes = join_metrics(items, tables)
    for path, table in tables:
        if unknown[str(path)] == len(table):
            raise InputError(path, "pair_id", "pair ids of rated items", "none matches an item")
    _check_target(items, o.target)
    tgt = o.target or ("gvf" if o.aggregate_method == "majority" else "p_good")
    items, (metrics, directions, attributes, proxies) = _columns(
        items, unknown, notes, target=o.target, tgt=tgt, lower=o.lower, higher=o.higher,
        where=ratings_path)
    clusters = pd.factorize(
        pd.MultiIndex.from_arrays([items["clip_id"].astype(str), items["track_id"].astype(str)])
    )[0]
    n_boot = boot_size(items, o.n_boot, notes)
    summary = summary_table(items, metrics, directions, SummaryOptions(
        target=tgt, n_boot=n_boot, seed=o.seed, rank_by=o.rank_by, progress=o.progress), clusters=clusters)
    ceiling = _ceiling(kept, summary, tgt, seed=o.seed)
    by_cols, skipped = breakdowns.breakdown_columns(items, attributes)
    notes += [skipped] if skipped else []
    categories = breakdowns.category_table(items, metrics, by=by_cols, target=tgt, progress=o.progress)
    by_offset, by_axis = axes.view_tables(items, [tgt] + metrics, by="label_class")
    return with_view_statistics(Analysis(
        ratings_path=str(ratings_path), target=tgt, items=items, metrics=metrics,
        directions=directions, attributes=attributes, proxies=proxies, summary=summary,
        categories=categories, by_offset=by_offset, by_axis=by_axis,
        encoders=breakdowns.encoder_table(summary), raters=raters, alpha=alpha,
        counts=_counts(votes, kept, items, raters, clusters), timing=timing,
        stability=stab, snr=snr, notes=notes, unknown_ids=unknown, n_boot=n_boot, seed=o.seed,
        rank_by=o.rank_by, screen=o.screen, ceiling=ceiling,
        comparison=_model_comparison(items, metrics, directions, summary, tgt,
                                     method=o.aggregate_method, seed=o.seed),
        margin=o.margin,
        methods=for_analysis(items, target=tgt, metrics=metrics, directions=directions,
                             attributes=attributes,
                             options=replace(o.compare, n_boot=n_boot, seed=o.seed, progress=o.progress),
                             where=ratings_path, metrics_paths=o.metrics_paths)
        if o.compare is not None else None,
    ), clusters=clusters)
