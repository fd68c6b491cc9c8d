"""Where the next vote goes: active pairwise selection and adaptive binary sampling.

Layer: annotate (rating study); pure functions on arrays and counts (no store, no UI).

**Pairwise, active** (in the spirit of ASAP: Mikhailiuk, Wilmot, Perez-Ortiz, Yue, Mantiuk,
"Active sampling for pairwise comparisons via approximate message passing and information
gain maximization", ICPR 2020; this is an independent implementation). Each item (object
and view) has its own scale of the M methods, with an independent Gaussian posterior per
method, ``N(mu[item, m], var[item, m])`` in JOD units (:data:`SIGMA_JOD`: the
Thurstone Case V observer prefers ``i`` to ``j`` with probability ``Phi((s_i - s_j) /
SIGMA_JOD)``). A vote updates the two methods' posteriors by assumed density filtering (the
TrueSkill update: moment matching of the probit likelihood); a "can't tell" takes the mean
of the two outcomes' updated moments (means unchanged when the methods are level,
variances shrink). The expected information gain of showing pair ``(i, j)`` of an item is
``p KL(post_i>j || post) + (1 - p) KL(post_j>i || post)`` with ``p`` the predictive
probability of ``i > j``: the mutual information between the answer and the scale, as ASAP
computes it. :func:`select_pair` picks the largest; :func:`select_batch` keeps several raters
busy: per item, the maximum-gain spanning tree of its comparison graph (ASAP's batch mode:
a minimum spanning tree of ``1 / gain``), the edges of all items pooled and taken by gain,
so no two raters get the same pair.

**Binary, adaptive** (curtailed sampling). An item's majority (``gvf >= 0.5``: good,
docs/FORMATS.md §5) is settled when the votes still to come cannot change it
(:func:`majority_settled`): with ``votes_per_item`` the usual quota, an item stops being asked
once its quota's majority is settled; the votes it frees go to the items whose GVF is most
uncertain (:func:`gvf_uncertainty`: the posterior probability, under a uniform prior, that
P(good) is on the other side of 0.5 than the current majority) up to ``max_votes_per_item``
(:func:`next_binary_items`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import betainc, log_ndtr, ndtri

__all__ = ["SIGMA_JOD", "PairPosterior", "pair_posterior", "update_pairwise", "posterior_from_votes", "pair_gain",
           "select_pair", "select_batch", "majority_settled", "binary_closed", "gvf_uncertainty",
           "next_binary_items"]

#: Standard deviation of the Thurstone Case V observer in JOD units: Phi(1 / SIGMA_JOD) = 0.75
#: (1 JOD: 75% prefer the better condition). Defined here, the earlier layer; analysis.stats.jod uses it.
SIGMA_JOD = float(1.0 / ndtri(0.75))
_SQRT2PI = np.sqrt(2.0 * np.pi)


@dataclass(frozen=True)
class PairPosterior:
    """Gaussian posterior of each item's method scale (JOD units).

    Attributes
    ----------
    mu : (I, M) float64
        Posterior means.
    var : (I, M) float64
        Posterior variances.
    """

    mu: np.ndarray
    var: np.ndarray


def pair_posterior(n_items: int, n_methods: int, *, prior_sd: float = 1.5) -> PairPosterior:
    """The prior: every method of every item ``N(0, prior_sd**2)``.

    Parameters
    ----------
    n_items, n_methods : int
        Items I and methods M.
    prior_sd : float, optional
        Prior standard deviation in JOD.

    Returns
    -------
    PairPosterior
    """
    return PairPosterior(np.zeros((n_items, n_methods)), np.full((n_items, n_methods), prior_sd ** 2))


def _adf(mu_w, mu_l, v_w, v_l):
    """Moments after observing 'w beats l' (arrays broadcast): (mu_w, mu_l, v_w, v_l)."""
    c2 = SIGMA_JOD ** 2 + v_w + v_l
    c = np.sqrt(c2)
    t = (mu_w - mu_l) / c
    lam = np.exp(-0.5 * t * t - log_ndtr(t)) / _SQRT2PI        # phi(t) / Phi(t)
    w = lam * (lam + t)
    return (mu_w + v_w / c * lam, mu_l - v_l / c * lam,
            v_w * (1.0 - v_w / c2 * w), v_l * (1.0 - v_l / c2 * w))


def update_pairwise(post: PairPosterior, item: int, a: int, b: int, score: float) -> PairPosterior:
    """The posterior after one vote (a new object; ``post`` is left as it is).

    Parameters
    ----------
    post : PairPosterior
        The current posterior.
    item : int
        The item voted on.
    a, b : int
        The two methods shown.
    score : float
        1 when ``a`` won, 0 when ``b`` won, 0.5 for "can't tell".

    Returns
    -------
    PairPosterior
    """
    mu, var = post.mu.copy(), post.var.copy()
    ma, mb, va, vb = mu[item, a], mu[item, b], var[item, a], var[item, b]
    wa = _adf(ma, mb, va, vb)           # a won
    wb = _adf(mb, ma, vb, va)           # b won
    if score == 1.0:
        new = (wa[0], wa[1], wa[2], wa[3])
    elif score == 0.0:
        new = (wb[1], wb[0], wb[3], wb[2])
    else:
        new = ((wa[0] + wb[1]) / 2, (wa[1] + wb[0]) / 2, (wa[2] + wb[3]) / 2, (wa[3] + wb[2]) / 2)
    mu[item, a], mu[item, b], var[item, a], var[item, b] = new
    return PairPosterior(mu, var)


def posterior_from_votes(n_items: int, n_methods: int, votes, *, prior_sd: float = 1.5) -> PairPosterior:
    """The posterior after replaying ``votes`` in order from the prior.

    Parameters
    ----------
    n_items, n_methods : int
        Items I and methods M.
    votes : iterable of (item, a, b, score)
        Codes of each vote and its score (1: a won, 0: b won, 0.5: can't tell).
    prior_sd : float, optional
        Prior standard deviation in JOD.

    Returns
    -------
    PairPosterior
    """
    post = pair_posterior(n_items, n_methods, prior_sd=prior_sd)
    for item, a, b, score in votes:
        post = update_pairwise(post, int(item), int(a), int(b), float(score))
    return post


def _pairs(m: int) -> tuple[np.ndarray, np.ndarray]:
    return np.triu_indices(m, 1)


def _kl(mu1, v1, mu0, v0):
    """KL(N(mu1, v1) || N(mu0, v0)), elementwise."""
    return 0.5 * (np.log(v0 / v1) + (v1 + (mu1 - mu0) ** 2) / v0 - 1.0)


def pair_gain(post: PairPosterior) -> np.ndarray:
    """Expected information gain of one more vote on each item and pair of methods.

    Parameters
    ----------
    post : PairPosterior
        The current posterior (I items, M methods).

    Returns
    -------
    (I, P) float64
        Gain in nats; pairs ``P = M (M - 1) / 2`` in the order of ``numpy.triu_indices(M, 1)``.
    """
    i, j = _pairs(post.mu.shape[1])
    mi, mj, vi, vj = post.mu[:, i], post.mu[:, j], post.var[:, i], post.var[:, j]
    p = np.exp(log_ndtr((mi - mj) / np.sqrt(SIGMA_JOD ** 2 + vi + vj)))
    a = _adf(mi, mj, vi, vj)
    b = _adf(mj, mi, vj, vi)
    kl_a = _kl(a[0], a[2], mi, vi) + _kl(a[1], a[3], mj, vj)
    kl_b = _kl(b[1], b[3], mi, vi) + _kl(b[0], b[2], mj, vj)
    return p * kl_a + (1.0 - p) * kl_b


def select_pair(post: PairPosterior, *, allowed: np.ndarray | None = None) -> tuple[int, int, int]:
    """The item and pair with the largest expected information gain.

    Parameters
    ----------
    post : PairPosterior
        The current posterior.
    allowed : (I, P) bool, optional
        Candidates (default: all); e.g. the pairs a rater has not seen.

    Returns
    -------
    (item, a, b) : tuple of int
        ``a < b``; ``(-1, -1, -1)`` when no candidate is allowed.
    """
    g = pair_gain(post)
    if allowed is not None:
        g = np.where(allowed, g, -np.inf)
    k = int(np.argmax(g))
    if not np.isfinite(g.flat[k]):
        return -1, -1, -1
    item, pair = divmod(k, g.shape[1])
    i, j = _pairs(post.mu.shape[1])
    return item, int(i[pair]), int(j[pair])


def _max_spanning_edges(gain: np.ndarray, m: int) -> list[int]:
    """Pair indices (triu order) of the maximum-gain spanning tree of one item (Prim)."""
    i, j = _pairs(m)
    w = np.full((m, m), -np.inf)
    w[i, j] = w[j, i] = gain
    pair_of = np.zeros((m, m), dtype=int)
    pair_of[i, j] = pair_of[j, i] = np.arange(len(i))
    inside = np.zeros(m, dtype=bool)
    inside[0] = True
    best, parent = w[0].copy(), np.zeros(m, dtype=int)
    edges = []
    for _ in range(m - 1):
        cand = np.where(inside, -np.inf, best)
        v = int(np.argmax(cand))
        if not np.isfinite(cand[v]):
            break
        edges.append(int(pair_of[parent[v], v]))
        inside[v] = True
        better = (w[v] > best) & ~inside
        best[better], parent[better] = w[v][better], v
    return edges


def select_batch(post: PairPosterior, k: int, *, allowed: np.ndarray | None = None,
                 rng: np.random.Generator | None = None) -> list[tuple[int, int, int]]:
    """``k`` different (item, pair) comparisons for ``k`` raters at once (ASAP's batch mode).

    Per item, the spanning tree of its comparison graph that maximises the summed gain (the
    minimum spanning tree of ``1 / gain``); the trees' edges of all items are pooled and the
    ``k`` with the largest gain are returned, largest first.

    Parameters
    ----------
    post : PairPosterior
        The current posterior.
    k : int
        Comparisons wanted.
    allowed : (I, P) bool, optional
        Candidates (default: all).
    rng : numpy.random.Generator, optional
        Breaks ties between equal gains at random (a relative jitter of 1e-9); without it the
        lowest indices win, and an item's first tree is a star around method 0.

    Returns
    -------
    list of (item, a, b)
        At most ``k`` distinct comparisons, ``a < b``; fewer when fewer are allowed.
    """
    g = pair_gain(post)
    if rng is not None:
        g = g * (1.0 + 1e-9 * rng.random(g.shape))
    if allowed is not None:
        g = np.where(allowed, g, -np.inf)
    m = post.mu.shape[1]
    i, j = _pairs(m)
    # only items that could supply one of the k best edges need a tree
    top = np.argsort(-g.max(axis=1), kind="stable")[:k]
    pool = [(g[it, e], int(it), e) for it in top for e in _max_spanning_edges(g[it], m)
            if np.isfinite(g[it, e])]
    pool.sort(key=lambda t: -t[0])
    return [(it, int(i[e]), int(j[e])) for _, it, e in pool[:k]]


# --- binary design -------------------------------------------------------------------------

def majority_settled(good, bad, max_votes) -> np.ndarray:
    """Whether an item's majority (``gvf >= 0.5``: good) can no longer change when it gets at
    most ``max_votes`` votes.

    Parameters
    ----------
    good, bad : (N,) int
        Votes so far.
    max_votes : int or (N,) int
        The most votes the item will get.

    Returns
    -------
    (N,) bool

    >>> majority_settled(np.array([3, 2, 0, 2]), np.array([0, 2, 3, 3]), 5).tolist()
    [True, False, True, True]
    """
    good, bad = np.asarray(good), np.asarray(bad)
    left = np.maximum(np.asarray(max_votes) - good - bad, 0)
    return (good >= bad + left) | (bad > good + left)


def gvf_uncertainty(good, bad) -> np.ndarray:
    """The posterior probability that the item's P(good) lies on the other side of 0.5 than
    its current majority: ``min(P, 1 - P)`` with ``P = P(p >= 0.5 | Beta(1 + good, 1 + bad))``.

    Parameters
    ----------
    good, bad : (N,) int
        Votes so far.

    Returns
    -------
    (N,) float64
        In [0, 0.5]; 0.5 for an item without votes.

    >>> gvf_uncertainty(np.array([0, 1, 2]), np.array([0, 0, 0])).round(4).tolist()
    [0.5, 0.25, 0.125]
    """
    good, bad = np.asarray(good, dtype=float), np.asarray(bad, dtype=float)
    p = betainc(1.0 + bad, 1.0 + good, 0.5)        # P(p >= 0.5) for p ~ Beta(1 + good, 1 + bad)
    return np.minimum(p, 1.0 - p)


def binary_closed(good, bad, *, votes_per_item: int, max_votes_per_item: int) -> np.ndarray:
    """Items adaptive sampling asks no more about: the majority over ``votes_per_item`` votes
    was settled before the item got them all (curtailed), the majority is settled over
    ``max_votes_per_item``, or the item has ``max_votes_per_item`` votes.

    Parameters
    ----------
    good, bad : (N,) int
        Test votes so far per item.
    votes_per_item : int
        The usual quota per item.
    max_votes_per_item : int
        The most votes an item may get.

    Returns
    -------
    (N,) bool

    >>> binary_closed(np.array([3, 2, 3]), np.array([0, 1, 2]), votes_per_item=5,
    ...               max_votes_per_item=7).tolist()
    [True, False, False]
    """
    good, bad = np.asarray(good), np.asarray(bad)
    n = good + bad
    curtailed = majority_settled(good, bad, votes_per_item) & (n < votes_per_item)
    return curtailed | majority_settled(good, bad, max_votes_per_item) | (n >= max_votes_per_item)


def next_binary_items(good, bad, *, votes_per_item: int, max_votes_per_item: int, k: int = 1) -> np.ndarray:
    """The ``k`` items that should get the next votes under adaptive sampling (module docstring).

    The items :func:`binary_closed` closes get no more votes (an item whose quota ended close
    stays open); among the open items, the most uncertain GVF first (:func:`gvf_uncertainty`),
    then the fewest votes, then the lowest index.

    Parameters
    ----------
    good, bad : (N,) int
        Test votes so far per item.
    votes_per_item : int
        The usual quota per item.
    max_votes_per_item : int
        The most votes an item may get (>= ``votes_per_item``).
    k : int, optional
        Items wanted (different items).

    Returns
    -------
    (<= k,) int64
        Item indices, best first; empty when every item is closed.
    """
    good, bad = np.asarray(good), np.asarray(bad)
    n = good + bad
    closed = binary_closed(good, bad, votes_per_item=votes_per_item, max_votes_per_item=max_votes_per_item)
    open_ = np.flatnonzero(~closed)
    if open_.size == 0:
        return open_.astype(np.int64)
    u = gvf_uncertainty(good[open_], bad[open_])
    order = np.lexsort((open_, n[open_], -u))
    return open_[order[:k]].astype(np.int64)
