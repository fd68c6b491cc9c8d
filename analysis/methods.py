"""The leaderboard of reconstruction methods: ``analyze ... --compare-methods`` (docs/FORMATS.md §11).

Input: the per-object table of either ``analyze`` path (every pair joined with its metrics,
or the rated items with GVF), with a ``method`` column: one row per object, view and method.
An *object* is ``(clip_id, camera, track_id, timestamp_us, view)``; the view is the
perturbation of :mod:`data_schema.perturbation` (the lateral offset ``y_offset_m`` and the
optional 6-DoF columns, at their 0.01 precision). *On-path* is the recorded view (offset 0),
*off-path* every other view (:mod:`analysis.common.method_cells`).

Outputs (one fact each):

- :data:`TABLE_COLUMNS` (``methods.csv``): per method, metric and group: ``n``,
  ``n_tracks``, ``mean``, ``median`` and the 95% percentile interval of the mean from a
  cluster bootstrap over tracks ``(clip_id, track_id)`` (:mod:`analysis.stats.bootstrap`). Groups:
  ``breakdown = 'off-path'`` and ``'on-path'`` (group ``'all'``); one breakdown per view axis,
  named by its column (``y_offset_m``, ``yaw_deg``, ...; the real camera's view is value 0 of
  every axis, as in :mod:`analysis.tables.axes`; values as :func:`analysis.common.text.offset_text`);
  ``label_class``; each scene attribute.
- :data:`PAIRED_COLUMNS` (``methods_paired.csv``): per pair of methods ``(a, b)``, metric and
  cell (``axis = 'off-path'`` or ``'on-path'``, or an axis column with its ``offset``; with
  ``by``, also per value of the crossed columns: ``by`` and ``group``), over the objects both
  methods scored: ``mean_diff`` = mean of ``x_a - x_b`` in the metric's units with its 95%
  paired cluster-bootstrap interval (:func:`analysis.stats.bootstrap.paired_difference` on the
  replicate means), the two-sided sign-flip p-value over tracks (:mod:`analysis.stats.signflip`:
  exact up to 16 tracks, else Monte Carlo; ``p_floor`` the smallest it can give, ``p_test``
  which), ``p_holm`` (Holm over the rows of one ``by``), ``win_rate`` (share of objects where
  ``a`` scores better, by the metric's direction) and ``tie_rate`` (equal values), and
  ``better``: the name of the better method when ``p_holm < 0.05`` and the interval excludes
  0, else ``'neither'``. ``n_only_a`` / ``n_only_b`` count objects left out because only one
  method has a value.
- the leaderboard (:func:`leaderboard_table`): methods sorted by the mean of one metric over
  their off-path objects (default: NVRQ-CA of the first encoder, :func:`default_rank_metric`),
  each with whether it is better than the next at ``p_holm < 0.05`` in the paired comparison.

All bootstrap statistics share one set of track draws, and all Monte Carlo p-values one set
of sign patterns, so they are paired across methods, metrics and views. Rules for degenerate
input (DESIGN rule 7): a mean needs one value; an interval and a p-value need ``min_clusters``
tracks (default 5, :data:`MIN_CLUSTERS`) and a bootstrap; undefined values are empty with the
reason, which names the count of tracks.

>>> holm(np.array([0.01, 0.04, 0.03, np.nan])).tolist()
[0.03, 0.06, 0.06, nan]
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
import pandas as pd
from tqdm.auto import tqdm

from analysis.common.choices import MIN_CLUSTERS
from analysis.common.method_cells import PATHS, cell_breakdowns, on_path, parse_by, view_breakdowns
from analysis.common.text import offset_text
from analysis.options import MethodOptions
from analysis.stats import bootstrap as bs
from analysis.stats.signflip import draw_signs, sign_flip_p
from data_schema.datasets import table_columns
from data_schema.errors import InputError
from data_schema.methods import (
    FLOOR_METHOD,
    METHOD_COLUMN,
    REFERENCE_METHODS,
    method_values,
    table_methods,
)
from data_schema.options import options_or_keywords
from data_schema.perturbation import perturbation_array
from data_schema.tables import OBJECT_COLUMNS, require_columns

__all__ = [
    "METHOD_COLUMN",
    "TABLE_COLUMNS",
    "PAIRED_COLUMNS",
    "LEADERBOARD_COLUMNS",
    "ALPHA",
    "MIN_CLUSTERS",
    "MethodsResult",
    "holm",
    "default_rank_metric",
    "compared_methods",
    "object_codes",
    "too_few_tracks",
    "view_breakdowns",
    "compare_methods",
    "leaderboard_table",
    "for_analysis",
]

TABLE_COLUMNS = ["method", "metric", "breakdown", "group", "n", "n_tracks", "mean", "median",
                 "ci_lo", "ci_hi", "reason"]
PAIRED_COLUMNS = ["method_a", "method_b", "metric", "axis", "offset", "n", "n_tracks", "n_only_a",
                  "n_only_b", "mean_diff", "ci_lo", "ci_hi", "p", "p_holm", "p_floor", "p_test",
                  "win_rate", "tie_rate", "better", "by", "group", "reason"]
LEADERBOARD_COLUMNS = ["rank", "method", "metric", "n", "n_tracks", "mean", "ci_lo", "ci_hi", "median",
                       "next", "p_holm_vs_next", "better_than_next", "view", "p_floor_vs_next"]
#: Significance level of ``better`` and of the leaderboard's "better than the next".
ALPHA = 0.05


@dataclass
class MethodsResult:
    """What ``--compare-methods`` adds to the report (see the module docstring).

    Attributes
    ----------
    methods : list of str
        Every compared method, in leaderboard order.
    metrics : list of str
        The compared metrics.
    directions : dict of str to bool
        Per metric, whether higher is better.
    rank_metric : str
        The metric the leaderboard ranks on.
    table : pandas.DataFrame
        Per-method summaries (:data:`TABLE_COLUMNS`).
    paired : pandas.DataFrame
        Paired method comparisons (:data:`PAIRED_COLUMNS`).
    leaderboard : pandas.DataFrame
        The leaderboard (:data:`LEADERBOARD_COLUMNS`).
    n_boot : int
        Bootstrap draws of the intervals and p-values.
    notes : list of str
        Notes for the report.
    rank_view : str
        The view the leaderboard ranks on (``'off-path'`` or ``'on-path'``).
    min_clusters : int
        The fewest tracks of an interval or a p-value.
    by : str
        The crossed breakdown of methods_paired.csv (``''`` for none).
    sets : pandas.DataFrame or None
        The ``nvrq score-sets`` table (``analyze --sets``), for the off-path table, or None.
    references : list of str
        The viewpoint floor's methods (``perfect``, ``floor``) in the table, neither ranked nor
        paired: the tents draw them dashed.
    """

    methods: list[str]  # every compared method, in leaderboard order
    metrics: list[str]
    directions: dict[str, bool]
    rank_metric: str
    table: pd.DataFrame  # TABLE_COLUMNS
    paired: pd.DataFrame  # PAIRED_COLUMNS
    leaderboard: pd.DataFrame  # LEADERBOARD_COLUMNS
    n_boot: int = 0
    notes: list[str] = field(default_factory=list)
    rank_view: str = "off-path"  # the view the leaderboard ranks on (PATHS)
    min_clusters: int = MIN_CLUSTERS  # the fewest tracks of an interval or a p-value
    by: str = ""  # the crossed breakdown of methods_paired.csv ('' for none)
    sets: pd.DataFrame | None = None  # `nvrq score-sets` table (analyze --sets), for the off-path table
    references: list[str] = field(default_factory=list)  # the viewpoint floor's methods, never ranked


def holm(p: np.ndarray) -> np.ndarray:
    """Holm-Bonferroni adjusted p-values of ``p`` (n,); NaN stays NaN and is not counted.

    The i-th smallest of m p-values becomes ``max_{j <= i} min(1, (m - j + 1) p_(j))``
    (Holm 1979). The module doctest: m = 3 defined values 0.01, 0.03, 0.04 give 3 x 0.01 = 0.03,
    max(0.03, 2 x 0.03) = 0.06 and max(0.06, 1 x 0.04) = 0.06.

    Parameters
    ----------
    p : (n,) float array_like
        Unadjusted p-values; NaN where undefined.

    Returns
    -------
    numpy.ndarray
        (n,) float64 adjusted p-values, NaN where ``p`` is not finite.
    """
    p = np.asarray(p, dtype=np.float64)
    out = np.full(p.shape, np.nan)
    ok = np.flatnonzero(np.isfinite(p))
    if ok.size == 0:
        return out
    order = ok[np.argsort(p[ok], kind="stable")]
    m = order.size
    adj = np.minimum(1.0, (m - np.arange(m)) * p[order])
    out[order] = np.maximum.accumulate(adj)
    return out


def default_rank_metric(metrics: list[str]) -> str | None:
    """NVRQ-CA of the first encoder (``nvrq_ca:ENC`` or ``nvrq_ca``), else the first metric.

    Parameters
    ----------
    metrics : list of str
        Metric column names.

    Returns
    -------
    str or None
        The metric to rank on; None when ``metrics`` is empty.

    >>> default_rank_metric(["psnr", "nvrq:a", "nvrq_ca:a", "nvrq_ca:b"])
    'nvrq_ca:a'
    >>> default_rank_metric(["psnr", "ssim"])
    'psnr'
    """
    for m in metrics:
        if m == "nvrq_ca" or m.startswith("nvrq_ca:"):
            return m
    return metrics[0] if metrics else None


def compared_methods(items: pd.DataFrame, *, where, methods=None) -> list[str]:
    """The methods ``--compare-methods`` compares: those ``items`` holds
    (:func:`data_schema.methods.table_methods`, sorted), or ``methods`` in their order.

    Parameters
    ----------
    items : pandas.DataFrame
        The per-object table, one row per object, view and method; ``where`` names it in errors.
    methods : list of str, optional
        The methods to compare (each a method of ``items``; a repeat counts once).

    Returns
    -------
    list of str

    Raises
    ------
    InputError
        ``items`` has no ``method`` column, a name of ``methods`` is not among its methods
        (naming the parameter ``methods``), or fewer than two methods remain.
    """
    present = table_methods(items, where=where, expected="a method per row to compare "
                            "(`compare_methods`; docs/FORMATS.md §11)")
    if methods:
        unknown = [m for m in methods if m not in present]
        if unknown:
            raise InputError(param="methods", field=unknown[0], expected="a method of " + str(where) + " ("
                             + ", ".join(present) + ")", got="no such method")
        present = list(dict.fromkeys(methods))
    if len(present) < 2:
        raise InputError(where, f"column {METHOD_COLUMN!r}", "at least two methods to compare "
                         "(`compare_methods`)", "one: " + ", ".join(present) if present else "none")
    return present


def _method_codes(col: pd.Series, names: list[str]) -> np.ndarray:
    """(N,) int64 index of each row's method in ``names`` (-1: another method or none)."""
    codes, uniq = pd.factorize(col)
    lut = np.append(pd.Index(names).get_indexer([str(u) for u in uniq]), -1).astype(np.int64)
    return lut[codes]


