"""``analyze --pairs``: every metric against a proxy column over all pairs, no votes needed
(paper Table 2 over 28.4M crop rows).

Input: one per-pair table with ``clip_id`` (``--pairs``: a pairs dataset partitioned by
``clip_id`` as ``nvrq pairs`` writes it for a fleet, or a single pairs/metrics table with a
``clip_id`` column) and any number of ``--metrics-table`` tables (``pair_id`` + numeric columns;
files or datasets), joined on ``pair_id``. Column roles follow
:func:`analysis.tables.inputs.classify_columns` (the same rule as the ratings path); the target is a
numeric column named by ``--target`` (e.g. ``clip_drop``).

Streaming: the pairs input is read clip by clip (only the columns the analysis uses; rows in
the canonical order, sorted by ``clip_id`` then ``pair_id``, docs/FORMATS.md §6), each
clip's rows of every metric dataset are joined to it (a zero-cost check when both list the
clip's pairs in the same order, else a hash join on ``pair_id``), and the result goes into
preallocated columns: float64 for numbers, int32 codes for labels. No ``pair_id`` string
outlives its clip, so memory is about 8 bytes per number per row plus the statistics'
working arrays. The items table then goes through the same
:func:`~analysis.tables.summary.summary_table`, :mod:`~analysis.tables.breakdowns`, per-view tables
(:func:`analysis.tables.axes.view_tables`: ``by_offset`` and, for 6-DoF pairs, ``by_axis`` with one
tent plot per axis) and report code as the ratings path.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq
import pyarrow.types as pt
from tqdm.auto import tqdm

from analysis.methods import for_analysis
from analysis.options import AnalysisOptions, SummaryOptions, analysis_options
from analysis.pipeline import (
    Analysis,
    boot_size,
    find_timing_files,
    read_timing,
    with_view_statistics,
)
from analysis.tables import axes, breakdowns
from analysis.tables.inputs import NON_METRIC_COLUMNS, classify_columns, drop_empty_columns
from analysis.tables.summary import summary_table
from data_schema import datasets as ds
from data_schema.errors import InputError, check_number
from data_schema.methods import FLOOR_METHOD, METHOD_COLUMN, method_values
from data_schema.perturbation import EXTRA_PERTURBATION_COLUMNS
from data_schema.tables import TableKind, read_table
from data_schema.text import plural

__all__ = ["TableSource", "read_all_pairs", "run_pairs_analysis", "RATER_COLUMNS"]

#: Pair columns the analysis uses (identity and breakdowns); the rest of PAIRS_COLUMNS is not read.
_KEEP = ("clip_id", "track_id", "label_class", "y_offset_m", "gt_visible", "novel_visible")
#: The 6-DoF view components (docs/FORMATS.md §9), read as numbers when present: the per-axis
#: tables and tent plots (:func:`analysis.tables.axes.view_tables`); never metrics.
_VIEW = EXTRA_PERTURBATION_COLUMNS
# incl. the view label; ``method`` (scenes with methods, docs/FORMATS.md §2) is carried through as a label
_SKIP = (set(NON_METRIC_COLUMNS) - set(_KEEP) - set(_VIEW) - {METHOD_COLUMN}) | {"scene_root"}
RATER_COLUMNS = ["rater_id", "simulated", "excluded", "excluded_reason"]


def _is_numeric(t) -> bool:
    return pt.is_integer(t) or pt.is_floating(t) or pt.is_boolean(t) or pt.is_null(t)


class TableSource:
    """A table file or a clip-partitioned dataset, readable clip by clip as pyarrow tables.

    Parameters
    ----------
    path : str or pathlib.Path
        A table file (read whole) or a clip-partitioned dataset folder.
    kind : TableKind
        The table's kind: its checks, and its name in errors (e.g. ``"pairs table"``).
    """

    def __init__(self, path, *, kind: TableKind):
        what = kind.value
        self.path, self.what = str(path), what
        self.dataset = ds.is_dataset(path)
        if self.dataset:
            files = ds.dataset_files(path, what=what)
            ds.check_schemas(files, root=path)

            self.schema = pq.read_schema(files[0][1])
            self.by_clip: dict[str, list[Path]] = {}
            for clip, f in files:
                self.by_clip.setdefault(clip, []).append(f)
            self.n_rows = sum(pq.read_metadata(f).num_rows for _, f in files)
            return
        df = read_table(path, kind=kind, dtype={"pair_id": str, "clip_id": str, "track_id": str})
        self.table = pa.Table.from_pandas(df, preserve_index=False)
        self.schema, self.n_rows = self.table.schema, len(df)
        self.index = None

    @property
    def columns(self) -> list[str]:
        return [c for c in self.schema.names] + ([ds.PARTITION] if self.dataset else [])

    def clips(self) -> list[str]:
        if self.dataset:
            return sorted(self.by_clip)
        if ds.PARTITION not in self.schema.names:
            raise InputError(self.path, "column 'clip_id'", "a pairs dataset partitioned by clip_id "
                             "or a table with a clip_id column", "neither")

        return sorted(map(str, pc.unique(self.table.column(ds.PARTITION).cast("string")).to_pylist()))

    def clip(self, clip_id: str, columns: list[str]):
        """The clip's rows (pyarrow table with ``columns`` that exist), or ``None``."""

        cols = [c for c in columns if c in self.schema.names]
        if self.dataset:
            fs = self.by_clip.get(clip_id)
            if not fs:
                return None
            return pa.concat_tables([pq.read_table(f, columns=cols) for f in fs])
        if ds.PARTITION not in self.schema.names:
            return None
        if not hasattr(self, "_groups"):
            codes = self.table.column(ds.PARTITION).cast("string").to_pandas()
            self._groups = {str(k): v for k, v in codes.groupby(codes, sort=False).indices.items()}
        rows = self._groups.get(clip_id)
        return None if rows is None else self.table.select(cols).take(pa.array(rows))

    def lookup(self, pair_ids, columns: list[str]):
        """Positions of ``pair_ids`` in a file table (-1: absent) and its ``columns`` as float64."""
        if self.index is None:
            # unique: read_table already rejects a repeated pair_id (data_schema.tables.check_metrics)
            self.index = pd.Index(self.table.column("pair_id").cast("string").to_pandas())
            self.values = {c: self.table.column(c).to_numpy(zero_copy_only=False).astype(np.float64)
                           for c in columns}
            self.matched = np.zeros(self.n_rows, dtype=bool)
        pos = self.index.get_indexer(pd.Index(pair_ids.cast("string").to_pandas()))
        self.matched[pos[pos >= 0]] = True
        return pos, self.values


