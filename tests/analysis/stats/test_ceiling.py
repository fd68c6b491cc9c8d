"""Noise ceiling: hand-worked split half, Spearman-Brown, identical raters."""

import numpy as np
import pytest

from analysis.stats.ceiling import noise_ceiling, spearman_brown, split_half


def test_split_half_hand_worked():
    # 4 items x 4 raters; halves {r0, r1} and {r2, r3}
    m = np.array([[1, 1, 1, 1], [1, 1, 0, 0], [0, 0, 0, 0], [1, 0, 1, 0.0]])
    # half GVFs: a = (1, 1, 0, .5), b = (1, 0, 0, .5); deviations from means .625 / .375:
    # sum of products .3125, sums of squares .6875 each -> r = .3125 / .6875 = 5/11
    d = split_half(m, np.array([True, True, False, False]))
    assert d["pearson"] == pytest.approx(5 / 11) and d["n"] == 4
    # ranks a = (3.5, 3.5, 1, 2), b = (4, 1.5, 1.5, 3): deviations (1, 1, -1.5, -.5) and
    # (1.5, -1, -1, .5), products 1.75, squares 4.5 each -> 1.75 / 4.5 = 7/18
    assert d["spearman"] == pytest.approx(7 / 18)
    # Spearman-Brown: 2 r / (1 + r) = (10/11) / (16/11) = 0.625
    assert spearman_brown(5 / 11) == pytest.approx(0.625)


def test_identical_raters_give_ceiling_one():
    rng = np.random.default_rng(0)
    col = (rng.random(40) < 0.5).astype(float)
    m = np.repeat(col[:, None], 6, axis=1)
    c = noise_ceiling(m, n_splits=10, n_boot=20)
    assert c["reliability"] == pytest.approx(1.0) and c["plcc_ceiling"] == pytest.approx(1.0)
    assert c["srcc_ceiling"] == pytest.approx(1.0) and c["reason"] is None


def test_random_raters_give_low_ceiling_and_undefined_case():
    rng = np.random.default_rng(1)
    m = (rng.random((200, 6)) < 0.5).astype(float)
    c = noise_ceiling(m, n_splits=10, n_boot=20)
    assert abs(c["reliability"]) < 0.3 and c["reliability_ci_lo"] <= c["reliability_ci_hi"]
    assert noise_ceiling(m[:, :1])["reason"] == "needs >= 2 raters and >= 3 items"


def _direct_interval(mat, seed, n_boot):
    """The bootstrap interval computed the straightforward way: every split of 5 raters into
    halves of 2 and 3 (C(5, 2) = 10 <= 20 splits, so no random splits), then per replicate the
    items resampled as rows ``mat[draw]`` and every split recomputed from scratch."""
    import itertools

    from analysis.stats import stats

    n_items, n_r = mat.shape
    halves = [np.isin(np.arange(n_r), c) for c in itertools.combinations(range(n_r), n_r // 2)]
    rng = np.random.default_rng(seed)
    boot = []
    for _ in range(n_boot):
        m = mat[rng.integers(0, n_items, n_items)]
        rels = []
        for h in halves:
            has = np.isfinite(m)
            both = has[:, h].any(1) & has[:, ~h].any(1)
            ga = np.nansum(m[both][:, h], 1) / has[both][:, h].sum(1)
            gb = np.nansum(m[both][:, ~h], 1) / has[both][:, ~h].sum(1)
            r = stats.pearson(ga, gb)[0]
            rels.append(2 * r / (1 + r))
        boot.append(np.nanmean(rels) if np.isfinite(rels).any() else np.nan)
    return np.nanpercentile(boot, [2.5, 97.5])


@pytest.mark.parametrize("missing", [0.0, 0.3])
def test_columnar_bootstrap_equals_resampling_the_rows(missing):
    # the interval comes from counts of resampled items per distinct pair of half GVFs
    # (weighted Pearson, one sparse product per replicate): the same numbers as resampling rows
    rng = np.random.default_rng(3)
    m = (rng.random((120, 5)) < rng.random(120)[:, None]).astype(float)
    m[rng.random(m.shape) < missing] = np.nan
    c = noise_ceiling(m, n_boot=60, seed=11)
    lo, hi = _direct_interval(m, 11, 60)
    assert c["reliability_ci_lo"] == pytest.approx(lo, abs=1e-12)
    assert c["reliability_ci_hi"] == pytest.approx(hi, abs=1e-12)
    assert lo < c["reliability"] < hi
