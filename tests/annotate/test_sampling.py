"""Sampling designs (annotate/sampling.py): against quadrature, brute force and SciPy."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.sparse.csgraph import minimum_spanning_tree
from scipy.stats import beta, norm

from analysis.stats.jod import SIGMA_JOD
from annotate.sampling import (
    PairPosterior,
    gvf_uncertainty,
    majority_settled,
    next_binary_items,
    pair_gain,
    pair_posterior,
    posterior_from_votes,
    select_batch,
    select_pair,
    update_pairwise,
)


def _grid_posterior(mu, var, won: bool):
    """Exact moments of N(mu, diag(var)) x Phi(+-(s_a - s_b) / SIGMA_JOD) by 2-D quadrature."""
    sa = np.linspace(mu[0] - 8 * np.sqrt(var[0]), mu[0] + 8 * np.sqrt(var[0]), 801)
    sb = np.linspace(mu[1] - 8 * np.sqrt(var[1]), mu[1] + 8 * np.sqrt(var[1]), 801)
    a, b = np.meshgrid(sa, sb, indexing="ij")
    w = norm.pdf(a, mu[0], np.sqrt(var[0])) * norm.pdf(b, mu[1], np.sqrt(var[1]))
    w = w * norm.cdf((a - b) / SIGMA_JOD * (1 if won else -1))
    w /= w.sum()
    ma, mb = (w * a).sum(), (w * b).sum()
    return np.array([ma, mb]), np.array([(w * (a - ma) ** 2).sum(), (w * (b - mb) ** 2).sum()])


@pytest.mark.parametrize("score", [1.0, 0.0])
def test_update_matches_exact_moments(score):
    post = PairPosterior(np.array([[0.3, -0.4, 0.0]]), np.array([[1.2, 0.7, 2.0]]))
    new = update_pairwise(post, 0, 0, 1, score)
    mu, var = _grid_posterior([0.3, -0.4], [1.2, 0.7], won=score == 1.0)
    np.testing.assert_allclose(new.mu[0, :2], mu, atol=1e-4)
    np.testing.assert_allclose(new.var[0, :2], var, atol=1e-4)
    assert new.mu[0, 2] == 0.0 and new.var[0, 2] == 2.0      # other methods untouched
    assert post.mu[0, 0] == 0.3                              # the input is left as it was


def test_gain_is_the_expected_kl_of_the_exact_updates():
    mu, var = np.array([0.3, -0.4]), np.array([1.2, 0.7])
    post = PairPosterior(mu[None], var[None])
    p = norm.cdf((mu[0] - mu[1]) / np.sqrt(SIGMA_JOD ** 2 + var.sum()))   # predictive P(a wins)

    def kl(m1, v1):
        return (0.5 * (np.log(var / v1) + (v1 + (m1 - mu) ** 2) / var - 1)).sum()

    want = p * kl(*_grid_posterior(mu, var, True)) + (1 - p) * kl(*_grid_posterior(mu, var, False))
    assert pair_gain(post)[0, 0] == pytest.approx(want, rel=1e-3)


def test_gain_prefers_close_and_uncertain_pairs():
    post = PairPosterior(np.array([[0.0, 0.1, 5.0]]), np.full((1, 3), 0.5))
    g = pair_gain(post)[0]           # pairs (0,1), (0,2), (1,2)
    assert g[0] > g[1] and g[0] > g[2]
    assert select_pair(post) == (0, 0, 1)


def test_votes_move_the_posterior_and_ties_keep_level_means():
    post = posterior_from_votes(2, 3, [(1, 0, 2, 1.0), (1, 0, 2, 1.0)])
    assert post.mu[1, 0] > 0 > post.mu[1, 2] and (post.var[1, [0, 2]] < 2.25).all()
    assert (post.mu[0] == 0).all()
    tie = update_pairwise(pair_posterior(1, 2), 0, 0, 1, 0.5)
    assert (tie.mu == 0).all() and (tie.var < 2.25).all()


def test_batch_is_distinct_and_a_spanning_tree_per_item():
    rng = np.random.default_rng(0)
    post = PairPosterior(rng.normal(0, 1, (3, 5)), rng.uniform(0.2, 2.0, (3, 5)))
    batch = select_batch(post, 6)
    assert len(set(batch)) == 6
    allowed = np.zeros((3, 10), dtype=bool)
    allowed[1] = True                      # one item: its tree, 4 edges
    tree = select_batch(post, 10, allowed=allowed)
    g = pair_gain(post)[1]
    i, j = np.triu_indices(5, 1)
    w = np.zeros((5, 5))
    w[i, j] = 1.0 / g                      # ASAP: minimum spanning tree of 1 / gain (SciPy's)
    mst = minimum_spanning_tree(w).toarray()
    assert {(a, b) for _, a, b in tree} == {(int(min(a, b)), int(max(a, b))) for a, b in zip(*np.nonzero(mst), strict=True)}
    assert all(it == 1 for it, _, _ in tree)


def test_majority_settled_matches_brute_force():
    for cap in (4, 5):
        for good in range(cap + 1):
            for bad in range(cap + 1 - good):
                left = cap - good - bad
                finals = {good + g >= bad + (left - g) for g in range(left + 1)}   # gvf >= 0.5
                assert majority_settled(np.array([good]), np.array([bad]), cap)[0] == (len(finals) == 1)


def test_gvf_uncertainty_is_the_beta_tail():
    g, b = np.array([0, 3, 2, 7]), np.array([0, 1, 2, 2])
    p = beta.sf(0.5, 1 + g, 1 + b)
    np.testing.assert_allclose(gvf_uncertainty(g, b), np.minimum(p, 1 - p))


def test_adaptive_order_curtails_and_reallocates():
    good = np.array([3, 0, 2, 3, 1, 4])
    bad = np.array([0, 0, 2, 2, 0, 4])
    nxt = next_binary_items(good, bad, votes_per_item=5, max_votes_per_item=9, k=6)
    # item 0 (3:0) is curtailed; 5 (4:4) is settled over 9? no: 1 vote left, 4:4 + good = good, + bad = bad
    assert 0 not in nxt
    assert nxt[0] == 1 and set(nxt) == {1, 2, 3, 4, 5}      # no votes: most uncertain first
    assert list(nxt[1:3]) == [2, 5] or list(nxt[1:3]) == [5, 2]  # level items next
    assert next_binary_items(good, bad, votes_per_item=5, max_votes_per_item=5, k=6).tolist() == [1, 2, 4]
    every = list(itertools.product(range(4), range(4)))
    full = next_binary_items(np.array([g for g, _ in every]), np.array([b for _, b in every]),
                             votes_per_item=3, max_votes_per_item=3, k=99)
    assert all(not majority_settled(np.array([every[k][0]]), np.array([every[k][1]]), 3)[0] for k in full)
