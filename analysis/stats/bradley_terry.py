"""The Bradley-Terry model of pairwise comparisons and the two-way bootstrap of a pairwise study
(docs/FORMATS.md §11).

Layer: analysis (statistics of votes and metrics).

- :func:`win_matrix`: votes -> wins of each method over each other (a tie is half a win each);
- :func:`bradley_terry`: strengths ``p`` (sum 1) with ``P(i beats j) = p_i / (p_i + p_j)``,
  the maximum-likelihood fit by the MM algorithm of Hunter (2004), the model of crowd-kit's
  ``BradleyTerry``, iterated to convergence (crowd-kit 1.4 stops after its second iteration:
  its convergence check compares the new strengths with themselves, which is exact for two
  methods only);
- :func:`win_prob`: the mean of ``P(i beats j)`` over the other methods;
- :class:`Draws`: bootstrap draw counts of raters and items, a vote weighing the product of
  its rater's and its item's counts.

>>> w = np.array([[0.0, 3.0], [1.0, 0.0]])  # a beat b 3 times, b beat a once
>>> np.round(bradley_terry(w), 3).tolist()
[0.75, 0.25]
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from analysis.stats import bootstrap as bs

__all__ = ["CHOICES", "coded_votes", "win_matrix", "bradley_terry", "strongly_connected", "win_prob",
           "Draws"]

#: The share of a vote's win going to side a, per ``choice`` (docs/FORMATS.md §12).
CHOICES = {"a": 1.0, "tie": 0.5, "b": 0.0}

_TOL, _MAX_ITER = 1e-12, 20_000


def strongly_connected(w: np.ndarray) -> np.ndarray:
    """w: (..., M, M) wins -> (...,) bool: every method reaches every other by edges i->j
    where i beat j (so each won and lost against the rest).

    Parameters
    ----------
    w : (..., M, M) float64
        ``w[..., i, j] > 0`` where method i beat method j at least once (ties count).

    Returns
    -------
    (...,) bool
        One flag per matrix: True where the maximum-likelihood fit is finite.
    """
    m = w.shape[-1]
    r = (w > 0) | np.eye(m, dtype=bool)
    for _ in range(max(1, int(np.ceil(np.log2(max(m, 2)))))):
        r = (r.astype(np.int64) @ r.astype(np.int64)) > 0
    return r.all(axis=(-2, -1))


def bradley_terry(w: np.ndarray) -> np.ndarray:
    """Bradley-Terry strengths of win matrices ``w`` (..., M, M) -> (..., M), summing to 1.

    ``w[..., i, j]``: (weighted) wins of method i over method j; a tie adds 0.5 to both cells.
    Fitted by the MM iteration ``p_i <- W_i / sum_j n_ij / (p_i + p_j)`` (Hunter 2004) until no
    strength moves by more than 1e-12. A method without comparisons gets NaN. Where the
    comparison graph is not strongly connected (:func:`strongly_connected`) the likelihood has
    no finite maximum and the iteration moves towards its limit (a method that never won
    tends to 0), the values the table reports with that reason.

    Parameters
    ----------
    w : (..., M, M) float64
        Win matrices.

    Returns
    -------
    (..., M) float64
        Strengths summing to 1; NaN for a method without comparisons.
    """
    w = np.asarray(w, dtype=np.float64)
    n = w + np.swapaxes(w, -1, -2)
    wins = w.sum(axis=-1)
    active = n.sum(axis=-1) > 0
    m = w.shape[-1]
    p = np.where(active, 1.0, 0.0)
    p = p / np.maximum(p.sum(axis=-1, keepdims=True), 1.0)
    for _ in range(_MAX_ITER):
        with np.errstate(invalid="ignore", divide="ignore"):
            pair = p[..., :, None] + p[..., None, :]
            denom = np.where(n > 0, n / np.where(pair > 0, pair, 1.0), 0.0).sum(axis=-1)
            new = np.where(denom > 0, wins / np.where(denom > 0, denom, 1.0), 0.0)
            total = new.sum(axis=-1, keepdims=True)
            new = np.where(total > 0, new / np.where(total > 0, total, 1.0), 1.0 / m)
        delta = float(np.abs(new - p).max()) if new.size else 0.0
        p = new
        if delta < _TOL:
            break
    return np.where(active, p, np.nan)


def win_prob(p: np.ndarray) -> np.ndarray:
    """(..., M) strengths -> (..., M) mean of p_i / (p_i + p_j) over the other methods with
    comparisons (finite p_j; two strengths of 0 count as even).

    Parameters
    ----------
    p : (..., M) float64
        Strengths.

    Returns
    -------
    (..., M) float64
        In [0, 1].
    """
    with np.errstate(invalid="ignore", divide="ignore"):
        s = p[..., :, None] + p[..., None, :]
        pr = np.where(s > 0, p[..., :, None] / np.where(s > 0, s, 1.0), 0.5)
    m = p.shape[-1]
    other = ~np.eye(m, dtype=bool) & np.isfinite(pr)
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.where(other, pr, 0.0).sum(axis=-1) / other.sum(axis=-1)
    return np.where(np.isfinite(p), out, np.nan)


def coded_votes(votes: pd.DataFrame, methods: list[str]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pairwise votes as the codes :func:`win_matrix` counts: methods by index, choices by score.

    Parameters
    ----------
    votes : pandas.DataFrame
        V votes with columns ``method_a, method_b, choice``.
    methods : list of str
        The methods; a method's code is its index in this list.

    Returns
    -------
    a, b : (V,) int64
        The codes of each vote's side a and side b; -1 for a method not in ``methods``.
    s : (V,) float64
        The share of the win going to side a (:data:`CHOICES`); NaN for another choice.

    >>> v = pd.DataFrame({"method_a": ["x", "y"], "method_b": ["y", "z"], "choice": ["tie", "a"]})
    >>> [c.tolist() for c in coded_votes(v, ["x", "y"])]
    [[0, 1], [1, -1], [0.5, 1.0]]
    """
    a = pd.Index(methods).get_indexer(votes["method_a"]).astype(np.int64)
    b = pd.Index(methods).get_indexer(votes["method_b"]).astype(np.int64)
    return a, b, votes["choice"].map(CHOICES).to_numpy(np.float64)


