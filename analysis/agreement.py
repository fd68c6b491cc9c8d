"""Krippendorff's alpha for nominal data (Krippendorff 2011, "Computing Krippendorff's
Alpha-Reliability"), from long-format (unit, value) pairs — one per rater vote.

With ``N[u, c]`` the number of values ``c`` given to unit ``u`` and ``m_u`` the values of
unit ``u``, only units with ``m_u >= 2`` are pairable. The coincidence matrix is
``o[c, k] = sum_u (N[u, c] N[u, k] - [c == k] N[u, c]) / (m_u - 1)``, ``n_c = sum_k o[c, k]``,
``n = sum_c n_c``, and for nominal data

    alpha = 1 - (n - 1) * sum_{c != k} o[c, k] / sum_{c != k} n_c n_k.

Undefined (NaN with a reason) when no unit has two values, or when only one value occurs.

>>> alpha_nominal(["a", "a", "b", "b"], [1, 1, 0, 0])
(1.0, None)
"""

from __future__ import annotations

import numpy as np
import pandas as pd

__all__ = ["alpha_nominal"]


def alpha_nominal(units, values) -> tuple[float, str | None]:
    """Krippendorff's alpha (nominal) of ``values`` (n,) given to ``units`` (n,).

    Missing values (NaN/None) are ignored. Returns ``(alpha, reason)``.
    """
    df = pd.DataFrame({"u": np.asarray(units, dtype=object), "v": np.asarray(values, dtype=object)})
    df = df[df["v"].notna()]
    u_codes, _ = pd.factorize(df["u"])
    v_codes, v_uniques = pd.factorize(df["v"])
    n_units, n_vals = (u_codes.max() + 1 if len(u_codes) else 0), len(v_uniques)
    counts = np.zeros((n_units, n_vals), dtype=np.float64)  # (U, V)
    np.add.at(counts, (u_codes, v_codes), 1.0)
    m = counts.sum(axis=1)
    pairable = m >= 2
    if not pairable.any():
        return float("nan"), "no unit has two values"
    c = counts[pairable]
    inv = 1.0 / (m[pairable] - 1.0)
    o = (c * inv[:, None]).T @ c - np.diag((c * inv[:, None]).sum(axis=0))  # (V, V)
    n_c = o.sum(axis=1)
    n = n_c.sum()
    disagree_obs = o.sum() - np.trace(o)
    disagree_exp = n_c.sum() ** 2 - (n_c**2).sum()
    if disagree_exp == 0:
        return float("nan"), "only one value occurs"
    return float(1.0 - (n - 1.0) * disagree_obs / disagree_exp), None
