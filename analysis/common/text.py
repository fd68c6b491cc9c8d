"""How the reports write numbers: one cell format and one "value [interval]" format, shared by
the report (:mod:`analysis.report.report`), the leaderboard section (:mod:`analysis.report.methods_report`)
and the pairwise report (:mod:`analysis.report.pairwise_report`); and the sentence that says which
raters were left out and why (:func:`screening_text`, also printed by ``analyze``).

Layer: analysis (report text).

>>> fmt(0.61234), fmt(float("nan")), fmt(True), fmt(7)
('0.612', '', 'yes', '7')
>>> interval_text(0.61234, 0.54, 0.68), interval_text(0.5, float("nan"), float("nan"), digits=2)
('0.612 [0.540, 0.680]', '0.50')
"""

from __future__ import annotations

import re

import numpy as np
import pandas as pd

from data_schema.text import plural

__all__ = ["fmt", "cell_text", "interval_text", "offset_text", "screening_text", "no_votes_left",
           "md_escape", "MdText", "MISSING_TEXT"]

#: What a table shows for a value that is missing by nature (``None``): a dash, not "None".
MISSING_TEXT = "\u2014"
_COUNT_NAMES = frozenset({"n", "k", "wins", "ties", "losses", "votes", "gold_failures", "pairs",
                          "n_tracks", "n_votes"})

# what makes Markdown run or link data: a backslash (it would undo an escape), "<" before what
# starts raw HTML or an autolink, and "](" of a link or image
_MD_ACTIVE = re.compile(r"\\|<(?=[A-Za-z/!?])|\]\(")


class MdText(str):
    """Markdown the report made itself (a rendered table): :func:`md_escape` leaves it as is."""


def md_escape(text: str, *, cell: bool = False) -> str:
    """``text`` made inert in Markdown: shown as written, never run as HTML nor made a link.

    A backslash is doubled, ``<`` before a letter, ``/``, ``!`` or ``?`` (raw HTML, an
    autolink) and ``](`` (a link or image) are backslash-escaped. With ``cell``, for a
    Markdown table cell, ``|`` is escaped too and line breaks become spaces. :class:`MdText`
    is returned unchanged.

    Parameters
    ----------
    text : str
        Text that may carry data (names, values, paths).
    cell : bool
        The text goes in a Markdown table cell.

    Returns
    -------
    str
        The escaped text; renders as ``text`` itself.

    >>> md_escape('<img src=x onerror=alert(1)> p < 0.01')
    '\\\\<img src=x onerror=alert(1)> p < 0.01'
    >>> md_escape("[a](javascript:x) | b", cell=True)
    '[a\\\\](javascript:x) \\\\| b'
    """
    if isinstance(text, MdText):
        return text
    out = _MD_ACTIVE.sub(lambda m: "\\" + m.group(0), text)
    return out.replace("|", "\\|").replace("\r", " ").replace("\n", " ") if cell else out


def fmt(v, digits: int = 3) -> str:
    """A table cell: ``''`` for a missing or non-finite number, ``yes``/``no`` for a bool,
    ``digits`` decimals for a float, else ``str(v)``.

    Parameters
    ----------
    v : object
        The value.
    digits : int, optional
        Decimals of a float.

    Returns
    -------
    str
    """
    if v is None or (isinstance(v, float) and not np.isfinite(v)) or v is pd.NA:
        return ""
    if isinstance(v, (bool, np.bool_)):
        return "yes" if v else "no"
    if isinstance(v, (float, np.floating)):
        return f"{v:.{digits}f}"
    return str(v)


def _is_count(column) -> bool:
    c = str(column)
    return (c in _COUNT_NAMES or c.startswith("n_") or c.endswith("_n") or c.endswith("_ms")
            or c.endswith(" n"))


