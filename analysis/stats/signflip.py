"""The paired sign-flip (permutation) test over tracks of the method comparison
(docs/FORMATS.md §11).

Layer: analysis (statistics of votes and metrics).

Under the null hypothesis that two methods are equally good, the paired differences of one
track are as likely to come out with the opposite sign: flipping the sign of a whole track's
differences gives another equally likely data set. The statistic is the sum of the
differences, ``T = sum_t S_t`` with ``S_t`` the sum of track t's differences (so ``T / n`` is
the reported mean difference: a track weighs by its objects, as in the point estimate and the
cluster bootstrap). The two-sided p-value is the share of sign patterns ``s`` with
``|sum_t s_t S_t| >= |T|``:

- exact, over all ``2^n`` patterns of the ``n`` tracks, when ``n <= EXACT_MAX_TRACKS``
  (16: 65,536 patterns); it is never below ``2 / 2^n`` (the identity and the all-flipped
  pattern always count), the floor this many tracks allow;
- else Monte Carlo over B random patterns (shared by every row, so rows stay paired), with the
  add-one rule ``(1 + #{|T*| >= |T|}) / (B + 1)`` (Phipson & Smyth 2010), floor ``1 / (B + 1)``.

Values that equal ``|T|`` up to rounding (relative 100 machine epsilons, the tolerance of
:func:`scipy.stats.permutation_test`) count as reaching it. The test is exact for any number
of tracks (no large-sample approximation), which is why it replaces the bootstrap p-value:
the percentile bootstrap over few tracks is no test at all.

>>> p, floor, exact = sign_flip_p(np.array([[1.0, 2.0, 3.0]]), signs=None)
>>> p.tolist(), floor.tolist(), exact.tolist()  # 2 of 8 patterns reach |1 + 2 + 3| = 6
([0.25], [0.25], [True])
"""

from __future__ import annotations

import numpy as np

from analysis.stats.bootstrap import CHUNK_CELLS

__all__ = ["EXACT_MAX_TRACKS", "sign_patterns", "draw_signs", "sign_flip_p"]

#: Up to this many tracks the p-value enumerates every sign pattern (2^16 = 65,536).
EXACT_MAX_TRACKS = 16
_RTOL = 100 * np.finfo(np.float64).eps


def sign_patterns(n: int) -> np.ndarray:
    """(2^n, n) float64: every pattern of signs +1/-1 of ``n`` tracks, the identity first.

    Parameters
    ----------
    n : int
        Tracks.

    Returns
    -------
    (2**n, n) float64

    >>> sign_patterns(2).tolist()
    [[1.0, 1.0], [-1.0, 1.0], [1.0, -1.0], [-1.0, -1.0]]
    """
    bits = (np.arange(2 ** n)[:, None] >> np.arange(n)[None, :]) & 1
    return 1.0 - 2.0 * bits


def draw_signs(n_tracks: int, n_draws: int, *, seed: int) -> np.ndarray:
    """(B, K) int8 random signs +1/-1 of K tracks in each of B Monte Carlo patterns.

    Parameters
    ----------
    n_tracks : int
        Tracks K, each flipped on its own.
    n_draws : int
        Monte Carlo patterns B (rows of the result).
    seed : int
        Seed of ``numpy.random.default_rng``; one seed, one set of patterns.

    Returns
    -------
    (B, K) int8
        +1 or -1, each with probability 1/2.
    """
    rng = np.random.default_rng(seed)
    return (1 - 2 * rng.integers(0, 2, size=(n_draws, n_tracks))).astype(np.int8)


def sign_flip_p(sums: np.ndarray, *, signs: np.ndarray | None,
                exact_max: int = EXACT_MAX_TRACKS) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Two-sided sign-flip p-values of G rows (module docstring).

    Parameters
    ----------
    sums : numpy.ndarray
        (G, K) each row's sum of paired differences per track; NaN where the track has no
        object in the row (a track with objects whose differences sum to 0 is 0).
    signs : numpy.ndarray or None
        (B, K) Monte Carlo sign patterns (:func:`draw_signs`) for rows of more than
        ``exact_max`` tracks; None: such rows get NaN.
    exact_max : int, optional
        The most tracks a row enumerates exactly.

    Returns
    -------
    p, floor : numpy.ndarray
        (G,) the p-value and the smallest p-value the row's test can give (NaN without tracks).
    exact : numpy.ndarray
        (G,) bool: the p-value enumerates every pattern.
    """
    sums = np.atleast_2d(np.asarray(sums, dtype=np.float64))
    has = np.isfinite(sums)
    n = has.sum(axis=1)
    x = np.where(has, sums, 0.0)
    t = np.abs(x.sum(axis=1))
    tol = t - _RTOL * t
    p = np.full(len(sums), np.nan)
    floor = np.full(len(sums), np.nan)
    exact = (n >= 1) & (n <= exact_max)
    patterns: dict[int, np.ndarray] = {}
    for g in np.flatnonzero(exact):  # one product per row: at most 2^16 x 16
        k = int(n[g])
        pat = patterns.setdefault(k, sign_patterns(k))
        p[g] = float((np.abs(pat @ x[g, has[g]]) >= tol[g]).mean())
        floor[g] = 2.0 / 2 ** k
    mc = np.flatnonzero(n > exact_max)
    if signs is not None and mc.size:
        b = signs.shape[0]
        reached = np.zeros(mc.size)
        step = max(1, CHUNK_CELLS // max(1, signs.shape[1]))  # patterns per product: bounded memory
        for b0 in range(0, b, step):
            null = np.abs(x[mc] @ signs[b0:b0 + step].T.astype(np.float64))  # (rows, chunk)
            reached += (null >= tol[mc, None]).sum(axis=1)
        p[mc] = (1.0 + reached) / (b + 1.0)
        floor[mc] = 1.0 / (b + 1.0)
    return p, floor, exact