class _Columns:
    """Preallocated output columns: float64 numbers, int32 codes (+ category lists) for labels."""

    def __init__(self, n: int, numeric: list[str], labels: list[str]):
        self.n, self.at = n, 0
        self.num = {c: np.full(n, np.nan) for c in numeric}
        self.codes = {c: np.full(n, -1, dtype=np.int32) for c in labels}
        self.cats = {c: {} for c in labels}
        self.track = np.zeros(n, dtype=np.int32)
        self.n_tracks = 0

    def add_labels(self, name: str, arr, sl: slice) -> None:
        enc = arr.cast("string").dictionary_encode().combine_chunks()
        lut = np.array([self.cats[name].setdefault(v, len(self.cats[name])) for v in enc.dictionary.to_pylist()]
                       + [-1], dtype=np.int32)
        idx = enc.indices.fill_null(-1).to_numpy(zero_copy_only=False).astype(np.int64)
        self.codes[name][sl] = lut[idx]

    def frame(self) -> pd.DataFrame:
        cols = {}
        for c, codes in self.codes.items():
            cols[c] = pd.Categorical.from_codes(codes[: self.at], categories=list(self.cats[c]))
        for c, v in self.num.items():
            cols[c] = v[: self.at]
        return pd.DataFrame(cols, copy=False)


