"""The viewpoint floor in the reports: what a perfect render would score at each view
(analysis layer; docs/FORMATS.md §3 and §11).

Two methods of a pairs table measure the viewpoint, not a reconstruction
(:data:`data_schema.methods.REFERENCE_METHODS`):

- ``perfect``: a synthetic render with no artefact (``nvrq synth --methods perfect:0``);
- ``floor``: pairs of two GT views of one object whose change of viewpoint matches the novel
  view's (``nvrq pairs --floor``, :mod:`nvrq.floor`), the floor a real log can give.

The reports draw them as the "viewpoint floor" (a dashed line, no interval band) beside the
methods. ``perfect`` is always drawn. ``floor`` stands in for a perfect render, so it is drawn only
when it predicts one: within :data:`FLOOR_TOLERANCE` NVRQ-CA of the perfect render's median at
every offset it covers (:func:`floor_verdict`). A table holding both methods (a synthetic clip
with ``--floor``) is checked on itself (:func:`floor_check`); a real log, which has no perfect
render, is checked against the figures measured on the synthetic clip of docs/FORMATS.md §3
(:data:`MEASURED_GAPS`): an offset the measurement does not cover is not vouched for.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from analysis.common.text import offset_text
from data_schema.methods import (
    FLOOR_METHOD,
    METHOD_COLUMN,
    PERFECT_METHOD,
    REFERENCE_METHODS,
    method_values,
)
from data_schema.perturbation import PERTURBATION_COLUMNS
from data_schema.tables import OBJECT_COLUMNS

__all__ = ["FLOOR_TOLERANCE", "FLOOR_METRIC_PREFIX", "MEASURED_GAPS", "FLOOR_LABELS", "FLOOR_COLOUR", "FloorVerdict",
           "floor_label", "is_reference", "floor_check", "floor_verdict", "items_floor_verdict", "floor_by_offset",
           "tent_floor"]

#: the largest gap (NVRQ-CA) between the floor's and the perfect render's medians at an offset
FLOOR_TOLERANCE = 0.1
#: the metric the rule is judged on: NVRQ-CA (of any encoder; ``nvrq_ca`` or ``nvrq_ca:ENCODER``)
FLOOR_METRIC_PREFIX = "nvrq_ca"
#: floor median minus perfect median of NVRQ-CA (efficientnet-lite0) per lateral offset (m), on the
#: same novel views, measured on the synthetic clip of docs/FORMATS.md §3 (2 s, 640x360, 5 fps,
#: seed 0, ``--methods perfect:0,sharp:0.5``, offsets -3..3; ``python docs/make_floor_numbers.py OUT``)
MEASURED_GAPS = {-1.0: -0.105, 1.0: 0.086}
#: the colour of the floor's dashed line in every figure
FLOOR_COLOUR = "0.3"
#: how the reports name the reference methods
FLOOR_LABELS = {PERFECT_METHOD: "viewpoint floor (perfect render)", FLOOR_METHOD: "viewpoint floor (two GT views)"}


@dataclass(frozen=True)
class FloorVerdict:
    """Whether the reports draw the ``floor`` method, and the sentence that says why.

    Attributes
    ----------
    draw : bool
        True when the floor predicts the perfect render at every offset it covers.
    sentence : str
        One sentence for the report.
    gaps : dict
        Offset (m) -> floor median minus perfect median (NVRQ-CA) the verdict was judged on.
    """

    draw: bool
    sentence: str
    gaps: dict


def floor_label(method: str) -> str:
    """The report's name of a method: :data:`FLOOR_LABELS` for a reference method, else itself.

    Parameters
    ----------
    method : str
        A method name (``''`` for none).

    Returns
    -------
    str

    >>> floor_label("perfect"), floor_label("3dgs")
    ('viewpoint floor (perfect render)', '3dgs')
    """
    return FLOOR_LABELS.get(method, method)


def is_reference(method: str) -> bool:
    """Whether ``method`` measures the viewpoint (:data:`data_schema.methods.REFERENCE_METHODS`).

    Parameters
    ----------
    method : str
        A method name.

    Returns
    -------
    bool
    """
    return method in REFERENCE_METHODS


def _lateral(items: pd.DataFrame) -> np.ndarray:
    """``(N,)`` bool: the rows whose view is lateral (every 6-DoF column other than y is 0 or absent)."""
    cols = [c for c in PERTURBATION_COLUMNS if c in items.columns and c != "y_offset_m"]
    if not cols:
        return np.ones(len(items), bool)
    return (items[cols].apply(pd.to_numeric).fillna(0) == 0).all(axis=1).to_numpy()


def floor_check(items: pd.DataFrame, metric: str) -> pd.DataFrame:
    """The floor against the perfect render per lateral offset, on the same novel views.

    Parameters
    ----------
    items : pandas.DataFrame
        One row per pair (N rows): :data:`data_schema.tables.OBJECT_COLUMNS`, ``y_offset_m`` (and
        the optional 6-DoF view columns, all 0 on the lateral views used here), ``method`` and
        ``metric``; rows of methods ``floor`` and ``perfect`` are used.
    metric : str
        The metric column.

    Returns
    -------
    pandas.DataFrame
        One row per offset with a floor row: ``offset, n, floor, perfect, perfect_all, gap``:
        ``n`` floor rows, their median ``floor``, the median ``perfect`` of the perfect render on
        the same (camera, frame, track, offset) views, the perfect render's median on all its
        views of that offset, and ``gap = floor - perfect``, in offset order.
    """
    method = method_values(items)
    lateral = _lateral(items)
    keys = [*OBJECT_COLUMNS, "y_offset_m"]
    fl = items.loc[(method == FLOOR_METHOD) & lateral, [*keys, metric]]
    pf = items.loc[(method == PERFECT_METHOD) & lateral, [*keys, metric]]
    both = fl.merge(pf, on=keys, suffixes=("_floor", "_perfect"))
    rows = []
    for off, g in both.groupby("y_offset_m", sort=True):
        a, b = g[f"{metric}_floor"].to_numpy(float), g[f"{metric}_perfect"].to_numpy(float)
        ok = np.isfinite(a) & np.isfinite(b)
        if not ok.any():
            continue
        all_p = pf.loc[pf["y_offset_m"] == off, metric].to_numpy(float)
        rows.append({"offset": float(off), "n": int(ok.sum()), "floor": float(np.median(a[ok])),
                     "perfect": float(np.median(b[ok])), "perfect_all": float(np.nanmedian(all_p)),
                     "gap": float(np.median(a[ok]) - np.median(b[ok]))})
    return pd.DataFrame(rows, columns=["offset", "n", "floor", "perfect", "perfect_all", "gap"])


def floor_verdict(gaps: dict, covered, *, tolerance: float = FLOOR_TOLERANCE, source: str = "") -> FloorVerdict:
    """The rule: draw the floor when it predicts the perfect render within ``tolerance`` at every
    offset it covers.

    Parameters
    ----------
    gaps : dict
        Offset (m) -> floor median minus perfect median (NVRQ-CA), where measured.
    covered : iterable of float
        The offsets (m) the floor covers in the report's data.
    tolerance : float, optional
        The largest ``|gap|`` allowed (:data:`FLOOR_TOLERANCE`).
    source : str, optional
        Where the gaps were measured, for the sentence (e.g. ``"on the synthetic check clip"``).

    Returns
    -------
    FloorVerdict
        ``draw`` False when some covered offset's ``|gap|`` exceeds ``tolerance``, has no
        measured gap, or when nothing is covered; the sentence names the first failing offset.

    >>> floor_verdict({-1.0: -0.07, 1.0: 0.02}, [-1.0, 1.0]).draw
    True
    >>> floor_verdict({-1.0: -0.07, 1.0: 0.02}, [1.0, 2.0]).sentence
    'The viewpoint floor (two GT views) is left out: it was not checked against a perfect render at +2 m.'
    """
    covered = sorted({float(o) for o in covered})
    where = f" {source}" if source else ""
    if not covered:
        return FloorVerdict(False, "The viewpoint floor (two GT views) is left out: it covers no offset.", {})
    used = {o: gaps.get(o, np.nan) for o in covered}
    for o in covered:
        g = used[o]
        if not np.isfinite(g):
            return FloorVerdict(False, f"The viewpoint floor (two GT views) is left out: it was not checked "
                                f"against a perfect render at {offset_text(o)} m{where}.", used)
        if abs(g) > tolerance:
            return FloorVerdict(False, f"The viewpoint floor (two GT views) is left out: at {offset_text(o)} m "
                                f"its median NVRQ-CA is {abs(g):.3f} {'below' if g < 0 else 'above'} a perfect "
                                f"render's{where}, more than the {tolerance:g} allowed.", used)
    worst = max(abs(g) for g in used.values())
    offsets = ", ".join(f"{offset_text(o)} m" for o in covered)
    return FloorVerdict(True, f"The viewpoint floor (two GT views) is drawn: it predicts a perfect render's "
                        f"median NVRQ-CA within {worst:.3f} at every offset it covers ({offsets}){where}.", used)


def items_floor_verdict(items: pd.DataFrame, metrics) -> FloorVerdict | None:
    """:func:`floor_verdict` for a report's per-pair items: None without ``floor`` rows.

    The gaps come from the items themselves when they also hold ``perfect`` rows (a synthetic
    clip), else from :data:`MEASURED_GAPS`; the covered offsets are the lateral offsets of the
    ``floor`` rows.

    Parameters
    ----------
    items : pandas.DataFrame
        One row per pair, with ``method`` and the metric columns (N rows).
    metrics : list of str
        The metric columns; the first NVRQ-CA column (:data:`FLOOR_METRIC_PREFIX`) judges.

    Returns
    -------
    FloorVerdict or None
    """
    if METHOD_COLUMN not in items.columns:
        return None
    method = method_values(items)
    if not (method == FLOOR_METHOD).any():
        return None
    lateral = _lateral(items)
    offsets = pd.to_numeric(items.loc[(method == FLOOR_METHOD) & lateral, "y_offset_m"]).unique()
    ca = [m for m in metrics if m == FLOOR_METRIC_PREFIX or str(m).startswith(FLOOR_METRIC_PREFIX + ":")]
    if (method == PERFECT_METHOD).any() and ca:
        check = floor_check(items, ca[0])
        return floor_verdict(dict(zip(check["offset"], check["gap"], strict=True)), offsets,
                             source="on this clip")
    return floor_verdict(MEASURED_GAPS, offsets, source="on the synthetic check clip (docs/FORMATS.md §3)")


def floor_by_offset(pairs: pd.DataFrame, metrics: pd.DataFrame, *, where: object = "floor pairs") -> pd.DataFrame:
    """The viewpoint floor of a tent plot: each metric's mean per lateral offset over the pairs of
    a reference method (``perfect``, else ``floor``), e.g. a perfect render of the demo's clip.

    Parameters
    ----------
    pairs : pandas.DataFrame
        A pairs table (N rows) with ``pair_id``, ``y_offset_m`` and ``method``.
    metrics : pandas.DataFrame
        Its metrics table: ``pair_id`` and metric columns.
    where : object, optional
        The pairs file, named in errors.

    Returns
    -------
    pandas.DataFrame
        ``y_offset_m, column, n, mean``: one row per offset and metric column (as
        :func:`analysis.tables.breakdowns.offset_table`'s), in offset order.

    Raises
    ------
    InputError
        ``pairs`` has no row of method ``perfect`` or ``floor`` on a lateral view, or no metric
        of ``metrics`` scores them.
    """
    from data_schema.errors import InputError

    method = method_values(pairs)
    ref = PERFECT_METHOD if (method == PERFECT_METHOD).any() else FLOOR_METHOD
    rows = pairs.loc[(method == ref) & _lateral(pairs), ["pair_id", "y_offset_m"]]
    if rows.empty:
        raise InputError(where, METHOD_COLUMN, "pairs of method perfect (a render with no artefact) or floor (two GT "
                         "views of each object) on lateral views", "none")
    cols = [c for c in metrics.columns if c != "pair_id" and pd.api.types.is_numeric_dtype(metrics[c])]
    got = rows.merge(metrics[["pair_id", *cols]], on="pair_id", how="inner")
    if got.empty or not cols:
        raise InputError(where, "pair_id", f"metric values for its {ref} pairs in the floor metrics table",
                         "none matches")
    long = got.melt(id_vars=["y_offset_m"], value_vars=cols, var_name="column", value_name="v").dropna()
    out = long.groupby(["y_offset_m", "column"], sort=True)["v"].agg(n="size", mean="mean").reset_index()
    return out[["y_offset_m", "column", "n", "mean"]]


def tent_floor(pairs: pd.DataFrame, metrics: pd.DataFrame, *,
               where: object = "floor pairs") -> tuple[pd.DataFrame | None, str]:
    """The tent plot's floor and the report's sentence about it: a perfect render is drawn; a
    log's floor (``floor`` rows, no ``perfect``) only when :func:`items_floor_verdict` says so.

    Parameters
    ----------
    pairs : pandas.DataFrame
        A pairs table with ``method`` (N rows).
    metrics : pandas.DataFrame
        Its metrics table.
    where : object, optional
        The pairs file, named in errors.

    Returns
    -------
    floor : pandas.DataFrame or None
        :func:`floor_by_offset`'s table, or None when a log's floor is left out.
    sentence : str
        The verdict's sentence for a log's floor; ``''`` for a perfect render.

    Raises
    ------
    InputError
        As :func:`floor_by_offset`.
    """
    table = floor_by_offset(pairs, metrics, where=where)
    if (method_values(pairs) == PERFECT_METHOD).any():
        return table, ""
    cols = [c for c in metrics.columns if c != "pair_id"]
    verdict = items_floor_verdict(pairs.merge(metrics, on="pair_id"), cols)
    return (table if verdict.draw else None), verdict.sentence
