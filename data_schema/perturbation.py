"""Novel-view perturbations (docs/FORMATS.md §1, generalised): six components, labels, axes.

Layer: data_schema (file formats).

A render is taken from a virtual camera moved away from the real one by a *perturbation*
``(dx, dy, dz, roll, pitch, yaw)`` in the rig frame (x forward, y left, z up): metres for
the translation, degrees for the rotation. ``nvrq.geometry.poses.perturb_T_sensor_rig``
turns it into ``T_sensor'_rig``; this module holds the facts every table shares:

- the six table columns :data:`PERTURBATION_COLUMNS` (``y_offset_m`` is the paper's lateral
  offset and keeps its contract name; the other five are optional and default to 0, so tables
  written before they existed load unchanged);
- the readable label (column :data:`LABEL_COLUMN`): the non-zero components at 0.01
  precision, e.g. ``'y=+2.00'``, ``'z=+0.50,yaw=-5.00'``, ``'none'`` for the real camera;
- the *axis* of a perturbation: the name of its only non-zero component, ``'none'`` when
  all are zero and ``'combined'`` when several are;
- the grid syntax of ``--perturb``: ``y=-3:3:1,z=0:2:0.5,yaw=-10:10:5`` (start:stop:step,
  stop included; or a single value ``z=1``), one single-axis perturbation per grid value.

>>> P = parse_perturb("y=-1:1:1,yaw=5")
>>> labels(P)
['y=-1.00', 'none', 'y=+1.00', 'yaw=+5.00']
>>> axes(P).tolist(), axis_values(P).tolist()
(['y', 'none', 'y', 'yaw'], [-1.0, 0.0, 1.0, 5.0])
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from data_schema.errors import InputError
from data_schema.text import comma_list

__all__ = [
    "perturb_option",
    "AXES",
    "AXIS_UNITS",
    "PERTURBATION_COLUMNS",
    "EXTRA_PERTURBATION_COLUMNS",
    "LABEL_COLUMN",
    "LIMITS",
    "perturbation_array",
    "with_perturbation_columns",
    "labels",
    "axes",
    "axis_values",
    "is_lateral",
    "view_suffix",
    "parse_perturb",
    "lateral",
    "view_columns",
    "VIEW_COLUMNS",
    "extra_columns",
    "views_from",
]

#: The six components, in the order of a perturbation vector ``(6,)``.
AXES = ("x", "y", "z", "roll", "pitch", "yaw")
AXIS_UNITS = {"x": "m", "y": "m", "z": "m", "roll": "deg", "pitch": "deg", "yaw": "deg"}
#: Table columns of the six components (same order as :data:`AXES`).
PERTURBATION_COLUMNS = ("x_offset_m", "y_offset_m", "z_offset_m", "roll_deg", "pitch_deg", "yaw_deg")
#: The optional columns (all but the contract's ``y_offset_m``), 0 when absent.
EXTRA_PERTURBATION_COLUMNS = tuple(c for c in PERTURBATION_COLUMNS if c != "y_offset_m")
#: Readable label column of pairs tables, ratings and plans.
LABEL_COLUMN = "perturbation"
#: The largest magnitude of a component, per unit (metres, degrees).
LIMITS = {"m": 20.0, "deg": 90.0}
#: The columns a table gains when some view is not lateral (after the contract columns).
VIEW_COLUMNS = (*EXTRA_PERTURBATION_COLUMNS, LABEL_COLUMN)


def extra_columns(P: np.ndarray, columns=EXTRA_PERTURBATION_COLUMNS) -> list[str]:
    """``list(columns)`` when some view of ``P: (N, 6)`` is not lateral, else ``[]``: the
    optional columns a table gains (lateral-only tables keep exactly their contract columns).

    Parameters
    ----------
    P : (N, 6) float64
        Perturbations ``(dx, dy, dz, roll, pitch, yaw)``: metres, degrees, rig frame.
    columns : sequence of str, optional
        The optional columns to add.

    Returns
    -------
    list of str

    >>> extra_columns(lateral([-1.0, 1.0])), extra_columns(np.eye(6)[[2]], ("z_offset_m",))
    ([], ['z_offset_m'])
    """
    return [] if is_lateral(P).all() else list(columns)


def views_from(offsets, perturbations) -> np.ndarray:
    """The views ``(K, 6)``: ``perturbations`` when given (they replace the offsets), else the
    lateral ``offsets`` (metres).

    Parameters
    ----------
    offsets : (K,) float, metres, or None
        Lateral offsets.
    perturbations : (K, 6) float64 or None
        Full perturbations (metres, degrees, rig frame); take precedence.

    Returns
    -------
    (K, 6) float64
        The views, metres and degrees.
    """
    if perturbations is None:
        return lateral([float(o) for o in offsets])
    return np.asarray(perturbations, float).reshape(-1, 6)


def perturbation_array(table: pd.DataFrame) -> np.ndarray:
    """The ``(N, 6)`` perturbations of a table's rows; absent optional columns count as 0.

    Parameters
    ----------
    table : pandas.DataFrame
        A table with ``y_offset_m`` and optionally the other :data:`PERTURBATION_COLUMNS`.

    Returns
    -------
    (N, 6) float64
        ``(dx, dy, dz, roll, pitch, yaw)`` per row: metres, degrees, rig frame.
    """
    n = len(table)
    return np.stack([table[c].to_numpy(np.float64) if c in table.columns else np.zeros(n)
                     for c in PERTURBATION_COLUMNS], axis=-1).reshape(n, 6)


def with_perturbation_columns(table: pd.DataFrame, *, label: bool = True) -> pd.DataFrame:
    """A copy of ``table`` with every absent optional component column set to 0 (and the
    label column added when ``label`` and absent). Old tables thus read as lateral-only.

    Parameters
    ----------
    table : pandas.DataFrame
        A pairs, metrics or study table.
    label : bool, optional
        Also add the label column when absent.

    Returns
    -------
    pandas.DataFrame
        A copy with every component column.
    """
    out = table.copy()
    for c in EXTRA_PERTURBATION_COLUMNS:
        if c not in out.columns:
            out[c] = 0.0
    if label and LABEL_COLUMN not in out.columns:
        out[LABEL_COLUMN] = labels(perturbation_array(out))
    return out


def _hundredths(P: np.ndarray) -> np.ndarray:
    return np.round(np.asarray(P, np.float64).reshape(-1, 6) * 100).astype(np.int64)


def _nonzero_components(P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """How many components of each row are non-zero at 0.01 ``(N,)``, and the first one ``(N,)``."""
    nz = _hundredths(P) != 0
    return nz.sum(axis=1), np.argmax(nz, axis=1)


def labels(P: np.ndarray) -> list[str]:
    """``P: (N, 6)`` -> readable labels (module docstring); equal labels mean the same view
    at the 0.01 precision of ``pair_id``.

    Parameters
    ----------
    P : (N, 6) float64
        Perturbations ``(dx, dy, dz, roll, pitch, yaw)``, metres and degrees in the rig frame;
        labelled at 0.01 precision.

    Returns
    -------
    list of str
        One label per view.
    """
    H = _hundredths(P)
    # each distinct view is formatted once (np.unique(H, axis=0) sorts rows as bytes: slower)
    view = pd.DataFrame(H).groupby(list(range(6)), sort=False).ngroup().to_numpy()  # 0..K-1
    names = []
    for row in H[np.unique(view, return_index=True)[1]]:
        parts = [f"{a}={v / 100:+.2f}" for a, v in zip(AXES, row, strict=True) if v != 0]
        names.append(",".join(parts) if parts else "none")
    return [names[k] for k in view.tolist()]


def axes(P: np.ndarray) -> np.ndarray:
    """``P: (N, 6)`` -> axis names ``(N,)``: the only non-zero component, 'none' or 'combined'.

    Parameters
    ----------
    P : (N, 6) float64
        One perturbation per row (metres, degrees); a component is non-zero when it is at
        0.01 precision.

    Returns
    -------
    (N,) object array of str
        ``'x'``, ``'y'``, ..., ``'none'`` or ``'combined'``.
    """
    count, first = _nonzero_components(P)
    names = np.array(AXES, dtype=object)[first] if len(first) else np.array([], object)
    return np.where(count == 0, "none", np.where(count > 1, "combined", names)).astype(object)


def axis_values(P: np.ndarray) -> np.ndarray:
    """``P: (N, 6)`` -> the signed value along the axis ``(N,)`` (0 for 'none', NaN for 'combined').

    Parameters
    ----------
    P : (N, 6) float64
        Perturbations in metres and degrees; the value returned is the component as given,
        unrounded.

    Returns
    -------
    (N,) float64
        Metres for a translation axis, degrees for a rotation.
    """
    P = np.asarray(P, np.float64).reshape(-1, 6)
    count, first = _nonzero_components(P)
    val = P[np.arange(len(P)), first] if len(P) else np.zeros(0)
    return np.where(count == 0, 0.0, np.where(count > 1, np.nan, val))


def is_lateral(P: np.ndarray) -> np.ndarray:
    """``(N,)`` True where only ``y`` may be non-zero (the paper's lateral offsets, and 0).

    Parameters
    ----------
    P : (N, 6) float64
        Perturbations; a row is lateral when ``dx, dz, roll, pitch, yaw`` are all 0 at 0.01.

    Returns
    -------
    (N,) bool
    """
    nz = _hundredths(P) != 0
    return ~nz[:, [0, 2, 3, 4, 5]].any(axis=1)


def view_suffix(P: np.ndarray) -> list[str]:
    """The view part of ``pair_id``: ``'+2.00'`` for a lateral view (unchanged contract format),
    else the label, e.g. ``'z=+0.50'``.

    Parameters
    ----------
    P : (N, 6) float64
        Perturbations of the render views; a lateral row's suffix is its ``dy`` in metres.

    Returns
    -------
    list of str
        One suffix per view.

    >>> view_suffix(np.array([[0, -0.5, 0, 0, 0, 0], [0, 0, 1, 0, 0, 0.0]]))
    ['-0.50', 'z=+1.00']
    """
    P = np.asarray(P, np.float64).reshape(-1, 6)
    lat = is_lateral(P)
    return [f"{p[1]:+.2f}" if ok else lab for p, ok, lab in zip(P, lat, labels(P), strict=True)]


def lateral(offsets_m) -> np.ndarray:
    """Lateral offsets ``(K,)`` metres -> perturbations ``(K, 6)``.

    Parameters
    ----------
    offsets_m : (K,) float, metres
        Lateral offsets along the rig's y axis (left positive).

    Returns
    -------
    (K, 6) float64
        Perturbations with only ``dy`` set.
    """
    y = np.atleast_1d(np.asarray(offsets_m, np.float64))
    P = np.zeros((len(y), 6))
    P[:, 1] = y
    return P


def _grid(axis: str, spec: str, text: str, option: str) -> list[float]:
    unit = AXIS_UNITS[axis]
    try:
        nums = [float(s) for s in spec.split(":")]
    except ValueError:
        nums = []
    if len(nums) not in (1, 3) or not all(math.isfinite(v) for v in nums):
        raise InputError(param=option, expected=f"{axis}=START:STOP:STEP or {axis}=VALUE in {unit}", got=text)
    if len(nums) == 1:
        values = nums
    else:
        start, stop, step = nums
        if step <= 0 or stop < start or (stop - start) / step > 1000:
            raise InputError(param=option, expected=f"{axis}=START:STOP:STEP with STEP > 0 and STOP >= START "
                             "(at most 1000 values)", got=text)
        n = int(math.floor((stop - start) / step + 1e-9)) + 1
        values = [round(start + i * step, 10) for i in range(n)]
    if any(abs(v) > LIMITS[unit] for v in values):
        raise InputError(param=option, expected=f"{axis} values within +-{LIMITS[unit]:g} {unit}", got=text)
    return values


def parse_perturb(text: str, *, option: str = "perturb") -> np.ndarray:
    """``'y=-3:3:1,z=0:2:0.5,yaw=-10:10:5'`` -> single-axis perturbations ``(K, 6)``, one per
    grid value, duplicates (e.g. several zeros) kept once, in order of appearance.

    ``option`` names the parameter in errors (the CLI passes ``'--perturb'``).

    Parameters
    ----------
    text : str
        Comma list of ``AXIS=START:STOP:STEP`` (stop included) or ``AXIS=VALUE`` items,
        ``AXIS`` in :data:`AXES`; metres for translations, degrees for rotations.
    option : str, optional
        The parameter named in errors.

    Returns
    -------
    (K, 6) float64
        One single-axis perturbation per grid value.

    Raises
    ------
    InputError
        A malformed item, unknown component or empty grid.
    """
    items = comma_list(text)
    if not items:
        raise InputError(param=option, expected="a comma list of AXIS=START:STOP:STEP items, e.g. "
                         "y=-3:3:1,yaw=-10:10:5", got=text)
    rows, seen = [], set()
    for item in items:
        axis, eq, spec = item.partition("=")
        axis = axis.strip().lower()
        if not eq or axis not in AXES:
            raise InputError(param=option, expected=f"items AXIS=START:STOP:STEP with AXIS in {{{', '.join(AXES)}}}",
                             got=item)
        for v in _grid(axis, spec.strip(), item, option):
            p = np.zeros(6)
            p[AXES.index(axis)] = v
            key = labels(p)[0]
            if key not in seen:
                seen.add(key)
                rows.append(p)
    return np.stack(rows)


def view_columns(table: pd.DataFrame) -> list[str]:
    """:data:`VIEW_COLUMNS` when some row of ``table`` is not lateral, else ``[]`` (so
    lateral-only studies and ratings keep exactly their former columns).

    Parameters
    ----------
    table : pandas.DataFrame
        A table with perturbation columns.

    Returns
    -------
    list of str
    """
    return extra_columns(perturbation_array(table), VIEW_COLUMNS)


def perturb_option(perturb: str | None, *, offsets=None, offsets_given: bool = False):
    """The ``(K, 6)`` views of a ``--perturb`` value (:func:`parse_perturb`), None without one;
    refused when ``--offsets`` was given too (``offsets_given``): the grid replaces the offsets,
    so one of them would be ignored.

    Parameters
    ----------
    perturb : str or None
        The ``--perturb`` text.
    offsets : str, optional
        The ``--offsets`` text, for the error.
    offsets_given : bool, optional
        Whether the user gave ``--offsets``.

    Returns
    -------
    (K, 6) float64 or None
    """
    if perturb is not None and offsets_given:
        raise InputError(param="offsets", expected="offsets or a perturbation grid, not both (the grid "
                         "replaces the offsets)", got=f"offsets {offsets} with the grid {perturb}")
    return None if perturb is None else parse_perturb(perturb)
