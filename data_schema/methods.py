"""Reconstruction methods in one scene (docs/FORMATS.md §2-3): the optional ``method`` column.

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
- :func:`method_suffix`, the part a method adds to a pair id (``':3dgs'``; nothing for none);
- :func:`parse_methods`, the ``NAME:SCALE,...`` list of ``nvrq synth --methods``.

>>> method_suffix(["3dgs", ""])
[':3dgs', '']
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

__all__ = ["METHOD_COLUMN", "GT_METHOD", "check_method_name", "method_values", "method_columns", "method_suffix",
           "parse_methods", "check_methods", "check_table_methods"]

#: The optional column naming the reconstruction method of a render (empty: none).
METHOD_COLUMN = "method"

#: The reserved name of the GT crop where a method is expected (``method_a`` of a pairwise
#: study's gold items, docs/FORMATS.md §12): never a method's name.
GT_METHOD = "gt"

_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,63}")
#: read as missing values by CSV readers, and the GT crop's name
_RESERVED = {"na", "null", "none", GT_METHOD}
_EXPECTED = ("a method name of letters, digits, '_', '-' and '.' (starting with a letter or digit, "
             "at most 64 characters, with a letter, not NA/null/none/gt), e.g. 3dgs")


def check_method_name(name, *, where: object, field: str | None) -> str:
    """``name`` if it is a valid method name (module docstring), else :class:`InputError`.

    >>> check_method_name("3dgut-v2", where="images.csv", field="row 3, column method")
    '3dgut-v2'
    >>> check_method_name("a:b", where="--methods", field=None)
    Traceback (most recent call last):
    ...
    data_schema.errors.InputError: --methods: expected a method name of letters, digits, '_', '-' and '.' (starting with a letter or digit, at most 64 characters, with a letter, not NA/null/none/gt), e.g. 3dgs, got 'a:b'
    """
    if not _is_method_name(name):
        raise InputError(where, field, _EXPECTED, repr(name))
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
    """Each row's method ``(N,)`` object array of str; ``''`` where none (no column, empty or NaN)."""
    if METHOD_COLUMN not in table.columns:
        return np.full(len(table), "", dtype=object)
    col = table[METHOD_COLUMN]
    return col.where(col.notna(), "").astype(str).to_numpy(dtype=object)


def method_columns(table: pd.DataFrame) -> list[str]:
    """``[METHOD_COLUMN]`` when some row of ``table`` names a method, else ``[]`` (so tables of
    single-method scenes keep exactly their former columns).

    >>> method_columns(pd.DataFrame({"method": ["", "a"]})), method_columns(pd.DataFrame({"x": [1]}))
    (['method'], [])
    """
    return [METHOD_COLUMN] if (method_values(table) != "").any() else []


def method_suffix(methods) -> list[str]:
    """The pair-id part of each method: ``':NAME'``, or ``''`` for none (ids unchanged)."""
    return [f":{m}" if m else "" for m in methods]


def check_table_methods(table: pd.DataFrame, *, where: object, line_offset: int = 2,
                        what: str = "row") -> None:
    """Every non-empty ``method`` value of ``table`` is a valid name; errors name the row
    (``what`` + position + ``line_offset``, e.g. ``row 5`` of a CSV with a header)."""
    values = method_values(table)
    bad = [v for v in pd.unique(values) if v and not _is_method_name(v)]
    if bad:
        i = int(np.flatnonzero(pd.Series(values).isin(bad).to_numpy())[0])
        check_method_name(values[i], where=where, field=f"{what} {i + line_offset}, column {METHOD_COLUMN}")


def parse_methods(text: str, *, option: str = "methods") -> list[tuple[str, float]]:
    """``'NAME:SCALE,...'`` -> ``[(name, scale), ...]`` in the given order, checked by
    :func:`check_methods`. Errors name ``option``."""
    items = comma_list(text)
    if not items:
        raise InputError(option, None, "a comma list of NAME:SCALE items, e.g. 3dgs:0.5,nerf:1.5", text)
    out = []
    for item in items:
        name, sep, scale = item.rpartition(":")
        if not sep:
            raise InputError(option, None, "NAME:SCALE items, e.g. 3dgs:0.5", item)
        try:
            value = float(scale)
        except ValueError:
            value = scale
        out.append((name, value))
    return check_methods(out, option=option)


def check_methods(methods, *, option: str = "methods") -> list[tuple[str, float]]:
    """``[(name, scale), ...]`` checked: names by :func:`check_method_name`, each once; a scale
    is a finite number >= 0 (``nvrq synth`` multiplies the artefact severity by it: 0 = a
    perfect render, 1 = the usual one). At least one. Errors name ``option``.

    >>> check_methods([("a", 1), ("a", 2)])
    Traceback (most recent call last):
    ...
    data_schema.errors.InputError: methods: a: expected each method name once, got again
    """
    try:
        items = [(name, scale) for name, scale in methods]
    except (TypeError, ValueError):
        raise InputError(option, None, "a list of (name, scale) pairs", repr(methods)) from None
    if not items:
        raise InputError(option, None, "at least one NAME:SCALE method", "none")
    out, seen = [], set()
    for name, scale in items:
        check_method_name(name, where=option, field=None)
        ok = isinstance(scale, int | float | np.integer | np.floating) and not isinstance(scale, bool) \
            and math.isfinite(scale) and scale >= 0
        if not ok:
            raise InputError(option, name, "a finite scale >= 0 after ':'", scale)
        if name in seen:
            raise InputError(option, name, "each method name once", "again")
        seen.add(name)
        out.append((name, float(scale)))
    return out
