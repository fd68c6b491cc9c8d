"""Reconstruction methods in one scene (docs/FORMATS.md §2-3): the optional ``method`` column.

Layer: data_schema (file formats).

A scene may hold the renders of several reconstruction methods (e.g. 3DGS and 3DGUT of the
same clip): ``images.csv`` then has a ``method`` column naming, on every render row, the
method that produced it; GT rows leave it empty (the real image is shared by all methods).
A scene without the column (or with it empty everywhere) is one unnamed method, and every
table made from it keeps exactly its former columns and pair ids.

The facts every table shares live here:

- :data:`METHOD_COLUMN`, the column name in ``images.csv``, pairs tables, study items and
  ratings (present only when the scene has methods);
- :func:`check_method_name`, the one rule for a method name: letters, digits, ``_``, ``-``
  and ``.``, starting with a letter or digit, at most 64 characters, containing a letter, not
  a word a CSV reader takes for a missing value (``NA``, ``null``, ``none``) and not ``gt``
  (the GT crop's name in pairwise studies). So a name never breaks a pair id (``:``), a comma
  list, a path or a CSV round trip;
- :func:`method_values` and :func:`table_methods`, the one rule for which methods a table
  holds: a row's method is its ``method`` value, ``''`` where the column is absent or empty;
  the table holds the distinct non-empty ones (what ``annotate build --design pairwise`` and
  ``analyze --compare-methods`` choose from);
- :func:`method_suffix`, the part a method adds to a pair id (``':3dgs'``; nothing for none);
- :func:`parse_methods` and :func:`check_method_scales`, the ``NAME:SCALE,...`` list of
  ``nvrq synth --methods``.

>>> method_suffix(["3dgs", ""])
[':3dgs', '']
>>> table_methods(pd.DataFrame({"method": ["nerf", "", "3dgs", "nerf"]}))
['3dgs', 'nerf']
>>> parse_methods("3dgs:0.5,nerf:1.5")
[('3dgs', 0.5), ('nerf', 1.5)]
"""

from __future__ import annotations

import math
import re

import numpy as np
import pandas as pd

from data_schema.errors import InputError
from data_schema.text import comma_list

__all__ = ["METHOD_COLUMN", "GT_METHOD", "REAL_METHOD", "FLOOR_METHOD", "PERFECT_METHOD",
           "REFERENCE_METHODS", "FLOOR_PAIR_COLUMNS", "check_method_name", "method_values", "table_methods", "method_columns",
           "method_suffix", "parse_methods", "check_method_scales", "check_table_methods"]

#: The optional column naming the reconstruction method of a render (empty: none).
METHOD_COLUMN = "method"

#: The reserved name of the GT crop where a method is expected (``method_a`` of a pairwise
#: study's gold items, docs/FORMATS.md §12): never a method's name.
GT_METHOD = "gt"

#: The reserved name of a real photograph used as a render (the right image of a rectified
#: stereo pair, ``nvrq import stereo``, docs/FORMATS.md §16): a valid method of a scene, never
#: a synthetic method of ``nvrq synth --methods``.
REAL_METHOD = "real"

#: The reserved name of the viewpoint floor of a real log (``nvrq pairs --floor``, docs/FORMATS.md
#: §3): pairs of two GT views of one object, never a synthetic method.
FLOOR_METHOD = "floor"

#: The columns ``nvrq pairs --floor`` adds to a pairs table (docs/FORMATS.md §3): the novel view's
#: change of viewpoint and the floor partner's; never metrics.
FLOOR_PAIR_COLUMNS = ("view_angle_deg", "view_ratio", "floor_angle_deg", "floor_ratio")

#: The reserved name of a synthetic render with no artefact (``nvrq synth --methods perfect:0``,
#: scale 0 only): the viewpoint floor of a synthetic scene.
PERFECT_METHOD = "perfect"

#: The methods that measure the viewpoint rather than a reconstruction: drawn as the floor by the
#: reports, never shown to raters (``annotate build`` leaves their pairs out).
REFERENCE_METHODS = (PERFECT_METHOD, FLOOR_METHOD)

_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,63}")
#: read as missing values by CSV readers, and the GT crop's name
_RESERVED = {"na", "null", "none", GT_METHOD}
_EXPECTED = ("a method name of letters, digits, '_', '-' and '.' (starting with a letter or digit, "
             "at most 64 characters, with a letter, not NA/null/none/gt), e.g. 3dgs")


