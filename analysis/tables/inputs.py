"""Reading and checking ``ratings.csv`` and metric tables (docs/FORMATS.md §4, §5, §7).

Layer: analysis (input tables).

Which columns are metrics — the written rule:

1. Known non-metric columns are never metrics: the ratings columns (``item_id, rater_id,
   vote, voted_at, response_ms, kind``), the pair columns of docs/FORMATS.md §3 (``clip_id``,
   ``camera``, ``track_id``, ``label_class``, ``timestamp_us``, ``y_offset_m``, paths and
   box corners), ``pair_id``, ``method`` (the reconstruction method, docs/FORMATS.md §2; carried
   through, not an attribute), ``gold_expected`` and the per-item labels ``analyze`` itself
   writes (``n_votes, n_good, gvf, majority_good, gvf_ci_lo, gvf_ci_hi, p_good,
   model_good``).
2. Registry entries of kind ``proxy`` (``s_det``, ``imagenet_drop``, ``clip_drop``) are
   downstream targets for ``--target``, not metrics ranked against GVF.
3. Every other *numeric* column is a metric. Its direction comes from the metric registry
   (``nvrq.metrics.direction``) or from ``--lower-better/--higher-better``; a metric with
   no known direction stops the command with an error naming it.
4. Every other non-numeric column is a scene attribute (e.g. ``lighting``, ``road_type``)
   when it is constant per item; results are broken down by it.

Every column of a ``--metrics`` file other than ``pair_id`` must be numeric.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from data_schema.csv_safe import unquote_frame
from data_schema.errors import InputError
from data_schema.methods import FLOOR_PAIR_COLUMNS, METHOD_COLUMN
from data_schema.perturbation import VIEW_COLUMNS
from data_schema.tables import (
    ITEM_KINDS,
    PAIR_META_COLUMNS,
    PAIRS_COLUMNS,
    RATINGS_COLUMNS,
    SOURCE_VISIBILITY,
    VISIBILITY_COLUMNS,
    read_metrics,
    read_table,
)
from data_schema.tables import csv_line as _line
from nvrq.metrics import column_info, direction

__all__ = [
    "CANONICAL_VOTE_ORDER",
    "NON_METRIC_COLUMNS",
    "MAX_METRICS",
    "read_ratings",
    "read_metrics",
    "classify_columns",
    "drop_empty_columns",
]

#: The most metric columns one analysis takes (docs/FORMATS.md §6): every metric gets its own
#: statistics, bootstrap and figure panels, so the report's time grows with them (about a second
#: per metric on a small study).
MAX_METRICS = 100

ITEM_LABEL_COLUMNS = (
    "n_votes",
    "n_good",
    "gvf",
    "majority_good",
    "gvf_ci_lo",
    "gvf_ci_hi",
    "p_good",
    "model_good",
)
#: The canonical order of votes (docs/FORMATS.md §6): :func:`read_ratings` sorts by these keys
#: (unique per vote), so every result is the same for any row order of the file.
CANONICAL_VOTE_ORDER = ("item_id", "rater_id", "kind")
NON_METRIC_COLUMNS = frozenset(
    RATINGS_COLUMNS + PAIRS_COLUMNS + ITEM_LABEL_COLUMNS + ("gold_expected",) + VIEW_COLUMNS + (METHOD_COLUMN,)
    + FLOOR_PAIR_COLUMNS + VISIBILITY_COLUMNS + (SOURCE_VISIBILITY,)
)


def _check_vote_columns(df: pd.DataFrame, path) -> None:
    """At least one row; ``vote`` 0 or 1, ``kind`` an item kind, ids present, ``response_ms``
    numeric (``vote`` and ``response_ms`` converted in place); errors name the file's line."""
    if len(df) == 0:
        raise InputError(path, None, "at least one vote row", "no rows")
    vote = pd.to_numeric(df["vote"], errors="coerce")
    bad = ~vote.isin([0, 1])
    if bad.any():
        i = int(np.flatnonzero(bad.to_numpy())[0])
        raise InputError(path, f"{_line(i)}: vote", "0 or 1", df["vote"].iloc[i])
    df["vote"] = vote.astype(np.int8)
    bad = ~df["kind"].isin(ITEM_KINDS)
    if bad.any():
        i = int(np.flatnonzero(bad.to_numpy())[0])
        raise InputError(
            path, f"{_line(i)}: kind", "one of " + ", ".join(ITEM_KINDS), df["kind"].iloc[i]
        )
    for col, what in (("item_id", "an item id"), ("rater_id", "a rater id")):
        bad = df[col].isna()
        if bad.any():
            raise InputError(
                path, f"{_line(int(np.flatnonzero(bad.to_numpy())[0]))}: {col}", what, "empty"
            )
    rt = pd.to_numeric(df["response_ms"], errors="coerce")
    bad = rt.isna() & df["response_ms"].notna()
    if bad.any():
        i = int(np.flatnonzero(bad.to_numpy())[0])
        raise InputError(
            path, f"{_line(i)}: response_ms", "a number of milliseconds", df["response_ms"].iloc[i]
        )
    df["response_ms"] = rt.astype(np.float64)


