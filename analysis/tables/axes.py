"""Results along each perturbation axis (6-DoF novel views, issue "beyond lateral").

Layer: analysis (statistics of votes and metrics).

A rated item's view is a perturbation ``(dx, dy, dz, roll, pitch, yaw)``
(:mod:`data_schema.perturbation`). Items of the real camera's view (axis ``'none'``, value
0) belong to every axis, as the centre of its tent; items with several non-zero components
(``'combined'``) belong to none and are only counted.

- :func:`axis_table`: long table ``axis, value, column, n, mean, std`` (the per-offset
  table of :func:`analysis.tables.breakdowns.offset_table`, once per axis);
- :func:`axis_tent_plots`: one tent plot per axis (:func:`analysis.common.plots.tent_plot`);
- :func:`lateral_items`: the items the paper's lateral tent plot shows (axis y or none);
- :func:`view_tables`: both tables at once, ``(by_offset, by_axis)``, the one place the ratings
  path and ``analyze --pairs`` get them from.

>>> items = pd.DataFrame({"y_offset_m": [0.0, 1.0, 0.0, 0.0], "yaw_deg": [0.0, 0.0, 5.0, 5.0],
...                       "gvf": [1.0, 0.5, 0.25, 0.75]})
>>> t = axis_table(items, ["gvf"])
>>> t[["axis", "value", "n", "mean"]].values.tolist()
[['y', 0.0, 1, 1.0], ['y', 1.0, 1, 0.5], ['yaw', 0.0, 1, 1.0], ['yaw', 5.0, 2, 0.5]]
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from analysis.common import plots
from analysis.tables.breakdowns import offset_table
from data_schema.perturbation import AXES, AXIS_UNITS, axes, axis_values, perturbation_array

__all__ = ["AXIS_TABLE_COLUMNS", "axis_table", "axis_tent_plots", "lateral_items", "item_axes",
           "is_multi_axis", "view_tables"]

AXIS_TABLE_COLUMNS = ["axis", "value", "column", "n", "mean", "std"]


def item_axes(items: pd.DataFrame) -> tuple[np.ndarray, np.ndarray]:
    """``(axis names (N,), signed values (N,))`` of the items' views (absent columns: 0).

    Parameters
    ----------
    items : pandas.DataFrame
        N items; missing perturbation columns read as 0.

    Returns
    -------
    axes : (N,) object array of str
        The axis each view moves along (``'none'`` for the recorded view).
    values : (N,) float64
        The signed offset along it, metres or degrees.
    """
    P = perturbation_array(items)
    return axes(P), axis_values(P)


def is_multi_axis(items: pd.DataFrame) -> bool:
    """True when some item's view is not lateral (then the report shows one tent per axis).

    Parameters
    ----------
    items : pandas.DataFrame
        Items with perturbation columns.

    Returns
    -------
    bool
        False when every view is lateral or the recorded one.
    """
    names, _ = item_axes(items)
    return bool(np.isin(names, ["y", "none"], invert=True).any())


def lateral_items(items: pd.DataFrame) -> pd.DataFrame:
    """The items on the lateral axis (and the real camera's view); all of a lateral study.

    Parameters
    ----------
    items : pandas.DataFrame
        Items of any study, with their perturbation columns.

    Returns
    -------
    pandas.DataFrame
        The rows of ``items`` on axis ``y`` or ``none``, index kept.
    """
    names, _ = item_axes(items)
    return items[np.isin(names, ["y", "none"])]


def axis_table(items: pd.DataFrame, columns: list[str]) -> pd.DataFrame:
    """Long table :data:`AXIS_TABLE_COLUMNS`: per axis with items (in the order x, y, z,
    roll, pitch, yaw) and value along it, ``n``, mean and sample std of each column; the
    axis-'none' items are value 0 of every axis.

    Parameters
    ----------
    items : pandas.DataFrame
        Items with perturbation columns.
    columns : list of str
        The value columns summarised.

    Returns
    -------
    pandas.DataFrame
        Columns :data:`AXIS_TABLE_COLUMNS`.
    """
    names, values = item_axes(items)
    frames = []
    for axis in AXES:
        if not (names == axis).any():
            continue
        sel = (names == axis) | (names == "none")
        t = offset_table(items[sel].assign(_value=values[sel]), columns, offset_col="_value")
        frames.append(t.rename(columns={"y_offset_m": "value"}).assign(axis=axis))
    if not frames:
        return pd.DataFrame(columns=AXIS_TABLE_COLUMNS)
    return pd.concat(frames, ignore_index=True).loc[:, AXIS_TABLE_COLUMNS]


def view_tables(items: pd.DataFrame, columns: list[str], *, by: str | None = None):
    """``(by_offset, by_axis)`` of ``items`` for ``columns`` (target first, then metrics).

    ``by_offset``: :func:`~analysis.tables.breakdowns.offset_table` of the :func:`lateral_items`
    (with ``gvf`` added when the items have it), followed, with ``by`` (e.g. ``label_class``),
    by its per-condition rows (offset x value of ``by``); ``by_axis``: :func:`axis_table`, or
    ``None`` when every view is lateral (:func:`is_multi_axis`).

    Parameters
    ----------
    items : pandas.DataFrame
        Items with perturbation columns.
    columns : list of str
        Target first, then metrics.
    by : str, optional
        A condition column (e.g. ``label_class``).

    Returns
    -------
    by_offset : pandas.DataFrame
    by_axis : pandas.DataFrame or None
    """
    lateral = lateral_items(items)
    cols = columns + ["gvf"] if "gvf" in items.columns and "gvf" not in columns else columns
    by_offset = offset_table(lateral, cols)
    if by is not None:
        by_offset = pd.concat([by_offset, offset_table(lateral, cols, by=by)], ignore_index=True)
    return by_offset, axis_table(items, columns) if is_multi_axis(items) else None


def axis_tent_plots(by_axis: pd.DataFrame, columns: list[str], directions: dict[str, bool], *,
                    target_label: str = "GVF") -> list[tuple[str, str, object]]:
    """``(name, title, figure)`` per axis of ``by_axis`` (:func:`axis_table`): name
    ``tent_<axis>``, x = the value along the axis in its unit.

    Parameters
    ----------
    by_axis : pandas.DataFrame
        :func:`axis_table` of the items, every axis in it gets a figure.
    columns : list of str
        The panels of each figure, as in :func:`analysis.common.plots.tent_plot`.
    directions : dict
        Whether higher is better, per entry of ``columns``.
    target_label : str, optional
        How the target (``columns[0]``) is named in panels and titles.

    Returns
    -------
    list of (str, str, matplotlib.figure.Figure)
        ``(name, title, figure)``.
    """
    out = []
    for axis in dict.fromkeys(by_axis["axis"]):
        t = by_axis[by_axis["axis"] == axis].rename(columns={"value": "y_offset_m"})
        fig = plots.tent_plot(t, columns, directions, target_label=target_label)
        for ax in fig.axes:
            ax.set_xlabel(f"{axis} ({AXIS_UNITS[axis]})", fontsize=8)
        out.append((f"tent_{axis}", f"Tent plot along {axis} ({AXIS_UNITS[axis]}; {target_label} first, "
                    "mean +/- 1 std)", fig))
    return out
