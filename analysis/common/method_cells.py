"""The cells the method comparison breaks objects into (docs/FORMATS.md §11): on and off the
recorded path, each view, and crossed breakdowns (``--by class,offset``).

Layer: analysis (statistics of votes and metrics).

- *On-path* is the recorded camera's own view (every perturbation component 0: offset 0);
  *off-path* is every other view, the novel views a reconstruction is benchmarked on.
- A crossed breakdown names columns of the objects (``label_class``, a scene attribute such
  as ``lighting``) and optionally ``view``: one cell per combination of their values, and per
  view along each axis (with ``view``) or on/off path (without).

>>> import pandas as pd
>>> objs = pd.DataFrame({"y_offset_m": [0.0, 1.0, -1.0, 1.0], "label_class": ["car", "car", "ped", "ped"]})
>>> on_path(objs).tolist()
[True, False, False, False]
>>> [(b.by, b.cells) for b in cell_breakdowns(objs, by=["label_class"], with_view=False)]
[('label_class', [('car', 'off-path', nan), ('car', 'on-path', nan), ('ped', 'off-path', nan)])]
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from analysis.common.choices import PATHS
from data_schema.errors import InputError
from data_schema.perturbation import (
    AXES,
    PERTURBATION_COLUMNS,
    axes,
    axis_values,
    perturbation_array,
)

__all__ = ["PATHS", "VIEW", "Breakdown", "on_path", "view_breakdowns", "view_cells", "parse_by",
           "cell_breakdowns"]

#: The name of the views in a crossed breakdown (``--by class,view``; ``offset`` is accepted).
VIEW = "view"
_ALIASES = {"class": "label_class", "offset": VIEW, "offsets": VIEW, "views": VIEW}


@dataclass(frozen=True)
class Breakdown:
    """One breakdown of objects into cells: ``codes`` (N,) the cell of each object (-1: in
    none), ``cells`` one ``(group, axis, offset)`` per code; ``by`` names the crossed columns
    (``''`` for the default breakdowns by view).

    Attributes
    ----------
    by : str
        The crossed columns (``''``: by view).
    codes : (N,) int64
        Cell of each object, -1 in none.
    cells : list of (object, str, float)
        ``(group, axis, offset)`` per code.
    """

    by: str
    codes: np.ndarray
    cells: list


def on_path(items: pd.DataFrame) -> np.ndarray:
    """(N,) bool: the row's view is the recorded camera's (every component 0 at 0.01).

    Parameters
    ----------
    items : pandas.DataFrame
        N rows of methods' objects, with perturbation columns.

    Returns
    -------
    (N,) bool
        True on the recorded path.
    """
    return axes(perturbation_array(items)) == "none"


def view_breakdowns(items: pd.DataFrame) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """``(axis, values (N,), member (N,) bool)`` per view breakdown: ``'all'`` (values NaN),
    then each axis present (its column name), with the real camera's view at value 0.

    Parameters
    ----------
    items : pandas.DataFrame
        Rows with perturbation columns.

    Returns
    -------
    list of (str, (N,) float64, (N,) bool)
        ``(axis, values, member)``.
    """
    P = perturbation_array(items)
    names, values = axes(P), axis_values(P)
    n = len(items)
    out = [("all", np.full(n, np.nan), np.ones(n, bool))]
    for axis, column in zip(AXES, PERTURBATION_COLUMNS, strict=True):
        on = names == axis
        if on.any() or (axis == "y" and (names == "none").any()):
            out.append((column, np.where(on, values, 0.0), on | (names == "none")))
    return out


def view_cells(items: pd.DataFrame):
    """Each view cell of ``items``: every row (``axis = 'all'``), then each value along each
    axis of :func:`view_breakdowns` (the recorded camera's view counting as value 0).

    Parameters
    ----------
    items : pandas.DataFrame
        N rows (objects or votes) with perturbation columns.

    Yields
    ------
    axis : str
        ``'all'`` or a perturbation column name.
    value : float
        The offset along ``axis`` (metres or degrees); NaN for ``'all'``.
    member : (N,) bool
        The rows in the cell.

    >>> objs = pd.DataFrame({"y_offset_m": [0.0, 1.0, 1.0]})
    >>> [(a, float(v), m.tolist()) for a, v, m in view_cells(objs)][1:]
    [('y_offset_m', 0.0, [True, False, False]), ('y_offset_m', 1.0, [False, True, True])]
    """
    for axis, values, member in view_breakdowns(items):
        for value in ([np.nan] if axis == "all" else np.unique(values[member])):
            yield axis, value, member & ((values == value) if axis != "all" else True)


def parse_by(by, columns, *, attributes) -> tuple[list[str], bool]:
    """``(columns, with_view)`` of a crossed breakdown ``by`` (names; ``class`` is
    ``label_class``, ``offset`` or ``view`` the views).

    Parameters
    ----------
    by : sequence of str
        Breakdown names.
    columns : iterable of str
        The table's columns.
    attributes : iterable of str
        The scene attribute columns.

    Returns
    -------
    columns : list of str
        The crossed columns.
    with_view : bool
        Whether the views are crossed too.

    Raises
    ------
    InputError
        A name is neither ``class``, ``offset``/``view`` nor one of ``attributes`` present
        in ``columns`` (naming the parameter ``by``), or a name repeats.
    """
    names = [_ALIASES.get(b, b) for b in by or []]
    allowed = ["label_class", *[a for a in attributes if a != "label_class"]]
    for b, name in zip(by or [], names, strict=True):
        if name != VIEW and (name not in allowed or name not in columns):
            raise InputError(param="by", field=b, expected="class, offset or a clip attribute ("
                             + ", ".join(a for a in allowed if a in columns) + ")", got="no such column")
    if len(set(names)) < len(names):
        raise InputError(param="by", field=",".join(by), expected="each name once", got="a repeat")
    return [n for n in names if n != VIEW], VIEW in names


def _cells(by: str, parts, view_codes, view_cells, member) -> Breakdown:
    """The cells of the crossing of ``parts`` ((codes (N,), labels) per column) with a view code."""
    codes_all = [c for c, _ in parts] + [view_codes]
    member = member & np.all([c >= 0 for c in codes_all], axis=0)
    keys = np.stack(codes_all, axis=1)[member]
    uniq, inv = np.unique(keys, axis=0, return_inverse=True)
    codes = np.full(len(member), -1, np.int64)
    codes[member] = inv.reshape(-1)
    cells = [(",".join(str(labels[u[i]]) for i, (_, labels) in enumerate(parts)), *view_cells[u[-1]])
             for u in uniq]
    return Breakdown(by, codes, cells)


def cell_breakdowns(objects: pd.DataFrame, *, by=(), with_view: bool = False) -> list[Breakdown]:
    """The breakdowns of ``objects`` (one row each) into cells.

    Without ``by`` and ``with_view``: the default ones, on/off path then each view axis
    present (the recorded view is value 0 of every axis). With them: the crossing of the
    ``by`` columns with each view axis (``with_view``) or with on/off path.

    Parameters
    ----------
    objects : pandas.DataFrame
        One row per object.
    by : sequence of str, optional
        Columns to cross.
    with_view : bool, optional
        Cross them with each view axis (else with on/off path).

    Returns
    -------
    list of Breakdown
    """
    n = len(objects)
    parts = [pd.factorize(objects[c], sort=True) for c in by]
    label = ",".join([*by, *([VIEW] if with_view else [])])
    everyone = np.ones(n, bool)
    out = []
    if not with_view:
        out.append(_cells(label, parts, on_path(objects).astype(np.int64),
                          [(p, np.nan) for p in PATHS], everyone))
    if with_view or not by:
        for axis, values, member in view_breakdowns(objects)[1:]:
            uniq, inv = np.unique(values[member], return_inverse=True)
            vcodes = np.full(n, -1, np.int64)
            vcodes[member] = inv
            out.append(_cells(label, parts, vcodes, [(axis, float(v)) for v in uniq], member))
    return out