def read_ratings(path) -> pd.DataFrame:
    """Read ``ratings.csv`` and check it (docs/FORMATS.md §5 and §7); returns one row per vote
    in the canonical order (:data:`CANONICAL_VOTE_ORDER`, docs/FORMATS.md §6), whatever the
    file's row order.

    Checks: the contract columns exist; at least one row; ``vote`` is 0 or 1; ``kind`` is one of
    ``{'test', 'gold', 'training', 'repeat'}``; ``response_ms`` is numeric; no rater has two
    rows for the same (item, kind). Errors name the file's line.

    Parameters
    ----------
    path : str or pathlib.Path
        The ratings table (``ratings.csv``).

    Returns
    -------
    pandas.DataFrame
        One row per vote, in the canonical order.

    Raises
    ------
    InputError
        When a check fails, naming the file's line.
    """
    df = read_table(
        path,
        required=RATINGS_COLUMNS + PAIR_META_COLUMNS,
        what="ratings table",
        dtype={
            "item_id": str,
            "rater_id": str,
            "kind": str,
            "clip_id": str,
            "track_id": str,
            "camera": str,
            "label_class": str,
        },
    )
    df = unquote_frame(df)  # cells annotate export quoted against spreadsheet formulas
    _check_vote_columns(df, path)
    # sorted codes of the order's keys: the checks below and the canonical sort share them
    codes = {c: pd.factorize(df[c], sort=True)[0] for c in CANONICAL_VOTE_ORDER}
    _check_item_metadata(df, path, codes["item_id"])
    key = codes["item_id"].astype(np.int64)
    for c in CANONICAL_VOTE_ORDER[1:]:
        key = key * (int(codes[c].max()) + 1) + codes[c]
    dup = pd.Series(key).duplicated(keep="first")  # the same (item, rater, kind) again
    if dup.any():
        i = int(np.flatnonzero(dup.to_numpy())[0])
        raise InputError(
            path,
            _line(i),
            "one row per (rater_id, item_id, kind) (a changed vote keeps only the last)",
            f"a second row for rater {df['rater_id'].iloc[i]!r}, item {df['item_id'].iloc[i]!r}",
        )
    order = np.argsort(key, kind="stable")  # unique keys: a total order
    if (order[1:] < order[:-1]).any():
        df = df.take(order).reset_index(drop=True)
    return df


def _check_item_metadata(df: pd.DataFrame, path, item_codes: np.ndarray) -> None:
    """``timestamp_us`` an integer, ``y_offset_m`` a number, and each item's pair metadata
    (docs/FORMATS.md §5: clip, camera, track, class, timestamp, offset) the same on all its rows.

    ``item_codes``: (n,) int codes of ``df['item_id']``. A differing item is reported at its
    last row (the item that appears first in the file among those that differ)."""
    for col, what in (("timestamp_us", "an integer timestamp in microseconds"),
                      ("y_offset_m", "a number of metres")):
        num = pd.to_numeric(df[col], errors="coerce")
        bad = num.isna() & df[col].notna()
        if col == "timestamp_us":
            bad |= num.notna() & (num != np.round(num))
        if bad.any():
            i = int(np.flatnonzero(bad.to_numpy())[0])
            raise InputError(path, f"{_line(i)}: {col}", what, df[col].iloc[i])
        df[col] = num
    rows = np.arange(len(df))
    first = np.empty(int(item_codes.max()) + 1, dtype=np.int64)
    first[item_codes[::-1]] = rows[::-1]  # each item's first row
    for col in PAIR_META_COLUMNS:
        values = pd.factorize(df[col], use_na_sentinel=False)[0]  # a missing value is a value
        differs = values != values[first[item_codes]]
        if differs.any():
            bad_items = np.unique(item_codes[differs])
            code = bad_items[np.argmin(first[bad_items])]
            item = df["item_id"].iloc[first[code]]
            at = np.flatnonzero(item_codes == code)
            raise InputError(path, f"{_line(int(at[-1]))}: {col}", f"one {col} per item (item {item!r})",
                             ", ".join(map(str, df[col].iloc[at].unique()[:3])))


