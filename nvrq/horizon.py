"""The trust horizon: how far off the recorded path objects stay good.

Layer: ``nvrq`` (a pure computation on a table of per-object scores; imports ``data_schema``
only, so :mod:`analysis` and the Python API share it). docs/FORMATS.md §15 is the contract.

A row of ``scores`` is one object seen from one view: its score on one metric, its class
(``label_class``), its track (``clip_id``, ``track_id``), its view (the perturbation columns
of :mod:`data_schema.perturbation`; absent ones are 0) and, optionally, its ``method``,
``camera`` and ``timestamp_us``. An object is *good* when its score is at or above the
threshold (at or below it for a metric where lower is better). For each method, class, axis
and direction (:data:`DIRECTIONS`), the grid is the distinct magnitudes of the offsets along
that direction, 0 included (the recorded view belongs to both directions of every axis):

- ``horizon``: the largest grid offset ``d`` such that at every grid offset from 0 out to
  ``d`` at least ``share`` of the objects are good; empty when the first grid offset (the
  recorded view) already fails (reason ``'fails at the recorded view'``), and the largest grid
  offset when none fails (reason ``'beyond the grid'``: a lower bound);
- ``crossing``: where the share of good objects, linearly interpolated between the last grid
  offset that passes and the first that fails, equals ``share``;
- ``ci_lo``, ``ci_hi``: the 95% percentile interval of the crossing over a cluster bootstrap of
  the tracks (a replicate where nothing fails counts the largest grid offset, one that fails
  at the first grid offset counts that offset); none below ``min_clusters`` tracks, and none
  that misses its estimate (the crossing; the largest grid offset when nothing fails, the first
  when it fails), with the reason.

>>> s = pd.DataFrame({"track_id": list("abcd") * 3, "label_class": "car",
...                   "y_offset_m": [0.0] * 4 + [1.0] * 4 + [2.0] * 4,
...                   "m": [1, 1, 1, 1, 1, 1, 1, 0, 0, 0, 0, 0]})
>>> h = trust_horizon(s, threshold=0.5, metric="m", share=0.5, n_boot=0)
>>> h[["direction", "horizon", "crossing", "reason"]].values.tolist()  # 1 + (0.75 - 0.5) / 0.75
[['left', 1.0, 1.333333333, '4 tracks, fewer than the 5 an interval needs']]
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from data_schema.errors import InputError, check_number
from data_schema.perturbation import AXES, AXIS_UNITS, axes, axis_values, perturbation_array
from nvrq.choices import WINDOW_S_RANGE

__all__ = ["ALL_CLASSES", "HORIZON_COLUMNS", "TIMELINE_COLUMNS", "VIEW_COLUMNS", "DIRECTIONS", "DEFAULT_SHARE",
           "MIN_CLUSTERS", "Threshold", "view_keys", "trust_horizon", "horizon_timeline", "share_curves",
           "class_rows", "resolve_metric", "row_source"]

#: horizon.csv (docs/FORMATS.md §15).
HORIZON_COLUMNS = ["method", "label_class", "axis", "direction", "horizon", "crossing", "ci_lo",
                   "ci_hi", "n_tracks", "metric", "threshold", "threshold_source", "reason"]
#: horizon_timeline.csv (docs/FORMATS.md §15).
TIMELINE_COLUMNS = ["clip_id", "camera", "t0_us", "t1_us", "axis", "direction", "class", "method",
                    "horizon", "ci_lo", "ci_hi", "n_objects"]
#: A per-view threshold table (:attr:`Threshold.views`): ``axis`` is ``'none'`` for the
#: recorded view (offset 0) and a name of :data:`data_schema.perturbation.AXES` otherwise;
#: ``offset`` the signed offset along it at 0.01 precision (metres or degrees).
#: A table may also hold ``label_class``: a row naming a class judges that class's objects at its
#: view, over the row of :data:`ALL_CLASSES` (or no class) there, which judges every other class.
VIEW_COLUMNS = ["axis", "offset", "threshold", "source"]
#: ``label_class`` of a per-view threshold that judges every class.
ALL_CLASSES = "all"
#: Per axis: the names of its positive and negative direction (rig frame: x forward, y left, z up).
DIRECTIONS = {"x": ("forward", "back"), "y": ("left", "right"), "z": ("up", "down"),
              "roll": ("+", "-"), "pitch": ("+", "-"), "yaw": ("+", "-")}
#: The default share of good objects a grid offset needs.
DEFAULT_SHARE = 0.9
#: The fewest tracks a group needs for an interval (as ``analyze --min-clusters``'s default).
MIN_CLUSTERS = 5
#: The method of a table without a ``method`` column.
NO_METHOD = "all"


@dataclass(frozen=True)
class Threshold:
    """A threshold on one metric and where it came from.

    Parameters
    ----------
    metric : str
        The metric column.
    value : float
        The threshold, in the metric's units.
    good_above : bool, optional
        Good means at or above ``value`` (True) or at or below it (False): the metric's
        direction, as the caller resolved it.
    source : str, optional
        Where the value came from (``'given'``, or the fit to people's votes).
    ci_lo, ci_hi : float, optional
        Its 95% interval (NaN: none, e.g. a given value).
    views : pandas.DataFrame, optional
        A threshold per view (:data:`VIEW_COLUMNS`, one row per view of the grid): an object
        seen from a view is good against that view's ``threshold``, and a horizon row's
        ``threshold_source`` is the ``source`` of its views. ``value`` is then not used to
        judge objects (it stays in the outputs as the pooled reference, NaN if none).
    """

    metric: str
    value: float
    good_above: bool = True
    source: str = "given"
    ci_lo: float = math.nan
    ci_hi: float = math.nan
    views: pd.DataFrame | None = field(default=None, compare=False, repr=False)


def resolve_metric(name: str | None, columns, *, param: str = "metric") -> str:
    """The metric column ``name`` means among ``columns``: itself, else the one column
    ``name:ENCODER``; ``None``: NVRQ-CA of the first encoder.

    >>> resolve_metric("nvrq_ca", ["psnr", "nvrq_ca:efficientnet-lite0"])
    'nvrq_ca:efficientnet-lite0'

    Parameters
    ----------
    name : str or None
        A metric name as the user wrote it.
    columns : sequence of str
        The metric columns of the input.
    param : str, optional
        The parameter named in errors.

    Returns
    -------
    str
        The column.

    Raises
    ------
    InputError
        No column, or several, match.
    """
    columns = [str(c) for c in columns]
    want = "nvrq_ca" if name is None else name
    if want in columns:
        return want
    hits = [c for c in columns if c.startswith(want + ":")]
    if len(hits) != 1:
        raise InputError(param=param, field=want, expected="a metric column of the input ("
                         + (", ".join(columns) or "none") + ")",
                         got="several: " + ", ".join(hits) if hits else "no such column")
    return hits[0]


def _as_threshold(threshold, metric, higher_better, columns) -> Threshold:
    """A :class:`Threshold` from the API's arguments (a number or a Threshold)."""
    if isinstance(threshold, Threshold):
        col = resolve_metric(threshold.metric, columns)
        return Threshold(col, threshold.value, threshold.good_above, threshold.source,
                         threshold.ci_lo, threshold.ci_hi, threshold.views)
    check_number("threshold", threshold)
    col = resolve_metric(metric, columns)
    return Threshold(col, float(threshold), True if higher_better is None else bool(higher_better))


def _check(scores: pd.DataFrame, th: Threshold, share: float, min_clusters: int) -> None:
    check_number("share", share, low=0, high=1, low_open=True)
    if int(min_clusters) < 2:
        raise InputError(param="min_clusters", expected="an integer >= 2", got=min_clusters)
    for need in ("track_id", "label_class"):
        if need not in scores.columns:
            raise InputError(param="scores", field=need, expected="a per-object score column",
                             got="no such column")
    if not pd.api.types.is_numeric_dtype(scores[th.metric]):
        raise InputError(param="scores", field=th.metric, expected="numeric scores",
                         got=scores[th.metric].dtype)


@dataclass(frozen=True)
class _Rows:
    """The resolved per-row arrays of a score table (rows with a finite score only)."""

    good: np.ndarray  # (N,) bool
    axis: np.ndarray  # (N,) object: axis name, 'none' or 'combined'
    value: np.ndarray  # (N,) signed value along the axis (0.01 precision)
    track: np.ndarray  # (N,) int64 track code
    keys: pd.DataFrame  # (N rows) method, label_class (+ clip_id, camera, timestamp_us)


def view_keys(axis: np.ndarray, value: np.ndarray) -> pd.MultiIndex:
    """The view of each row as ``(axis, offset)``: ``('none', 0.0)`` for the recorded view, the
    signed offset at 0.01 precision otherwise (NaN for a view along several axes).

    >>> view_keys(np.array(["none", "y", "y"], object), np.array([0.0, -1.004, 2.0])).tolist()
    [('none', 0.0), ('y', -1.0), ('y', 2.0)]

    Parameters
    ----------
    axis : numpy.ndarray
        (N,) axis names (:func:`data_schema.perturbation.axes`).
    value : numpy.ndarray
        (N,) signed values along them.

    Returns
    -------
    pandas.MultiIndex
        N ``(axis, offset)`` keys.
    """
    off = np.where(axis == "none", 0.0, np.round(np.asarray(value, np.float64), 2)) + 0.0  # no -0.0
    return pd.MultiIndex.from_arrays([np.asarray(axis, object), off], names=["axis", "offset"])


def class_rows(views: pd.DataFrame) -> np.ndarray:
    """(V,) bool: the rows of a per-view threshold table that judge one class only (a
    ``label_class`` other than :data:`ALL_CLASSES`, empty or missing).

    Parameters
    ----------
    views : pandas.DataFrame
        A per-view threshold table (:data:`VIEW_COLUMNS`, optionally ``label_class``).

    Returns
    -------
    numpy.ndarray
    """
    if "label_class" not in views.columns:
        return np.zeros(len(views), bool)
    c = views["label_class"]
    return (c.notna() & ~c.astype(str).isin([ALL_CLASSES, "", "nan"])).to_numpy()


def _view_table(views: pd.DataFrame) -> pd.Series:
    """The thresholds of ``views`` indexed by :func:`view_keys` (offset 0 is the recorded view
    whatever its axis)."""
    off = np.round(views["offset"].to_numpy(np.float64), 2)
    ax = np.where((views["axis"].astype(str) == "none") | (off == 0), "none", views["axis"].astype(str))
    return pd.Series(views["threshold"].to_numpy(np.float64), index=view_keys(ax.astype(object), off))


def _view_thresholds(th: Threshold, axis: np.ndarray, value: np.ndarray, cls: np.ndarray) -> np.ndarray:
    """(N,) each row's threshold: ``th.value``, or its view's in ``th.views``: the row of its
    class ``cls`` there if the table has one, else the row for every class."""
    if th.views is None:
        return np.full(len(axis), th.value)
    mine = class_rows(th.views)
    table = _view_table(th.views[~mine])
    keys = view_keys(axis, value)
    pos = table.index.get_indexer(keys)
    single = np.isin(axis, AXES) | (axis == "none")
    missing = single & ((pos < 0) | ~np.isfinite(table.to_numpy()[np.maximum(pos, 0)]))
    if missing.any():
        views = sorted({f"{a} {o:+g}" if a != "none" else "the recorded view" for a, o in keys[missing]})
        raise InputError(param="threshold", field="views", expected="a finite threshold at every view "
                         "of the grid", got="none at " + ", ".join(views))
    out = np.where(pos >= 0, table.to_numpy()[np.maximum(pos, 0)], np.nan)
    if not mine.any():
        return out
    for c, rows in th.views[mine].groupby(th.views.loc[mine, "label_class"].astype(str), sort=True):
        t = _view_table(rows[np.isfinite(rows["threshold"].to_numpy(np.float64))])
        at = np.flatnonzero(cls == c)
        p = t.index.get_indexer(keys[at])
        out[at[p >= 0]] = t.to_numpy()[p[p >= 0]]
    return out


def _rows(scores: pd.DataFrame, th: Threshold) -> _Rows:
    s = scores[np.isfinite(pd.to_numeric(scores[th.metric], errors="coerce").to_numpy(np.float64))]
    v = s[th.metric].to_numpy(np.float64)
    P = perturbation_array(s)
    limit = _view_thresholds(th, axes(P), axis_values(P), s["label_class"].astype(str).to_numpy())
    good = v >= limit if th.good_above else v <= limit
    ids = [s[c].astype(str) for c in ("clip_id", "track_id") if c in s.columns]
    # codes in sorted (clip_id, track_id) order: the bootstrap draws the same tracks whatever the row order
    track = pd.factorize(pd.MultiIndex.from_arrays(ids) if len(ids) > 1 else ids[0], sort=True)[0]
    keys = pd.DataFrame({"method": s["method"].astype(str) if "method" in s.columns else NO_METHOD,
                         "label_class": s["label_class"].astype(str).to_numpy()}, index=s.index)
    for c in ("clip_id", "camera", "timestamp_us"):
        if c in s.columns:
            keys[c] = s[c].to_numpy()
    return _Rows(good, axes(P), np.round(axis_values(P), 2), track.astype(np.int64),
                 keys.reset_index(drop=True))


def _check_grid(rows: _Rows) -> None:
    """Refuse a table with fewer than two offsets along every axis (no horizon to find)."""
    named = rows.axis[np.isin(rows.axis, AXES)]
    if len(named) == 0:
        got = "only the recorded view" if (rows.axis == "none").any() else "no single-axis view"
        raise InputError(param="scores", field="view", expected="at least two offsets along an "
                         "axis (the recorded view and one more) to find a horizon", got=got)


def _boot_counts(n_tracks: int, n_boot: int, seed: int) -> np.ndarray:
    """(B, T) float64: how often each of T tracks is drawn in each of B replicates."""
    rng = np.random.default_rng(seed)
    return rng.multinomial(n_tracks, np.full(n_tracks, 1.0 / n_tracks), size=n_boot).astype(np.float64)


def _first_fail(share: np.ndarray, s: float) -> np.ndarray:
    """(B,) index of the first grid offset whose share (B, K) is below ``s`` (K: none fails;
    an offset without objects in a replicate, NaN, does not fail)."""
    fail = share < s
    return np.where(fail.any(axis=1), fail.argmax(axis=1), share.shape[1])


def _crossings(share: np.ndarray, grid: np.ndarray, s: float) -> np.ndarray:
    """(B,) the interpolated crossing of ``s`` by the share curves (B, K) over ``grid`` (K,);
    the largest offset when none fails, the first when it fails."""
    K = len(grid)
    f = _first_fail(share, s)
    p = np.clip(f - 1, 0, K - 1)
    fi = np.minimum(f, K - 1)
    rows = np.arange(share.shape[0])
    sp = np.nan_to_num(share[rows, p], nan=s)
    sf = share[rows, fi]
    with np.errstate(invalid="ignore", divide="ignore"):
        frac = np.clip((sp - s) / (sp - sf), 0.0, 1.0)
    x = grid[p] + np.nan_to_num(frac) * (grid[fi] - grid[p])
    return np.where(f >= K, grid[-1], np.where(f == 0, grid[0], x))


def _curve_parts(mag: np.ndarray, good: np.ndarray, track: np.ndarray):
    """(grid (K,), n (T, K), g (T, K)): the grid and per-track counts of objects and good ones."""
    grid, k = np.unique(mag, return_inverse=True)
    tcodes, t = np.unique(track, return_inverse=True)
    n = np.zeros((len(tcodes), len(grid)))
    g = np.zeros_like(n)
    np.add.at(n, (t, k), 1.0)
    np.add.at(g, (t, k), good.astype(np.float64))
    return grid, n, g


def _reason(first: int, grid: np.ndarray) -> str:
    """Why a group has no interpolated crossing: nothing fails, or the first grid offset does."""
    if first == len(grid):
        return "beyond the grid"
    return "fails at the recorded view" if grid[0] == 0 else f"fails at the nearest offset ({grid[0]:g})"


def _one(mag, good, track, *, share: float, n_boot: int, seed: int, min_clusters: int) -> dict:
    """The horizon of one group (module docstring): a dict of the result columns."""
    grid, n, g = _curve_parts(mag, good, track)
    curve = (g.sum(axis=0) / n.sum(axis=0))[None, :]
    f = int(_first_fail(curve, share)[0])
    K, T = len(grid), n.shape[0]
    out = {"horizon": grid[f - 1] if f > 0 else math.nan,
           "crossing": round(float(_crossings(curve, grid, share)[0]), 9) if 0 < f < K else math.nan,
           "ci_lo": math.nan, "ci_hi": math.nan, "n_tracks": T, "n_objects": int(n.sum()),
           "grid": grid, "share": curve[0]}
    reasons = [_reason(f, grid)] if f in (0, K) else []
    if T < min_clusters:
        reasons.append(f"{T} track{'s' if T != 1 else ''}, fewer than the {min_clusters} an interval needs")
    elif n_boot > 0 and K > 1:
        C = _boot_counts(T, n_boot, seed)
        with np.errstate(invalid="ignore", divide="ignore"):
            reps = _crossings((C @ g) / (C @ n), grid, share)
        lo, hi = (round(float(q), 9) for q in np.quantile(reps, [0.025, 0.975]))
        # the estimate the interval belongs to: the crossing, else the offset a replicate counts
        est = out["crossing"] if 0 < f < K else (grid[-1] if f == K else grid[0])
        if lo - 1e-9 <= est <= hi + 1e-9:
            out["ci_lo"], out["ci_hi"] = lo, hi
        else:
            reasons.append(f"the estimate lies outside its bootstrap interval [{lo:.4g}, {hi:.4g}]: "
                           "no interval given")
    out["reason"] = "; ".join(reasons)
    return out


def _direction_rows(rows: _Rows):
    """Yield ``(axis, direction, mask (N,), magnitude (N,))`` per axis and direction with a
    non-zero offset; the recorded view belongs to each."""
    none = rows.axis == "none"
    for axis in AXES:
        on = rows.axis == axis
        for name, sign in zip(DIRECTIONS[axis], (1.0, -1.0), strict=True):
            side = on & (np.sign(rows.value) == sign)
            if side.any():
                yield axis, name, side | none, np.abs(np.where(none, 0.0, rows.value))


def _groups(rows: _Rows, by: list[str]):
    """Yield ``(key tuple, row positions)`` of ``rows.keys`` grouped by ``by`` (sorted)."""
    yield from rows.keys.groupby(by, sort=True, observed=True).indices.items()


def _horizons(rows: _Rows, th: Threshold, by: list[str], opts: dict):
    """Yield ``(key, axis, direction, result dict)`` per group of ``by`` x axis x direction."""
    for axis, direction, mask, mag in _direction_rows(rows):
        for key, pos in _groups(rows, by):
            pos = pos[mask[pos]]
            if len(pos) == 0 or not (rows.axis[pos] == axis).any():
                continue
            yield key, axis, direction, _one(mag[pos], rows.good[pos], rows.track[pos], **opts)


def _prepare(scores, threshold, metric, higher_better, share, min_clusters):
    if not isinstance(scores, pd.DataFrame):
        raise InputError(param="scores", expected="a pandas DataFrame of per-object scores",
                         got=type(scores).__name__)
    th = _as_threshold(threshold, metric, higher_better, scores.columns)
    _check(scores, th, share, min_clusters)
    rows = _rows(scores, th)
    _check_grid(rows)
    return th, rows


def trust_horizon(scores: pd.DataFrame, *, threshold, share: float = DEFAULT_SHARE,
                  metric: str | None = None, higher_better: bool | None = None,
                  n_boot: int = 1000, seed: int = 0, min_clusters: int = MIN_CLUSTERS) -> pd.DataFrame:
    """The trust horizon per method, class, axis and direction (module docstring).

    Parameters
    ----------
    scores : pandas.DataFrame
        One row per object and view: ``track_id``, ``label_class``, the metric column, the
        perturbation columns (``y_offset_m``; absent ones are 0), optionally ``clip_id`` (tracks
        are ``(clip_id, track_id)``) and ``method``. Rows without a finite score are left out.
    threshold : float or Threshold
        Good means a score at or above it (at or below it where lower is better). A
        :class:`Threshold` brings its metric, direction and source.
    share : float, optional
        The share of objects (in (0, 1]) that must be good at every grid offset up to the horizon.
    metric : str, optional
        The metric column (a plain number ``threshold``); ``nvrq_ca`` matches ``nvrq_ca:ENC``;
        default: NVRQ-CA.
    higher_better : bool, optional
        With a plain number ``threshold``: the metric's direction (default True).
    n_boot, seed : int, optional
        Cluster-bootstrap replicates over tracks (0: no interval) and their seed.
    min_clusters : int, optional
        The fewest tracks a group needs for an interval.

    Returns
    -------
    pandas.DataFrame
        :data:`HORIZON_COLUMNS`, one row per method x class x axis x direction present; offsets
        in metres (x, y, z) or degrees (roll, pitch, yaw).

    Raises
    ------
    InputError
        A metric that is not a column, a share outside (0, 1], a table with fewer than two
        offsets along every axis.
    """
    th, rows = _prepare(scores, threshold, metric, higher_better, share, min_clusters)
    opts = {"share": float(share), "n_boot": int(n_boot), "seed": int(seed), "min_clusters": int(min_clusters)}
    out = [{"method": key[0], "label_class": key[1], "axis": axis, "direction": d, **r}
           for key, axis, d, r in _horizons(rows, th, ["method", "label_class"], opts)]
    t = pd.DataFrame(out, columns=[*HORIZON_COLUMNS, "n_objects", "grid", "share"])
    t = t.assign(metric=th.metric, threshold=th.value if th.views is None else math.nan,
                 threshold_source=[row_source(th, a, c) for a, c in zip(t["axis"], t["label_class"], strict=True)])
    return _sorted(t[HORIZON_COLUMNS], "label_class")


def row_source(th: Threshold, axis: str, label_class: str | None = None) -> str:
    """The threshold source of a horizon row along ``axis``: ``th.source``, or with per-view
    thresholds the distinct sources of the views that judged the row (the axis' and the
    recorded view's; those of ``label_class`` where the table has them), joined by ``'; '``.

    Parameters
    ----------
    th : Threshold
    axis : str
        An axis of :data:`data_schema.perturbation.AXES`.
    label_class : str, optional
        The row's class.

    Returns
    -------
    str
    """
    if th.views is None:
        return th.source
    v = th.views[th.views["axis"].isin([axis, "none"])]
    mine = class_rows(v)
    own = v[mine & (v["label_class"].astype(str) == str(label_class)).to_numpy()] if mine.any() else v[mine]
    used = _view_table(own[np.isfinite(own["threshold"].to_numpy(np.float64))]).index
    rest = v[~mine][~_view_table(v[~mine]).index.isin(used)]
    return "; ".join(dict.fromkeys([*own["source"].astype(str), *rest["source"].astype(str)])) or th.source


def _sorted(t: pd.DataFrame, cls: str) -> pd.DataFrame:
    """Rows by method, class, axis (x, y, z, roll, pitch, yaw) and direction (positive first)."""
    order = {(a, d): 2 * i + j for i, a in enumerate(AXES) for j, d in enumerate(DIRECTIONS[a])}
    key = pd.Series([order[(a, d)] for a, d in zip(t["axis"], t["direction"], strict=True)], index=t.index)
    return t.assign(_k=key).sort_values(["method", cls, "_k"], kind="stable").drop(columns="_k").reset_index(drop=True)


def share_curves(scores: pd.DataFrame, *, threshold, share: float = DEFAULT_SHARE,
                 metric: str | None = None, higher_better: bool | None = None) -> pd.DataFrame:
    """The share of good objects at each grid offset, per method, class, axis and direction
    (what the horizon reads; the figures draw it).

    Parameters
    ----------
    scores, threshold, share, metric, higher_better
        As for :func:`trust_horizon`.

    Returns
    -------
    pandas.DataFrame
        ``method, label_class, axis, direction, offset, share_good, n_objects``; signed offsets
        (negative for the second direction of :data:`DIRECTIONS`).
    """
    th, rows = _prepare(scores, threshold, metric, higher_better, share, MIN_CLUSTERS)
    parts = []
    for key, axis, d, r in _horizons(rows, th, ["method", "label_class"],
                                     {"share": float(share), "n_boot": 0, "seed": 0, "min_clusters": 2}):
        sign = 1.0 if d == DIRECTIONS[axis][0] else -1.0
        parts.append(pd.DataFrame({"method": key[0], "label_class": key[1], "axis": axis, "direction": d,
                                   "offset": sign * r["grid"], "share_good": r["share"]}))
    cols = ["method", "label_class", "axis", "direction", "offset", "share_good"]
    return pd.concat(parts, ignore_index=True) if parts else pd.DataFrame(columns=cols)


def _windows(rows: _Rows, window_s: float) -> np.ndarray:
    """(N,) int64 window index of each row: ``window_s`` seconds from its clip's first timestamp."""
    ts = rows.keys["timestamp_us"].to_numpy(np.int64)
    clip = rows.keys["clip_id"] if "clip_id" in rows.keys else pd.Series(0, index=rows.keys.index)
    start = pd.Series(ts).groupby(clip.to_numpy()).transform("min").to_numpy(np.int64)
    return (ts - start) // int(round(window_s * 1e6))


def horizon_timeline(scores: pd.DataFrame, *, threshold, share: float = DEFAULT_SHARE,
                     window_s: float = 2.0, n_boot: int = 1000, seed: int = 0,
                     min_clusters: int = MIN_CLUSTERS) -> pd.DataFrame:
    """The horizon per window of each clip and camera (horizon_timeline.csv).

    Parameters
    ----------
    scores : pandas.DataFrame
        As for :func:`trust_horizon`, with ``timestamp_us`` (and ``camera``; absent: ``''``).
    threshold : Threshold or float
        As for :func:`trust_horizon` (a float: NVRQ-CA, higher is better).
    share, n_boot, seed, min_clusters
        As for :func:`trust_horizon`.
    window_s : float, optional
        Window length in seconds, from each clip's first timestamp; in
        :data:`nvrq.choices.WINDOW_S_RANGE` (0.001 to 1e6 s), rounded to whole microseconds.

    Returns
    -------
    pandas.DataFrame
        :data:`TIMELINE_COLUMNS`; ``t0_us`` inclusive, ``t1_us`` exclusive; ``horizon`` empty
        where the recorded view already fails; ``n_objects``: object views (rows) of the group.
    """
    check_number("window_s", window_s, low=WINDOW_S_RANGE[0], high=WINDOW_S_RANGE[1])
    if "timestamp_us" not in scores.columns:
        raise InputError(param="scores", field="timestamp_us", expected="the time of each row for a "
                         "timeline", got="no such column")
    th, rows = _prepare(scores, threshold, None, None, share, min_clusters)
    keys = rows.keys.assign(_w=_windows(rows, window_s))
    for c in ("clip_id", "camera"):
        if c not in keys:
            keys[c] = ""
    rows = _Rows(rows.good, rows.axis, rows.value, rows.track, keys)
    opts = {"share": float(share), "n_boot": int(n_boot), "seed": int(seed), "min_clusters": int(min_clusters)}
    by = ["clip_id", "camera", "_w", "label_class", "method"]
    out = []
    starts = pd.Series(keys["timestamp_us"].to_numpy(np.int64)).groupby(keys["clip_id"].to_numpy()).min()
    w_us = int(round(window_s * 1e6))
    for key, axis, d, r in _horizons(rows, th, by, opts):
        t0 = int(starts[key[0]]) + int(key[2]) * w_us
        out.append({"clip_id": key[0], "camera": key[1], "t0_us": t0, "t1_us": t0 + w_us, "axis": axis,
                    "direction": d, "class": key[3], "method": key[4], "horizon": r["horizon"],
                    "ci_lo": r["ci_lo"], "ci_hi": r["ci_hi"], "n_objects": r["n_objects"]})
    t = pd.DataFrame(out, columns=TIMELINE_COLUMNS)
    return t.sort_values(["clip_id", "camera", "t0_us", "method", "class", "axis"], kind="stable",
                         ignore_index=True)


def unit_of(axis: str) -> str:
    """The unit of offsets along ``axis`` (``'m'`` or ``'deg'``)."""
    return AXIS_UNITS[axis]