def object_codes(items: pd.DataFrame, *, where) -> np.ndarray:
    """(N,) int64 code of each row's object view (:data:`data_schema.tables.OBJECT_COLUMNS`
    and the view): rows share a code exactly when they share a pair id without method.

    The view is compared at the 0.01 precision of pair ids (docs/FORMATS.md §3).

    Parameters
    ----------
    items : pandas.DataFrame
        (N rows) the object columns and the view columns.
    where : object
        The input named in errors.

    Returns
    -------
    numpy.ndarray
        (N,) int64 codes 0, 1, ... in order of first appearance.

    Raises
    ------
    InputError
        An object column is missing.
    """
    require_columns(items, OBJECT_COLUMNS, where=where)
    view = np.round(perturbation_array(items) * 100).astype(np.int64)
    keys = [pd.factorize(items[c])[0] for c in OBJECT_COLUMNS] + list(view.T)
    return pd.MultiIndex.from_arrays(keys).factorize()[0].astype(np.int64)


def _replicate_means(v, ok, groups, n_groups, clusters, counts):
    """Per-group mean of ``v`` over ``ok`` rows: point (G,), n (G,), tracks (G,), replicates (B, G).

    ``groups`` (N,) int codes; ``clusters`` (N,) track codes into the columns of ``counts`` (B, K).
    A replicate's mean weighs each row by how often its track was drawn.
    """
    g, c, x = groups[ok], clusters[ok], v[ok]
    n = np.bincount(g, minlength=n_groups).astype(np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):
        point = np.bincount(g, weights=x, minlength=n_groups) / n
    k = counts.shape[1] if counts is not None else int(clusters.max()) + 1 if len(clusters) else 1
    cell = g.astype(np.int64) * k + c
    tracks = np.bincount(np.unique(cell) // k, minlength=n_groups)
    if counts is None or counts.shape[0] == 0:
        return point, n, tracks, np.empty((0, n_groups))
    s = np.bincount(cell, weights=x, minlength=n_groups * k).reshape(n_groups, k)
    w = np.bincount(cell, minlength=n_groups * k).reshape(n_groups, k).astype(np.float64)
    reps = np.empty((counts.shape[0], n_groups))
    step = max(1, bs.CHUNK_CELLS // max(1, k))
    for b0 in range(0, counts.shape[0], step):
        cb = counts[b0:b0 + step].astype(np.float64)
        with np.errstate(invalid="ignore", divide="ignore"):
            reps[b0:b0 + step] = (cb @ s.T) / (cb @ w.T)
    return point, n, tracks, reps


def _groups_of(items: pd.DataFrame, attributes: list[str]):
    """``(breakdown, codes (N,) int (-1: not in the breakdown), group labels)`` for methods.csv:
    off and on the recorded path, the views in their order along each axis, classes and
    attributes sorted."""
    on = on_path(items)
    out = [(path, np.where(on == (path == "on-path"), 0, -1).astype(np.int64), ["all"]) for path in PATHS]
    for axis, values, member in view_breakdowns(items)[1:]:
        uniq, inv = np.unique(values[member], return_inverse=True)
        codes = np.full(len(items), -1, np.int64)
        codes[member] = inv
        out.append((axis, codes, [offset_text(v) for v in uniq]))
    for col in ["label_class", *attributes]:
        if col in items.columns:
            codes, uniq = pd.factorize(items[col], sort=True)
            out.append((col, codes.astype(np.int64), [str(u) for u in uniq]))
    return out


def too_few_tracks(n_tracks: int, min_clusters: int) -> str:
    """The reason of a group without interval or p-value: its count of tracks.

    Parameters
    ----------
    n_tracks : int
        Tracks in the group.
    min_clusters : int
        The fewest tracks an interval or p-value needs.

    Returns
    -------
    str
        The reason, for a table's notes.

    >>> too_few_tracks(2, 5)
    '2 tracks, fewer than the 5 an interval or p-value needs'
    """
    return f"{n_tracks} track{'s' if n_tracks != 1 else ''}, fewer than the {min_clusters} an interval or p-value needs"


def _method_table(items, metrics, m_codes, methods, breakdowns, clusters, counts, bar, min_clusters):
    """methods.csv (:data:`TABLE_COLUMNS`) over ``breakdowns`` (:func:`_groups_of`); ``bar``
    advances once per breakdown and metric; a group of fewer than ``min_clusters`` tracks
    gets no interval."""
    rows = []
    for breakdown, codes, uniq in breakdowns:
        sel = (codes >= 0) & (m_codes >= 0)
        gsize = len(uniq)
        groups = np.full(len(items), -1, np.int64)
        groups[sel] = m_codes[sel] * gsize + codes[sel]
        for metric in metrics:
            bar.update()
            v = items[metric].to_numpy(np.float64)
            ok = sel & np.isfinite(v)
            point, n, tracks, reps = _replicate_means(v, ok, np.maximum(groups, 0), len(methods) * gsize,
                                                      clusters, counts)
            med = pd.Series(v[ok]).groupby(groups[ok]).median()
            for gi in np.flatnonzero(n > 0):
                lo = hi = np.nan
                reason = None
                if tracks[gi] < min_clusters:
                    reason = too_few_tracks(int(tracks[gi]), min_clusters)
                elif reps.shape[0] == 0:
                    reason = "no bootstrap"
                else:
                    lo, hi, reason = bs.percentile_ci(reps[:, gi])
                rows.append({"method": methods[gi // gsize], "metric": metric, "breakdown": breakdown,
                             "group": uniq[gi % gsize], "n": int(n[gi]), "n_tracks": int(tracks[gi]),
                             "mean": point[gi], "median": float(med[gi]), "ci_lo": lo, "ci_hi": hi,
                             "reason": reason})
    return pd.DataFrame(rows, columns=TABLE_COLUMNS)


def _wide(items, metric, obj, m_codes, n_obj, n_methods):
    """(n_obj, M) values of ``metric`` per object and method (NaN: no finite value)."""
    v = items[metric].to_numpy(np.float64)
    ok = (m_codes >= 0) & np.isfinite(v)
    out = np.full((n_obj, n_methods), np.nan)
    out[obj[ok], m_codes[ok]] = v[ok]
    return out


@dataclass
class _Draws:
    """What every paired row shares: the track of each object (n_obj,), the bootstrap's
    track counts (B, K) and the Monte Carlo sign patterns (B, K) (None without bootstrap)."""

    clusters: np.ndarray
    counts: np.ndarray | None
    signs: np.ndarray | None
    min_clusters: int


def _track_sums(d, ok, codes, n_cells, clusters, k) -> np.ndarray:
    """(G, K) sum of ``d`` per cell and track over ``ok`` objects; NaN where the track has none."""
    cell = codes[ok] * k + clusters[ok]
    s = np.bincount(cell, weights=d[ok], minlength=n_cells * k).reshape(n_cells, k)
    has = np.bincount(cell, minlength=n_cells * k).reshape(n_cells, k) > 0
    return np.where(has, s, np.nan)


def _paired_rows(a, b, names, metric, hb, vals, breakdowns, draws: _Draws):
    """Rows of methods_paired.csv for methods ``a``, ``b`` and one metric, every cell of
    ``breakdowns`` (:func:`analysis.common.method_cells.cell_breakdowns` of the objects)."""
    xa, xb = vals[:, a], vals[:, b]
    fa, fb = np.isfinite(xa), np.isfinite(xb)
    both = fa & fb
    d = np.where(both, xa - xb, np.nan)
    better_a = (d > 0) if hb else (d < 0)  # a scores better, by the metric's direction
    rows = []
    for bd in breakdowns:
        member = bd.codes >= 0
        ok = both & member
        codes = np.maximum(bd.codes, 0)
        point, n, tracks, reps = _replicate_means(d, ok, codes, len(bd.cells), draws.clusters, draws.counts)
        defined = (tracks >= draws.min_clusters) & (n > 0)
        p = floor = np.full(len(bd.cells), np.nan)
        exact = np.zeros(len(bd.cells), bool)
        if draws.counts is not None and defined.any():
            sums = _track_sums(d, ok, codes, len(bd.cells), draws.clusters, draws.counts.shape[1])
            p, floor, exact = sign_flip_p(np.where(defined[:, None], sums, np.nan), signs=draws.signs)
        n_a = np.bincount(codes[member & fa & ~fb], minlength=len(bd.cells))
        n_b = np.bincount(codes[member & fb & ~fa], minlength=len(bd.cells))
        wins = np.bincount(codes[ok], weights=better_a[ok], minlength=len(bd.cells))
        ties = np.bincount(codes[ok], weights=d[ok] == 0, minlength=len(bd.cells))
        for gi, (group, axis, offset) in enumerate(bd.cells):
            row = {"method_a": names[a], "method_b": names[b], "metric": metric, "by": bd.by,
                   "group": group, "axis": axis, "offset": offset, "n": int(n[gi]),
                   "n_tracks": int(tracks[gi]), "n_only_a": int(n_a[gi]), "n_only_b": int(n_b[gi]),
                   "mean_diff": point[gi], "ci_lo": np.nan, "ci_hi": np.nan, "p": np.nan,
                   "p_floor": np.nan, "p_test": None,
                   "win_rate": wins[gi] / n[gi] if n[gi] else np.nan,
                   "tie_rate": ties[gi] / n[gi] if n[gi] else np.nan, "reason": None}
            if not n[gi]:
                row["reason"] = "no object scored by both methods"
            elif not defined[gi]:
                row["reason"] = too_few_tracks(int(tracks[gi]), draws.min_clusters)
            elif reps.shape[0] == 0:
                row["reason"] = "no bootstrap"
            else:
                row["ci_lo"], row["ci_hi"], _ = bs.paired_difference(reps[:, gi], np.zeros(reps.shape[0]))
                row.update(p=p[gi], p_floor=floor[gi], p_test="exact" if exact[gi] else "monte-carlo")
            rows.append(row)
    return rows


def _verdicts(t: pd.DataFrame, directions: dict[str, bool]) -> pd.DataFrame:
    """``p_holm`` (Holm within the rows of one ``by``) and ``better`` (the better method's
    name where ``p_holm < ALPHA`` and the interval excludes 0, else ``'neither'``)."""
    t["p_holm"] = np.nan
    for _, idx in t.groupby("by", sort=False).groups.items():
        t.loc[idx, "p_holm"] = holm(t.loc[idx, "p"].to_numpy(np.float64))
    hb = t["metric"].map(directions).astype(bool).to_numpy()
    sign = np.where(hb, 1.0, -1.0)
    lo, hi = t["ci_lo"].to_numpy(np.float64) * sign, t["ci_hi"].to_numpy(np.float64) * sign
    sig = t["p_holm"].to_numpy() < ALPHA
    a_wins = sig & (np.minimum(lo, hi) > 0)
    b_wins = sig & (np.maximum(lo, hi) < 0)
    t["better"] = np.where(a_wins, t["method_a"], np.where(b_wins, t["method_b"], "neither"))
    t.loc[~np.isfinite(t["p_holm"].to_numpy()), "better"] = None
    return t


def _objects(items, obj, m_codes, n_methods):
    """A row of each object (``first`` (n_obj,) row index) and which methods have it (n_obj, M)."""
    n_obj = int(obj.max()) + 1 if len(obj) else 0
    first = np.full(n_obj, -1, np.int64)
    first[obj[::-1]] = np.arange(len(obj))[::-1]  # a row of each object: its track and view
    present = np.zeros((n_obj, n_methods), bool)
    sel = m_codes >= 0
    present[obj[sel], m_codes[sel]] = True
    return first, present


def _paired_table(items, metrics, directions, m_codes, methods, obj, breakdowns, draws, bar):
    """methods_paired.csv (:data:`PAIRED_COLUMNS`) and the unpaired-object notes."""
    first, present = _objects(items, obj, m_codes, len(methods))
    rows, notes = [], []
    vals = {m: _wide(items, m, obj, m_codes, len(first), len(methods)) for m in metrics}
    for a in range(len(methods)):
        for b in range(a + 1, len(methods)):
            for ma, mb in ((a, b), (b, a)):
                only = int((present[:, ma] & ~present[:, mb]).sum())
                if only:
                    notes.append(f"{only} objects of method {methods[ma]!r} have no row of method "
                                 f"{methods[mb]!r} (not in its pairs): left out of the paired "
                                 f"{methods[a]!r}-{methods[b]!r} comparison")
            for metric in metrics:
                bar.update()
                rows += _paired_rows(a, b, methods, metric, directions[metric], vals[metric],
                                     breakdowns, draws)
    t = pd.DataFrame(rows, columns=[c for c in PAIRED_COLUMNS if c not in ("p_holm", "better")])
    return _verdicts(t, directions).loc[:, PAIRED_COLUMNS], notes


def leaderboard_table(table: pd.DataFrame, paired: pd.DataFrame, *, methods: list[str], metric: str,
                      higher_better: bool, view: str = "off-path") -> pd.DataFrame:
    """Methods sorted by their mean ``metric`` over their objects of ``view`` (``'off-path'``
    or ``'on-path'``; best first), each with ``better_than_next``: the paired comparison with
    the next method on that view says better at ``p_holm < ALPHA`` (:data:`LEADERBOARD_COLUMNS`;
    empty for the last and where the comparison is undefined).

    Parameters
    ----------
    table : pandas.DataFrame
        Per-method summaries (:data:`TABLE_COLUMNS`).
    paired : pandas.DataFrame
        Paired comparisons (:data:`PAIRED_COLUMNS`).
    methods : list of str
        The methods to rank.
    metric : str
        The metric to rank on.
    higher_better : bool
        Whether a higher ``metric`` is better.
    view : str
        ``'off-path'`` or ``'on-path'``.

    Returns
    -------
    pandas.DataFrame
        One row per method, best first (:data:`LEADERBOARD_COLUMNS`).
    """
    t = table[(table["breakdown"] == view) & (table["metric"] == metric)].set_index("method")
    t = t.reindex(methods)
    order = t["mean"].sort_values(ascending=not higher_better, kind="stable", na_position="last").index
    rows = []
    p_view = paired[(paired["axis"] == view) & (paired["by"] == "") & (paired["metric"] == metric)]
    for i, m in enumerate(order):
        nxt = order[i + 1] if i + 1 < len(order) else None
        p = better = floor = None
        if nxt is not None:
            r = p_view[((p_view["method_a"] == m) & (p_view["method_b"] == nxt))
                       | ((p_view["method_a"] == nxt) & (p_view["method_b"] == m))]
            if len(r):
                r = r.iloc[0]
                p, floor = r["p_holm"], r["p_floor"]
                better = bool(r["better"] == m) if isinstance(r["better"], str) else None
        rows.append({"rank": i + 1, "method": m, "metric": metric, "n": t.loc[m, "n"],
                     "n_tracks": t.loc[m, "n_tracks"], "mean": t.loc[m, "mean"],
                     "ci_lo": t.loc[m, "ci_lo"], "ci_hi": t.loc[m, "ci_hi"], "median": t.loc[m, "median"],
                     "next": nxt, "p_holm_vs_next": p, "better_than_next": better, "view": view,
                     "p_floor_vs_next": floor})
    return pd.DataFrame(rows, columns=LEADERBOARD_COLUMNS)


def _check_coverage(items, metrics, m_codes, names, *, where, sources) -> None:
    """Every compared method has values of every metric, else an error naming the metrics
    table that lacks that method's pairs (``sources``: column -> table path)."""
    for m in metrics:
        v = items[m].to_numpy(np.float64)
        has = np.bincount(m_codes[(m_codes >= 0) & np.isfinite(v)], minlength=len(names))
        if (has == 0).any():
            miss = names[int(np.flatnonzero(has == 0)[0])]
            raise InputError(sources.get(m, where), f"column {m!r}",
                             f"values for the pairs of every compared method (pair ids ending "
                             f"':{miss}' of {where})", f"none for method {miss!r}")


def _check_options(min_clusters, rank_view) -> None:
    """``min_clusters`` an integer >= 2 and ``rank_view`` one of :data:`PATHS`."""
    if isinstance(min_clusters, bool) or not isinstance(min_clusters, (int, np.integer)) or min_clusters < 2:
        raise InputError(param="min_clusters", expected="an integer >= 2 (tracks an interval needs)",
                         got=repr(min_clusters))
    if rank_view not in PATHS:
        raise InputError(param="rank_view", field=str(rank_view), expected="one of {" + ", ".join(PATHS) + "}",
                         got="no such view")


def compare_methods(items: pd.DataFrame, metrics: list[str], directions: dict[str, bool], *,
                    clusters: np.ndarray, options: MethodOptions | None = None, where="items",
                    sources=None, **keywords) -> MethodsResult:
    """The leaderboard tables of ``items`` (module docstring).

    Parameters
    ----------
    items : pandas.DataFrame
        One row per object, view and method (``method`` column).
    metrics : list of str
        Numeric columns of ``items``, with ``directions[m]`` True when higher is better.
    clusters : numpy.ndarray
        (N,) int track codes of the rows.
    options : analysis.options.MethodOptions, optional
        The methods compared, the rank metric and view, ``min_clusters``, the ``by`` breakdown,
        the scene ``attributes``, the bootstrap (``n_boot`` is raised to
        :func:`analysis.stats.bootstrap.replicates_for` the largest Holm family of paired rows; 0: no
        intervals and no p-values), its seed and the progress bar.
    where, sources : optional
        The input named in errors; column -> the metrics table it came from.
    **keywords
        Deprecated spelling, kept for earlier callers: the fields of
        :class:`~analysis.options.MethodOptions` as keywords. Not together with ``options``.

    Returns
    -------
    MethodsResult
        The methods ``perfect`` and ``floor`` (the viewpoint floor,
        :data:`data_schema.methods.REFERENCE_METHODS`) get their rows of the table and are its
        ``references``, neither ranked nor paired (while two other methods remain).

    Raises
    ------
    InputError
        Unknown methods, rank metric or ``by`` names; no ``method`` column; a method without
        values of a metric; two rows of one object and method; a bad ``min_clusters`` or
        ``rank_view``.
    """
    o = options_or_keywords(MethodOptions, options, keywords, who="compare_methods")
    _check_options(o.min_clusters, o.rank_view)
    names = compared_methods(items, where=where, methods=o.methods)
    # the viewpoint floor (perfect, floor) is summarised and drawn, never ranked nor paired
    # (unless fewer than two other methods remain)
    ranked = [m for m in names if m not in REFERENCE_METHODS]
    refs = [m for m in names if m in REFERENCE_METHODS] if len(ranked) >= 2 else []
    ranked = ranked if refs else names
    rank_metric = _rank_metric(o.rank_metric, metrics, where=where)
    by_cols, with_view = parse_by(o.by, items.columns, attributes=list(o.attributes))
    m_codes = _method_codes(items[METHOD_COLUMN], names)
    _check_coverage(items, metrics, m_codes, names, where=where, sources=sources or {})
    obj = object_codes(items, where=where)
    _check_one_row(items, obj, m_codes, where=where)
    first, _ = _objects(items, obj, m_codes, len(names))
    cells = cell_breakdowns(items.iloc[first])
    if by_cols or with_view:
        cells += cell_breakdowns(items.iloc[first], by=by_cols, with_view=with_view)
    k = int(clusters.max()) + 1 if len(clusters) else 0
    # enough replicates that Holm over the largest family of paired rows can still call a
    # decisive difference (a Monte Carlo p-value's floor is 1 / (B + 1))
    family = max(sum(len(c.cells) for c in cells if c.by == f) for f in {c.by for c in cells})
    n_boot = bs.replicates_for(o.n_boot, len(metrics) * len(ranked) * (len(ranked) - 1) // 2 * family,
                               alpha=ALPHA)
    counts = bs.draw_cluster_counts(k, n_boot, seed=o.seed) if n_boot and k else None
    draws = _Draws(clusters[first], counts,
                   draw_signs(k, n_boot, seed=o.seed + 1) if counts is not None else None, o.min_clusters)
    breakdowns = _groups_of(items, list(o.attributes))
    bar = tqdm(total=len(metrics) * (len(breakdowns) + len(names) * (len(names) - 1) // 2),
               desc="methods", unit="table", disable=not o.progress)
    table = _method_table(items, metrics, m_codes, names, breakdowns, clusters, counts, bar, o.min_clusters)
    hb = directions[rank_metric]
    table, names, rank_view, notes = _rank_methods(table, ranked, rank_metric, hb, o.rank_view)
    m_codes = _method_codes(items[METHOD_COLUMN], names)
    paired, unpaired = _paired_table(items, metrics, directions, m_codes, names, obj, cells, draws, bar)
    bar.close()
    board = leaderboard_table(table, paired, methods=names, metric=rank_metric, higher_better=hb,
                              view=rank_view)
    return MethodsResult(methods=list(board["method"]), references=refs, metrics=list(metrics), directions=dict(directions),
                         rank_metric=rank_metric, table=table, paired=paired, leaderboard=board,
                         n_boot=n_boot if counts is not None else 0, notes=notes + unpaired,
                         rank_view=rank_view, min_clusters=int(o.min_clusters),
                         by=",".join([*by_cols, *(["view"] if with_view else [])]))


def _rank_metric(rank_metric: str | None, metrics: list[str], *, where) -> str:
    """The metric that ranks the leaderboard: ``rank_metric`` (one of ``metrics``) or the default."""
    if rank_metric is not None and rank_metric not in metrics:
        raise InputError(param="rank_metric", field=rank_metric, expected="a metric column of the inputs ("
                         + ", ".join(metrics) + ")", got="no such metric")
    rank_metric = rank_metric or default_rank_metric(metrics)
    if rank_metric is None:
        raise InputError(where, None, "at least one metric column to rank methods by", "none")
    return rank_metric


def _check_one_row(items: pd.DataFrame, obj: np.ndarray, m_codes: np.ndarray, *, where) -> None:
    """Refuse a second row of one object and view for one method."""
    sel = np.flatnonzero(m_codes >= 0)
    dup = pd.DataFrame({"o": obj[sel], "m": m_codes[sel]}).duplicated().to_numpy()
    if dup.any():
        i = int(sel[np.flatnonzero(dup)[0]])
        raise InputError(where, METHOD_COLUMN, "one row per object, view and method",
                         "a second row for " + ":".join(str(items[c].iloc[i]) for c in OBJECT_COLUMNS)
                         + f" of method {items[METHOD_COLUMN].iloc[i]!r}")


def _rank_methods(table: pd.DataFrame, names: list[str], rank_metric: str, hb: bool,
                  rank_view: str) -> tuple[pd.DataFrame, list[str], str, list[str]]:
    """The methods in leaderboard order (by ``rank_metric``'s mean on ``rank_view``, the other
    view when it has no objects, with a note), and ``table`` in that order."""
    notes = []
    ranked = table[(table["breakdown"] == rank_view) & (table["metric"] == rank_metric)]
    if ranked.empty:
        other = PATHS[1 - PATHS.index(rank_view)]
        notes.append(f"no {rank_view} objects: the leaderboard ranks the {other} view")
        rank_view = other
        ranked = table[(table["breakdown"] == rank_view) & (table["metric"] == rank_metric)]
    means = ranked.set_index("method")["mean"].reindex(names)
    names = list(means.sort_values(ascending=not hb, kind="stable", na_position="last").index)
    # the table and the pairs follow the leaderboard: method_a is the higher-ranked one
    table = table.assign(_o=table["method"].map({m: i for i, m in enumerate(names)}))
    table = table.sort_values("_o", kind="stable").drop(columns="_o").reset_index(drop=True)
    return table, names, rank_view, notes


def for_analysis(items: pd.DataFrame, *, target: str | None, metrics, directions: dict, attributes,
                 options: MethodOptions, where, metrics_paths=()) -> MethodsResult:
    """:func:`compare_methods` on the items of either ``analyze`` path.

    Parameters
    ----------
    items : DataFrame
        The per-object table (:attr:`analysis.pipeline.Analysis.items`): the rated items, or
        every pair, with ``clip_id``, ``track_id`` and ``method``.
    target : str or None
        The analysis target; GVF (or the model's ``p_good``) is compared first on the ratings
        path, any other target is not compared.
    metrics : list of str
        The metric columns, compared in this order.
    directions : dict
        Metric -> whether higher is better.
    attributes : list of str
        Scene attributes; those other than ``method`` break the tables down.
    options : analysis.options.MethodOptions
        The comparison's options, with the analysis's bootstrap, seed and progress (its
        ``attributes`` are replaced by ``attributes``).
    where : str or Path
        The input named in errors (the ratings or pairs file).
    metrics_paths : sequence of path, optional
        The ``--metrics-table`` inputs, named in errors about their columns.

    Returns
    -------
    MethodsResult
        As :func:`compare_methods`. Items with ``floor`` rows (``nvrq pairs --floor``) get the
        sentence of :func:`analysis.common.viewpoint_floor.items_floor_verdict` first in the notes; when
        it says the floor does not predict a perfect render, the ``floor`` rows are left out
        (unless ``options.methods`` names the methods).

    Raises
    ------
    InputError
        As :func:`compare_methods` (unknown methods or rank metric, no ``method`` column, ...).
    """
    from analysis.common.viewpoint_floor import items_floor_verdict

    verdict = items_floor_verdict(items, metrics)  # the log's viewpoint floor: drawn when it holds
    if verdict is not None and not verdict.draw and not options.methods:
        items = items[method_values(items) != FLOOR_METHOD].reset_index(drop=True)
    votes = [target] if target in ("gvf", "p_good") else []
    clusters = pd.MultiIndex.from_arrays([items["clip_id"].astype(str),
                                          items["track_id"].astype(str)]).factorize()[0]
    res = compare_methods(items, votes + list(metrics), {**directions, **{t: True for t in votes}},
                          clusters=clusters,
                          options=replace(options, attributes=[c for c in attributes if c != METHOD_COLUMN]),
                          where=str(where),
                          sources={c: str(p) for p in metrics_paths for c in table_columns(p)})
    if verdict is not None:
        res.notes.insert(0, verdict.sentence)
    return res