def check_method_name(name, *, where: object = None, field: str | None = None,
                      param: str | None = None) -> str:
    """``name`` if it is a valid method name (module docstring), else :class:`InputError`.

    Parameters
    ----------
    name : object
        The name to check.
    where, field : optional
        The file and the row/column the name is in (a table's value).
    param : str, optional
        The parameter or option the name came from (a list of methods given by the user).

    Returns
    -------
    str
        ``name``.

    Raises
    ------
    InputError
        ``name`` breaks the rule, naming ``where``, ``param`` and ``field``.

    >>> check_method_name("3dgut-v2", where="images.csv", field="row 3, column method")
    '3dgut-v2'
    >>> check_method_name("a:b", param="methods")
    Traceback (most recent call last):
    ...
    data_schema.errors.InputError: methods: expected a method name of letters, digits, '_', '-' and '.' (starting with a letter or digit, at most 64 characters, with a letter, not NA/null/none/gt), e.g. 3dgs, got 'a:b'
    """
    if not _is_method_name(name):
        raise InputError(where, field, _EXPECTED, repr(name), param=param)
    return name


def _is_method_name(name) -> bool:
    """Whether ``name`` follows the rule of :func:`check_method_name`."""
    if not (isinstance(name, str) and _NAME.fullmatch(name) and re.search("[A-Za-z]", name)
            and name.lower() not in _RESERVED):
        return False
    try:
        float(name)  # 'inf', 'nan', '1e3' read back as numbers
    except ValueError:
        return True
    return False


def method_values(table: pd.DataFrame) -> np.ndarray:
    """Each row's method ``(N,)`` object array of str; ``''`` where none (no column, empty or NaN).

    Parameters
    ----------
    table : pandas.DataFrame
        Any table, with or without a ``method`` column.

    Returns
    -------
    numpy.ndarray
        ``(N,)`` object array of str, one per row.
    """
    if METHOD_COLUMN not in table.columns:
        return np.full(len(table), "", dtype=object)
    col = table[METHOD_COLUMN]
    return col.where(col.notna(), "").astype(str).to_numpy(dtype=object)


def table_methods(table: pd.DataFrame, *, where: object = None, expected: str | None = None) -> list[str]:
    """The methods ``table`` holds: the distinct non-empty values of :func:`method_values`, sorted.

    Parameters
    ----------
    table : pandas.DataFrame
        Any table of the toolkit (``images.csv``, pairs, study items, per-object items).
    where : object, optional
        The table's file, named in the error.
    expected : str, optional
        What a caller needs the column for. When given, a table without a ``method`` column is
        an error; without it such a table holds no method (``[]``).

    Returns
    -------
    list of str
        The method names in sorted order; ``[]`` for a single-method table.

    Raises
    ------
    InputError
        ``table`` has no ``method`` column and ``expected`` is given: ``where``, ``column
        'method'``, ``expected``, got ``no such column``.

    >>> table_methods(pd.DataFrame({"x": [1]}))
    []
    >>> table_methods(pd.DataFrame({"x": [1]}), where="pairs.csv", expected="a method column")
    Traceback (most recent call last):
    ...
    data_schema.errors.InputError: pairs.csv: column 'method': expected a method column, got no such column
    """
    if METHOD_COLUMN not in table.columns and expected is not None:
        raise InputError(where, f"column {METHOD_COLUMN!r}", expected, "no such column")
    return sorted(v for v in pd.unique(method_values(table)) if v)


def method_columns(table: pd.DataFrame) -> list[str]:
    """``[METHOD_COLUMN]`` when ``table`` holds a method (:func:`table_methods`), else ``[]`` (so
    tables of single-method scenes keep exactly their former columns).

    Parameters
    ----------
    table : pandas.DataFrame
        Any table.

    Returns
    -------
    list of str

    >>> method_columns(pd.DataFrame({"method": ["", "a"]})), method_columns(pd.DataFrame({"x": [1]}))
    (['method'], [])
    """
    return [METHOD_COLUMN] if table_methods(table) else []


def method_suffix(methods) -> list[str]:
    """The pair-id part of each method: ``':NAME'``, or ``''`` for none (ids unchanged).

    Parameters
    ----------
    methods : iterable of str
        One method per row (``''`` for none).

    Returns
    -------
    list of str
        One suffix per method.
    """
    return [f":{m}" if m else "" for m in methods]


