"""CSV files written for people: cells a spreadsheet would run as a formula are made inert
(data_schema layer: no dependency above pandas).

A spreadsheet opening a CSV runs a cell that starts with ``=``, ``+``, ``-`` or ``@`` as a
formula (``=HYPERLINK(...)``, ``=cmd|...``), and a leading tab or carriage return can hide one.
As OWASP recommends against CSV injection, every string cell (and column name) that starts with
one of :data:`FORMULA_START` gets a single quote in front; spreadsheets show the quote-prefixed
text as text. Numbers are never touched: a numeric column's ``-3`` stays ``-3``, and a string
cell that is a plain number (``-3``, ``+1.5``, ``-2e-3``) is left as it is, since no
spreadsheet runs it.

Which CSVs are for people (docs/FORMATS.md §5 and §6 list them): ``annotate export``'s
``ratings.csv`` and participants table, and the tables of an ``analyze`` report folder. Tables
that programs read back as given (pairs, metrics, scores, the study's own files) are written
raw. ``analyze`` reads a quote-prefixed cell of ``ratings.csv`` back as it was
(:func:`unquote_frame`), so an exported table round-trips. ``annotate export --raw-csv`` writes
the cells as they came.

>>> safe_cell("=HYPERLINK(\\"http://x\\")"), safe_cell("-3"), safe_cell(-3), safe_cell("@sum")
('\\'=HYPERLINK("http://x")', '-3', -3, "'@sum")
>>> unquote_cell(safe_cell("+cmd")), unquote_cell("'plain")
('+cmd', "'plain")
"""

from __future__ import annotations

import os
import re

import pandas as pd

__all__ = ["FORMULA_START", "safe_cell", "unquote_cell", "safe_frame", "unquote_frame",
           "write_people_table"]

#: First characters a spreadsheet treats as the start of a formula (OWASP, CSV injection).
FORMULA_START = ("=", "+", "-", "@", "\t", "\r")

_NUMBER = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?|[+-]")


def _risky(v) -> bool:
    return isinstance(v, str) and v[:1] in FORMULA_START and not _NUMBER.fullmatch(v)


def safe_cell(v):
    """``v`` with a single quote in front when it is a string a spreadsheet would run.

    Parameters
    ----------
    v : object
        A cell value.

    Returns
    -------
    object
        ``"'" + v`` for a string starting with one of :data:`FORMULA_START` that is not a
        plain number; ``v`` unchanged otherwise (numbers, NaN, other strings).
    """
    return "'" + v if _risky(v) else v


def unquote_cell(v):
    """The inverse of :func:`safe_cell`: a quote-prefixed risky string loses its quote.

    Parameters
    ----------
    v : object
        A cell value read from a CSV written for people.

    Returns
    -------
    object
        ``v[1:]`` when ``v`` is ``"'"`` followed by a string :func:`safe_cell` prefixes;
        ``v`` unchanged otherwise.
    """
    return v[1:] if isinstance(v, str) and v[:1] == "'" and _risky(v[1:]) else v


def _map_text(df: pd.DataFrame, f) -> pd.DataFrame:
    out = df.rename(columns=lambda c: f(c) if isinstance(c, str) else c)
    for i, dtype in enumerate(out.dtypes):
        if pd.api.types.is_object_dtype(dtype) or pd.api.types.is_string_dtype(dtype):
            col = out.iloc[:, i]
            if col.map(lambda v: f(v) is not v).any():
                out.isetitem(i, col.map(f))
    return out


def safe_frame(df: pd.DataFrame) -> pd.DataFrame:
    """A copy of ``df`` with :func:`safe_cell` applied to the column names and to every cell
    of its text (object or string) columns; numeric columns are not touched.

    Parameters
    ----------
    df : pandas.DataFrame
        Any table.

    Returns
    -------
    pandas.DataFrame
        Same shape, index and dtypes.
    """
    return _map_text(df, safe_cell)


def unquote_frame(df: pd.DataFrame) -> pd.DataFrame:
    """:func:`safe_frame` undone: column names and text cells lose the quote it added.

    Parameters
    ----------
    df : pandas.DataFrame
        A table read from a CSV written for people.

    Returns
    -------
    pandas.DataFrame
        Same shape, index and dtypes.
    """
    return _map_text(df, unquote_cell)


def write_people_table(df: pd.DataFrame, path: str | os.PathLike, *, raw: bool = False):
    """Write a table for people (:func:`data_schema.tables.write_table`): a ``.csv`` gets
    :func:`safe_frame` unless ``raw``; a ``.parquet`` is written as it is (no spreadsheet runs
    its cells).

    Parameters
    ----------
    df : pandas.DataFrame
        The table.
    path : str or os.PathLike
        ``.csv`` or ``.parquet``.
    raw : bool
        Keep the cells as they are (``annotate export --raw-csv``).

    Returns
    -------
    pathlib.Path
        The path written.
    """
    from data_schema.tables import write_table

    csv = str(path).lower().endswith(".csv")
    return write_table(df if raw or not csv else safe_frame(df), path)