def classify_columns(
    df: pd.DataFrame, *, lower: set[str], higher: set[str], target: str | None, where
) -> tuple[list[str], dict[str, bool], list[str], list[str]]:
    """Split the columns of the joined votes into (metrics, directions, attributes, proxies).

    See the module docstring for the rule. ``target`` (if given) is neither metric nor attribute.

    Parameters
    ----------
    df : pandas.DataFrame
        The votes joined with metric tables.
    lower, higher : set of str
        Metrics declared lower- or higher-is-better.
    target : str or None
        The target column.
    where : object
        The file named in errors.

    Returns
    -------
    metrics : list of str
    directions : dict
        Metric -> whether higher is better.
    attributes : list of str
    proxies : list of str

    Raises
    ------
    InputError
        A metric of unknown direction, a column given both directions or absent, a
        non-numeric column given a direction, or more than :data:`MAX_METRICS` metrics.
    """
    both = lower & higher
    if both:
        raise InputError(
            param="higher", field=sorted(both)[0], expected="one direction per metric", got="both"
        )
    for name in sorted(lower | higher):
        if name not in df.columns:
            raise InputError(
                param="lower" if name in lower else "higher",
                field=name,
                expected="a column of the ratings or metrics",
                got="no such column",
            )
    metrics, directions, attributes, proxies = [], {}, [], []
    for col in df.columns:
        if col in NON_METRIC_COLUMNS or col == target:
            continue
        info = column_info(col, kind=None, default=None)
        numeric = pd.api.types.is_numeric_dtype(df[col]) and not pd.api.types.is_bool_dtype(df[col])
        if info is not None and info.kind == "proxy" and col not in lower | higher:
            proxies.append(col)
            continue
        if not numeric:
            if col in lower | higher:
                raise InputError(where, f"column {col!r}", "numeric metric values", df[col].dtype)
            attributes.append(col)
            continue
        d = True if col in higher else False if col in lower else direction(col)
        if d is None:
            raise InputError(
                where,
                f"column {col!r}",
                "a metric with a known direction; say `lower_better` "
                f"{col} or `higher_better` {col}",
                "an unknown metric",
            )
        metrics.append(col)
        directions[col] = bool(d)
    if len(metrics) > MAX_METRICS:
        raise InputError(where, None, f"at most {MAX_METRICS} metric columns in one analysis (with the "
                         "metrics tables; split them over several analyses)", f"{len(metrics)} metric columns")
    return metrics, directions, attributes, proxies


def drop_empty_columns(items: pd.DataFrame, *, keep=(), unit: str = "item") -> tuple[pd.DataFrame, list[str]]:
    """``items`` without the columns that hold no value (numeric: no finite value; else all
    missing), except those in ``keep``, and the report's notes on them.

    A metric of the registry with no value is *undefined for these crops*, a note of its own
    that says the crop size it needs (``min_side``) or when else it is NaN; other empty columns
    share one "empty columns ignored" note. ``unit``: what a row is, for the notes.

    Parameters
    ----------
    items : pandas.DataFrame
        One row per item (or pair).
    keep : iterable of str, optional
        Columns kept even when empty.
    unit : str, optional
        What a row is, for the notes.

    Returns
    -------
    kept : pandas.DataFrame
    notes : list of str

    >>> t = pd.DataFrame({"niqe": [np.nan, np.nan], "psnr": [30.0, 31.0], "x": [None, None]})
    >>> kept, notes = drop_empty_columns(t, unit="pair")
    >>> list(kept.columns), notes[0]
    (['psnr'], 'niqe: undefined for every one of these 2 pairs, left out (NaN on all; a crop with \
a shorter side below 96 px gives NaN)')
    >>> notes[1]
    'empty columns ignored: x'
    """
    def empty(c) -> bool:
        col = items[c]
        if pd.api.types.is_numeric_dtype(col) and not pd.api.types.is_bool_dtype(col):
            return not np.isfinite(col.to_numpy(np.float64)).any()
        return bool(col.isna().all())

    gone = [c for c in items.columns if c not in keep and empty(c)]
    notes, other = [], []
    for c in gone:
        info = column_info(str(c), kind="metric", default=None)
        if info is None:
            other.append(str(c))
            continue
        why = [f"a crop with a shorter side below {info.min_side} px gives NaN"] if info.min_side > 1 else []
        why += [f"so does {info.undefined}"] if info.undefined else []
        notes.append(f"{c}: undefined for every one of these {len(items)} {unit}s, left out (NaN on "
                     "all" + "".join(f"; {w}" for w in why) + ")")
    if other:
        notes.append("empty columns ignored: " + ", ".join(other))
    return items.drop(columns=gone), notes
