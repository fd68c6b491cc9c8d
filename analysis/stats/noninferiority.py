"""The cheapest metric that is good enough: a non-inferiority recommendation.

Layer: analysis (statistics of votes and metrics).

Best metric: the highest |SRCC|; ties (equal |SRCC| within :data:`TIE_TOL`, e.g. NVRQ and
NVRQ-CA, which share their ranks by construction) go to the faster metric by measured
pairs/s, then to the alphabetically first name. A candidate is *non-inferior* when the
one-sided ``level`` (default 95%) upper bound of the paired cluster-bootstrap distribution of
``SRCC(best) - SRCC(candidate)`` (its ``level`` quantile over replicates sharing the same
track draws) is below ``margin`` (default 0.02). The recommendation is the fastest metric,
by pairs/s, among the best and its non-inferior candidates that are faster than it.
"Not significantly different" is not enough: a wide interval that includes 0 fails here.

>>> reps = {"a": np.array([0.60, 0.62, 0.64]), "b": np.array([0.59, 0.615, 0.635])}
>>> r = recommend({"a": 0.62, "b": 0.615}, {"a": 10.0, "b": 100.0}, reps)
>>> r.metric, round(r.bound, 4)
('b', 0.0095)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from analysis.common.choices import DEFAULT_MARGIN  # one definition of analyze's choices

__all__ = ["DEFAULT_MARGIN", "TIE_TOL", "Recommendation", "upper_bound", "recommend",
           "recommend_from_tables"]

TIE_TOL = 1e-12


@dataclass(frozen=True)
class Recommendation:
    """``metric``: the recommended one (``best`` when no faster one is non-inferior);
    ``bound``: its upper bound of SRCC(best) - SRCC(metric) (0 for the best itself);
    ``checked``: (metric, bound) of every faster candidate, fastest first.

    Attributes
    ----------
    metric : str
        The recommended metric.
    best : str
        The metric of highest |SRCC|.
    bound : float
        Upper bound of SRCC(best) - SRCC(metric).
    margin : float
        The non-inferiority margin.
    level : float
        One-sided coverage of the bound.
    checked : tuple of (str, float)
        ``(metric, bound)`` of every faster candidate, fastest first.
    """

    metric: str
    best: str
    bound: float
    margin: float
    level: float
    checked: tuple

    def sentence(self) -> str:
        tried = "; ".join(f"{m} {b:+.3f}" for m, b in self.checked) or "none with a measured speed"
        head = (f"Recommended: {self.metric}, the fastest metric non-inferior to the best ({self.best}): "
                f"one-sided {self.level:.0%} bound of SRCC({self.best}) - SRCC({self.metric}) = "
                f"{self.bound:.3f} < margin {self.margin:g}."
                if self.metric != self.best else
                f"No faster metric is non-inferior to the best ({self.best}) at margin {self.margin:g}; "
                f"use {self.best}.")
        return (f"{head} Faster candidates and their bounds: {tried}. Ties in the best SRCC go to "
                "the faster metric, then the first name.")


def upper_bound(best: np.ndarray, other: np.ndarray, *, level: float = 0.95) -> float:
    """One-sided ``level`` upper bound of ``best - other`` over paired replicates (B,) each
    (NaN replicates dropped; NaN when none is left).

    Parameters
    ----------
    best, other : (B,) float64
        Paired bootstrap replicates.
    level : float, optional
        One-sided coverage.

    Returns
    -------
    float
        NaN when no replicate is defined.
    """
    d = np.asarray(best, float) - np.asarray(other, float)
    d = d[np.isfinite(d)]
    return float(np.quantile(d, level)) if len(d) else float("nan")


def _best(srcc: dict, speed: dict) -> str:
    top = max(srcc.values())
    tied = [m for m, s in srcc.items() if top - s <= TIE_TOL]
    return sorted(tied, key=lambda m: (-speed.get(m, -np.inf), m))[0]


def recommend(srcc: dict, speed: dict, reps: dict, *, margin: float = DEFAULT_MARGIN,
              level: float = 0.95) -> Recommendation | None:
    """``srcc``: metric -> |SRCC| (finite ones count); ``speed``: metric -> pairs/s;
    ``reps``: metric -> (B,) bootstrap |SRCC| replicates on shared draws. ``None`` when no
    metric has an SRCC.

    Parameters
    ----------
    srcc : dict
        Metric -> |SRCC|.
    speed : dict
        Metric -> pairs per second.
    reps : dict
        Metric -> (B,) bootstrap |SRCC| replicates on shared draws.
    margin : float, optional
        The non-inferiority margin on |SRCC|.
    level : float, optional
        One-sided coverage of the bound.

    Returns
    -------
    Recommendation or None
    """
    srcc = {m: float(s) for m, s in srcc.items() if np.isfinite(s)}
    if not srcc:
        return None
    best = _best(srcc, speed)
    base = speed.get(best, np.nan)
    faster = sorted((m for m in srcc if m != best and np.isfinite(speed.get(m, np.nan))
                     and not speed[m] <= base), key=lambda m: -speed[m])
    checked = []
    for m in faster:
        b = upper_bound(reps[best], reps[m], level=level) if best in reps and m in reps else float("nan")
        checked.append((m, b))
    for m, b in checked:  # fastest first
        if b < margin:
            return Recommendation(m, best, b, margin, level, tuple(checked))
    return Recommendation(best, best, 0.0, margin, level, tuple(checked))


def recommend_from_tables(summary: pd.DataFrame, timing: pd.DataFrame | None, *,
                          margin: float = DEFAULT_MARGIN) -> Recommendation | None:
    """:func:`recommend` on the analysis summary (``metric, srcc``; replicates in
    ``summary.attrs['srcc_replicates']``) and the timing (``metric, pairs_per_s``).

    Parameters
    ----------
    summary : pandas.DataFrame
        The analysis summary (``metric, srcc``).
    timing : pandas.DataFrame or None
        The timing table (``metric, pairs_per_s``).
    margin : float, optional
        The non-inferiority margin on |SRCC|.

    Returns
    -------
    Recommendation or None
    """
    if timing is None or summary.empty:
        return None
    speed = dict(zip(timing["metric"], timing["pairs_per_s"], strict=True))
    srcc = {m: s for m, s in zip(summary["metric"], summary["srcc"], strict=True) if m in speed}
    return recommend(srcc, speed, summary.attrs.get("srcc_replicates", {}), margin=margin)