def check_table_methods(table: pd.DataFrame, *, where: object, line_offset: int = 2,
                        what: str = "row") -> None:
    """Every non-empty ``method`` value of ``table`` is a valid name; errors name the row
    (``what`` + position + ``line_offset``, e.g. ``row 5`` of a CSV with a header).

    Parameters
    ----------
    table : pandas.DataFrame
        The table read from ``where``.
    where : object
        The file, named in errors.
    line_offset : int, optional
        Added to the 0-based row position to name the line (2: CSV with a header).
    what : str, optional
        What a row is called in errors.

    Raises
    ------
    InputError
        A method value is not a valid name.
    """
    values = method_values(table)
    bad = [v for v in pd.unique(values) if v and not _is_method_name(v)]
    if bad:
        i = int(np.flatnonzero(pd.Series(values).isin(bad).to_numpy())[0])
        check_method_name(values[i], where=where, field=f"{what} {i + line_offset}, column {METHOD_COLUMN}")


def parse_methods(text: str, *, option: str = "methods") -> list[tuple[str, float]]:
    """``'NAME:SCALE,...'`` -> ``[(name, scale), ...]`` in the given order, checked by
    :func:`check_method_scales`.

    Parameters
    ----------
    text : str
        The ``--methods`` value of ``nvrq synth`` / ``nvrq demo``.
    option : str
        The parameter or option named in errors.

    Returns
    -------
    list of (str, float)

    Raises
    ------
    InputError
        An empty list, an item without ``:``, or a list :func:`check_method_scales` refuses.
    """
    items = comma_list(text)
    if not items:
        raise InputError(param=option, expected="a comma list of NAME:SCALE items, e.g. 3dgs:0.5,nerf:1.5", got=text)
    out = []
    for item in items:
        name, sep, scale = item.rpartition(":")
        if not sep:
            raise InputError(param=option, expected="NAME:SCALE items, e.g. 3dgs:0.5", got=item)
        try:
            value = float(scale)
        except ValueError:
            value = scale
        out.append((name, value))
    return check_method_scales(out, option=option)


def check_method_scales(methods, *, option: str = "methods") -> list[tuple[str, float]]:
    """The methods of a synthetic scene, checked: names by :func:`check_method_name`, each once;
    a scale is a finite number >= 0 (``nvrq synth`` multiplies the artefact severity by it:
    0 = a perfect render, 1 = the usual one). At least one. ``real`` and ``floor`` are reserved,
    and ``perfect`` takes scale 0 only (:data:`REFERENCE_METHODS`).

    Parameters
    ----------
    methods : iterable of (str, float)
        ``(name, scale)`` pairs.
    option : str
        The parameter or option named in errors.

    Returns
    -------
    list of (str, float)
        The pairs in the given order, scales as floats.

    Raises
    ------
    InputError
        Not a list of pairs, none, a bad or repeated name, or a bad scale.

    >>> check_method_scales([("a", 1), ("a", 2)])
    Traceback (most recent call last):
    ...
    data_schema.errors.InputError: methods: a: expected each method name once, got again
    """
    try:
        items = [(name, scale) for name, scale in methods]
    except (TypeError, ValueError):
        raise InputError(param=option, expected="a list of (name, scale) pairs", got=repr(methods)) from None
    if not items:
        raise InputError(param=option, expected="at least one NAME:SCALE method", got="none")
    out, seen = [], set()
    for name, scale in items:
        check_method_name(name, param=option)
        ok = isinstance(scale, int | float | np.integer | np.floating) and not isinstance(scale, bool) \
            and math.isfinite(scale) and scale >= 0
        if not ok:
            raise InputError(param=option, field=name, expected="a finite scale >= 0 after ':'", got=scale)
        if name == REAL_METHOD:
            raise InputError(param=option, field=name, expected="a method name other than 'real' (reserved "
                             "for real photographs, nvrq import stereo)", got=name)
        if name == FLOOR_METHOD:
            raise InputError(param=option, field=name, expected="a method name other than 'floor' (reserved "
                             "for pairs of two GT views, the viewpoint floor of a log)", got=name)
        if name == PERFECT_METHOD and scale != 0:
            raise InputError(param=option, field=name, expected="scale 0 for 'perfect' (reserved for the "
                             "render with no artefact, the viewpoint floor)", got=scale)
        if name in seen:
            raise InputError(param=option, field=name, expected="each method name once", got="again")
        seen.add(name)
        out.append((name, float(scale)))
    return out
