"""How the reports write numbers: one cell format and one "value [interval]" format, shared by
the report (:mod:`analysis.report`), the leaderboard section (:mod:`analysis.methods_report`)
and the pairwise report (:mod:`analysis.pairwise_report`).

>>> fmt(0.61234), fmt(float("nan")), fmt(True), fmt(7)
('0.612', '', 'yes', '7')
>>> interval_text(0.61234, 0.54, 0.68), interval_text(0.5, float("nan"), float("nan"), digits=2)
('0.612 [0.540, 0.680]', '0.50')
"""

from __future__ import annotations

import numpy as np
import pandas as pd

__all__ = ["fmt", "interval_text", "offset_text"]


def fmt(v, digits: int = 3) -> str:
    """A table cell: ``''`` for a missing or non-finite number, ``yes``/``no`` for a bool,
    ``digits`` decimals for a float, else ``str(v)``."""
    if v is None or (isinstance(v, float) and not np.isfinite(v)) or v is pd.NA:
        return ""
    if isinstance(v, (bool, np.bool_)):
        return "yes" if v else "no"
    if isinstance(v, (float, np.floating)):
        return f"{v:.{digits}f}"
    return str(v)


def interval_text(v, lo, hi, digits: int = 3) -> str:
    """``v`` (:func:`fmt`) followed by its interval ``[lo, hi]`` when ``lo`` is a finite
    number; ``''`` when ``v`` is undefined."""
    text = fmt(v, digits)
    if text and lo is not None and np.isfinite(lo):
        text += f" [{lo:.{digits}f}, {hi:.{digits}f}]"
    return text


def offset_text(v) -> str:
    """A view's value along its axis, the one way every table and figure writes it: signed,
    shortest form, ``0`` for the recorded view (``''`` when undefined).

    >>> offset_text(3.0), offset_text(-1.5), offset_text(0.0), offset_text(-0.0), offset_text(float("nan"))
    ('+3', '-1.5', '0', '0', '')
    """
    if v is None or not np.isfinite(v):
        return ""
    return "0" if v == 0 else f"{v:+g}"