def _plan(pairs: TableSource, metrics: list[TableSource], keep=()):
    """(numeric columns, label columns, per-metric-source columns), checking names and types;
    ``keep``: pair columns read although the analysis skips them (e.g. ``camera``)."""

    numeric, labels, seen = [], list(_KEEP[:3]), {}
    for name in pairs.schema.names:
        if (name in _SKIP and name not in keep) or name in _KEEP or name == "pair_id":
            continue
        t = pairs.schema.field(name).type
        if name in _VIEW and not _is_numeric(t):
            raise InputError(pairs.path, f"column {name!r}", "a number (docs/FORMATS.md §9)", str(t))
        (numeric if _is_numeric(t) else labels).append(name)
        seen[name] = pairs.path
    numeric.insert(0, "y_offset_m")
    for need in ("pair_id", "track_id", "label_class", "y_offset_m"):
        if need not in pairs.columns:
            raise InputError(pairs.path, f"column {need!r}", "a pairs table (docs/FORMATS.md §3)", "no such column")
    per_source = []
    for src in metrics:
        if "pair_id" not in src.schema.names:
            raise InputError(src.path, "column 'pair_id'", "a metrics table (pair_id + metric columns)",
                             "no such column")
        cols = []
        for name in src.schema.names:
            if name in ("pair_id", ds.PARTITION):
                continue
            t = src.schema.field(name).type
            if not _is_numeric(t) and not pt.is_dictionary(t):
                raise InputError(src.path, f"column {name!r}", "a numeric metric value", str(t))
            if name in seen:
                raise InputError(src.path, f"column {name!r}", "each metric column in one input",
                                 f"also in {seen[name]}")
            seen[name] = src.path
            cols.append(name)
        numeric += cols
        per_source.append(cols)
    return numeric, labels, per_source


def _canonical_order(ids) -> np.ndarray | None:
    """The clip's rows sorted by ``pair_id`` (stable), or ``None`` when they are already."""
    order = pc.sort_indices(ids).to_numpy()
    return None if (order[1:] > order[:-1]).all() else order


def _fill_clip(out: _Columns, clip: str, base, metrics, per_source, unknown: dict) -> None:
    """Append one clip's rows in the canonical order (sorted by ``pair_id``, docs/FORMATS.md §6),
    whatever the input's row order: the labels, numbers and track codes from the sorted rows;
    the metric joins match the rows as read (so the fast same-order join still applies) and
    write each value at its row's sorted place."""
    n = base.num_rows
    sl = slice(out.at, out.at + n)
    ids = base.column("pair_id")
    order = _canonical_order(ids)
    rows, place = (base, None) if order is None else (base.take(order), np.empty(n, np.int64))
    if place is not None:
        place[order] = np.arange(n)  # input row -> its sorted position
    for c in out.codes:
        if c == ds.PARTITION:
            out.codes[c][sl] = out.cats[c].setdefault(clip, len(out.cats[c]))
        elif c in rows.column_names:
            out.add_labels(c, rows.column(c), sl)
    for c in rows.column_names:
        if c in out.num:
            out.num[c][sl] = rows.column(c).to_numpy().astype(np.float64)
    tcodes = pd.factorize(rows.column("track_id").cast("string").to_pandas())[0]
    out.track[sl] = tcodes + out.n_tracks
    out.n_tracks += int(tcodes.max()) + 1 if n else 0
    for src, cols in zip(metrics, per_source, strict=True):
        _join_source(out, sl, src, clip, ids, cols, unknown, place)
    out.at += n


def _join_source(out: _Columns, sl: slice, src: TableSource, clip: str, ids, cols, unknown,
                 place: np.ndarray | None) -> None:
    """Join ``src``'s ``cols`` onto the clip's rows ``ids`` (as read); ``place``: each read
    row's position in the output slice (``None``: the same)."""
    if src.dataset:
        t = src.clip(clip, ["pair_id"] + cols)
        if t is None:
            return
        if t.column("pair_id").equals(ids):  # same pairs, same order: no hashing
            pos, hit = np.arange(len(ids)), np.ones(len(ids), bool)
            src_pos = pos
        else:
            index = pd.Index(t.column("pair_id").to_pandas())
            src_pos = index.get_indexer(pd.Index(ids.to_pandas()))
            hit = src_pos >= 0
            pos = np.flatnonzero(hit)
            src_pos = src_pos[hit]
            unknown[src.path] = unknown.get(src.path, 0) + int(t.num_rows - hit.sum())
        values = {c: t.column(c).to_numpy(zero_copy_only=False).astype(np.float64) for c in cols}
    else:
        src_pos_all, values = src.lookup(ids, cols)
        hit = src_pos_all >= 0
        pos, src_pos = np.flatnonzero(hit), src_pos_all[hit]
    at = sl.start + (pos if place is None else place[pos])
    for c in cols:
        out.num[c][at] = values[c][src_pos]