def win_matrix(a: np.ndarray, b: np.ndarray, score: np.ndarray, m: int) -> np.ndarray:
    """(M, M) win matrix of votes: ``a``, ``b`` (V,) method codes, ``score`` (V,) the share of
    the win going to ``a`` (1, 0.5 or 0); ``w[i, j]`` = summed share of i against j.

    Parameters
    ----------
    a, b : (V,) int
        Method codes of the two sides of each vote.
    score : (V,) float64
        Share of the win going to ``a``: 1, 0.5 or 0.
    m : int
        Number of methods M.

    Returns
    -------
    (M, M) float64

    >>> win_matrix(np.array([0, 0, 1]), np.array([1, 1, 0]), np.array([1.0, 0.5, 1.0]), 2).tolist()
    [[0.0, 1.5], [1.5, 0.0]]
    """
    cells = np.concatenate([a * m + b, b * m + a])
    share = np.concatenate([score, 1.0 - score])
    return np.bincount(cells, weights=share, minlength=m * m).reshape(m, m)


@dataclass
class Draws:
    """Draw counts of raters (B, R) and items (B, I); one draw set for every statistic.

    Attributes
    ----------
    raters : (B, R) int
        How often each rater is drawn in each replicate.
    items : (B, I) int
        How often each item is drawn in each replicate.
    """

    raters: np.ndarray
    items: np.ndarray

    @classmethod
    def make(cls, n_raters: int, n_items: int, n_boot: int, seed: int) -> Draws | None:
        if n_boot <= 0 or n_raters == 0 or n_items == 0:
            return None
        return cls(bs.draw_cluster_counts(n_raters, n_boot, seed=seed),
                   bs.draw_cluster_counts(n_items, n_boot, seed=seed + 1))

    def total(self, r: np.ndarray, i: np.ndarray, values: np.ndarray) -> np.ndarray:
        """(B,) sum over votes of (rater draws x item draws x value); votes given by their
        rater ``r`` and item ``i`` codes (V,). Works on the (R, I) grid, never on (B, V), and
        on at most :data:`analysis.stats.bootstrap.CHUNK_CELLS` replicate-items at a time."""
        grid = np.zeros((self.raters.shape[1], self.items.shape[1]))
        np.add.at(grid, (r, i), values)
        out = np.empty(self.raters.shape[0])
        step = max(1, bs.CHUNK_CELLS // max(1, grid.shape[1]))
        for b0 in range(0, len(out), step):
            sl = slice(b0, b0 + step)
            out[sl] = ((self.raters[sl].astype(np.float64) @ grid) * self.items[sl]).sum(axis=1)
        return out

    def win_matrices(self, a, b, score, m: int, r, i) -> np.ndarray:
        """(B, M, M) win matrices of the votes (:func:`win_matrix`) in every replicate."""
        cells = np.concatenate([a * m + b, b * m + a])
        share = np.concatenate([score, 1.0 - score])
        rr, ii = np.concatenate([r, r]), np.concatenate([i, i])
        out = np.zeros((self.raters.shape[0], m * m))
        for c in np.unique(cells):
            on = cells == c
            out[:, c] = self.total(rr[on], ii[on], share[on])
        return out.reshape(-1, m, m)