def cell_text(v, column="") -> str:
    """A report table's cell: :func:`fmt`, except that a count column (``n``, ``k``,
    ``n_*``, ``*_n``, wins/ties/losses, milliseconds ``*_ms``) prints a whole number without
    decimals, and ``None`` or the text ``"None"`` prints as :data:`MISSING_TEXT`.

    Parameters
    ----------
    v : object
        The value.
    column : str
        Its column's name.

    Returns
    -------
    str
        The cell's text.

    >>> cell_text(497.0, "nvrq_ca_n"), cell_text(919.4, "median_response_ms"), cell_text(0.5, "k")
    ('497', '919', '0.500')
    >>> cell_text(None), cell_text("None"), cell_text(float("nan"), "n")
    ('\u2014', '\u2014', '')
    """
    if v is None or (isinstance(v, str) and v == "None"):
        return MISSING_TEXT
    if (isinstance(v, (float, np.floating)) and np.isfinite(v) and _is_count(column)
            and (float(v).is_integer() or str(column).endswith("_ms"))):
        return f"{v:.0f}"
    return fmt(v)


def interval_text(v, lo, hi, digits: int = 3) -> str:
    """``v`` (:func:`fmt`) followed by its interval ``[lo, hi]`` when ``lo`` is a finite
    number; ``''`` when ``v`` is undefined.

    Parameters
    ----------
    v, lo, hi : float
        Value and interval bounds.
    digits : int, optional
        Decimals.

    Returns
    -------
    str
    """
    text = fmt(v, digits)
    if text and lo is not None and np.isfinite(lo):
        text += f" [{lo:.{digits}f}, {hi:.{digits}f}]"
    return text


def offset_text(v) -> str:
    """A view's value along its axis, the one way every table and figure writes it: signed,
    shortest form, ``0`` for the recorded view (``''`` when undefined).

    Parameters
    ----------
    v : float
        Value along the axis, metres or degrees.

    Returns
    -------
    str

    >>> offset_text(3.0), offset_text(-1.5), offset_text(0.0), offset_text(-0.0), offset_text(float("nan"))
    ('+3', '-1.5', '0', '0', '')
    """
    if v is None or not np.isfinite(v):
        return ""
    return "0" if v == 0 else f"{v:+g}"


def screening_text(raters: pd.DataFrame, *, applied: bool) -> str:
    """Who was excluded and why, and who was flagged but kept, from a screened rater table
    (:func:`annotate.screening.screen`: ``rater_id, flags, excluded, excluded_reason``);
    ``applied``: whether the screening rule excluded (``analyze``'s default).

    Parameters
    ----------
    raters : pandas.DataFrame
        A screened rater table.
    applied : bool
        Whether the screening rule excluded.

    Returns
    -------
    str

    >>> r = pd.DataFrame({"rater_id": ["ann", "bob"], "flags": ["", "gold failures"],
    ...                   "excluded": [False, True], "excluded_reason": ["", "screening: gold failures"]})
    >>> screening_text(r, applied=True)
    'Excluded 1 of 2 raters: bob (screening: gold failures).'
    >>> screening_text(r.assign(excluded=False), applied=False)
    'No rater excluded (2 raters). Screening off (--no-screen): kept despite its flags: bob (gold failures).'
    """
    ex = raters[raters["excluded"].astype(bool)]
    n = len(raters)
    text = (f"Excluded {len(ex)} of {plural(n, 'rater')}: " + "; ".join(
        f"{r.rater_id} ({r.excluded_reason})" for r in ex.itertuples()) + "."
        if len(ex) else f"No rater excluded ({plural(n, 'rater')}).")
    flags = raters.get("flags", pd.Series("", index=raters.index)).fillna("").astype(str)
    kept = raters[~raters["excluded"].astype(bool) & (flags != "")]
    if len(kept) and not applied:
        text += " Screening off (--no-screen): kept despite its flags: " + "; ".join(
            f"{r.rater_id} ({r.flags})" for r in kept.itertuples()) + "."
    return text


def no_votes_left(screened: bool) -> str:
    """What a vote table that the exclusions left without test votes should have had (the
    error of both designs; with screening on, how to keep the flagged raters).

    Parameters
    ----------
    screened : bool
        Whether screening was on.

    Returns
    -------
    str
    """
    return ("at least one test vote after exclusions (screening flagged every rater left; "
            "`screen` off keeps them)" if screened else "at least one test vote after exclusions")