def read_all_pairs(pairs_path, *, metrics_paths=(), progress: bool = True, keep=()):
    """The per-pair items table (categorical labels, float64 numbers) and track codes (n,).

    ``keep``: pair columns to read that the analysis otherwise skips (``--compare-methods``
    pairs methods on ``camera`` and ``timestamp_us``).

    Returns ``(items, clusters, unknown_ids)``; ``unknown_ids[path]`` counts pair ids of a metric
    dataset that are not in the pairs input.

    Parameters
    ----------
    pairs_path : str or pathlib.Path
        A pairs dataset folder, or a pairs table with ``clip_id``.
    metrics_paths : sequence of str or pathlib.Path
        Metrics tables or datasets joined to the pairs on ``pair_id``.
    progress : bool
        Show a per-clip progress bar.
    keep : sequence of str
        Pair columns to read that the analysis otherwise skips.

    Returns
    -------
    items : pandas.DataFrame
        One row per pair: categorical labels and float64 numbers.
    clusters : (n,) int32 numpy.ndarray
        Track code of each pair.
    unknown_ids : dict of str to int
        Per metrics path, the pair ids not in the pairs input.
    """

    pairs = TableSource(pairs_path, kind=TableKind.PAIRS)
    metrics = [TableSource(p, kind=TableKind.METRICS) for p in metrics_paths]
    numeric, labels, per_source = _plan(pairs, metrics, keep)
    clips = pairs.clips()
    out = _Columns(pairs.n_rows, numeric, labels)  # labels start with clip_id (_KEEP)
    read_cols = ["pair_id"] + [c for c in labels + numeric if c in pairs.schema.names]
    unknown = {str(p): 0 for p in metrics_paths}
    for clip in tqdm(clips, desc="read", unit="clip", disable=not progress):
        base = pairs.clip(clip, read_cols)
        if base is not None and base.num_rows:
            _fill_clip(out, clip, base, metrics, per_source, unknown)
    for src in metrics:
        if not src.dataset and src.index is not None:
            unknown[src.path] = int((~src.matched).sum())
    return out.frame(), out.track[: out.at], unknown


def _check_target(items: pd.DataFrame, target: str | None) -> None:
    if target is None:
        raise InputError(param="target", expected="a numeric per-pair column (e.g. clip_drop) of the "
                         "pairs or metrics", got="none")
    if target not in items.columns or not pd.api.types.is_numeric_dtype(items[target]):
        raise InputError(param="target", field=target, expected="a numeric column of the pairs or metrics",
                         got="no such column" if target not in items.columns else items[target].dtype)
    if not np.isfinite(items[target].to_numpy(np.float64)).any():
        raise InputError(param="target", field=target, expected="some finite values", got="none")


def _without_floor(items: pd.DataFrame, clusters: np.ndarray) -> tuple[pd.DataFrame, np.ndarray, str]:
    """``items`` and ``clusters`` without the rows of method ``floor``, and the note that says so
    (``''`` when there are none)."""
    floor = method_values(items) == FLOOR_METHOD
    if not floor.any():
        return items, clusters, ""
    note = (f"{plural(int(floor.sum()), 'pair')} of the viewpoint floor (method floor, two GT views) left out "
            "of the statistics; the method comparison draws the floor beside the methods")
    return items[~floor].reset_index(drop=True), pd.factorize(clusters[~floor])[0].astype(clusters.dtype), note


def run_pairs_analysis(pairs_path, options: AnalysisOptions | None = None, **keywords) -> Analysis:
    """The all-pairs analysis (module docstring); the same :class:`Analysis` as the ratings path.

    Parameters
    ----------
    pairs_path : str or Path
        A pairs dataset folder, or a pairs table with ``clip_id``.
    options : analysis.options.AnalysisOptions, optional
        As for :func:`analysis.pipeline.run_analysis`; the ratings-only fields
        (``exclude_raters``, ``screen``, ``aggregate_method``, ``stability_dir``) are not used.
        ``target`` is a numeric per-pair column (e.g. ``clip_drop``) of the pairs or metrics,
        required unless ``compare`` is set (then only the leaderboard is reported when it is
        None).
    **keywords
        Deprecated spelling, kept for earlier callers: as for
        :func:`analysis.pipeline.run_analysis`.

    Returns
    -------
    Analysis
        With ``source = 'pairs'``; ``methods`` is the leaderboard with ``compare_methods``.

    Raises
    ------
    InputError
        On bad input (files, columns, parameters), naming it.
    """
    o = analysis_options(keywords, options=options, who="run_pairs_analysis")
    if o.target is None and o.compare is None:  # said before any input is read
        raise InputError(param="target", expected="a numeric per-pair column (e.g. clip_drop) of the pairs "
                         "or metrics (needed unless the methods are compared)", got="none")
    check_number("margin", o.margin, low=0)
    target = o.target
    keep = ("camera", "timestamp_us") if o.compare else ()  # the view columns are read anyway
    timing = read_timing(find_timing_files(o.timing_paths, o.metrics_paths))  # before the statistics
    items, clusters, unknown = read_all_pairs(pairs_path, metrics_paths=o.metrics_paths,
                                              progress=o.progress, keep=keep)
    if not o.compare:  # the log's viewpoint floor (nvrq pairs --floor) is no render: never pooled
        items, clusters, floor_note = _without_floor(items, clusters)
    if target is not None or not o.compare:
        _check_target(items, target)
    notes = [f"all-pairs analysis: {len(items)} pairs, no votes; "
             + (f"target {target}" if target is not None else "no target (the methods only)")]
    notes += [floor_note] if not o.compare and floor_note else []
    numeric = [c for c in items.columns if pd.api.types.is_numeric_dtype(items[c])]
    items, empty_notes = drop_empty_columns(items, keep=[c for c in items.columns if c not in numeric]
                                            + [target], unit="pair")
    notes += empty_notes
    metrics, directions, attributes, proxies = classify_columns(
        items, lower=set(o.lower), higher=set(o.higher), target=target, where=pairs_path)
    for path, n in unknown.items():
        if n:
            notes.append(f"{path}: {n} pair ids are not in the pairs (ignored)")
    n_boot = boot_size(items, o.n_boot, notes, unit="pair")
    ranked = metrics if target is not None else []  # no target: nothing to correlate
    shown = o.progress and bool(ranked)
    summary = summary_table(items, ranked, directions, SummaryOptions(
        target=target or "y_offset_m", n_boot=n_boot, seed=o.seed, rank_by=o.rank_by, progress=shown),
        clusters=clusters)
    categories = breakdowns.category_table(items, ranked, by=["label_class"] + attributes,
                                           target=target or "y_offset_m", progress=shown)
    by_offset, by_axis = axes.view_tables(items, ([target] if target else []) + metrics)
    return with_view_statistics(Analysis(
        ratings_path=str(pairs_path), target=target, items=items, metrics=metrics,
        directions=directions, attributes=attributes, proxies=proxies, summary=summary,
        categories=categories, by_offset=by_offset, by_axis=by_axis,
        encoders=breakdowns.encoder_table(summary), raters=pd.DataFrame(columns=RATER_COLUMNS),
        alpha={}, counts=_pairs_counts(items, clusters), timing=timing, notes=notes, unknown_ids=unknown,
        n_boot=n_boot, seed=o.seed, rank_by=o.rank_by, source="pairs", margin=o.margin,
        methods=for_analysis(items, target=target, metrics=metrics, directions=directions,
                             attributes=attributes,
                             options=replace(o.compare, n_boot=n_boot, seed=o.seed, progress=o.progress),
                             where=pairs_path, metrics_paths=o.metrics_paths) if o.compare else None),
        clusters=clusters)


def _pairs_counts(items: pd.DataFrame, clusters: np.ndarray) -> dict:
    """The report's counts of an all-pairs analysis (no votes, no raters)."""
    return {"votes": 0, "test_votes": 0, "test_votes_kept": 0, "items": len(items),
            "tracks": int(clusters.max()) + 1 if len(clusters) else 0,
            "clips": int(items[ds.PARTITION].nunique()), "raters": 0, "raters_simulated": 0,
            "raters_excluded": 0, "gold_votes": 0, "repeat_votes": 0}
